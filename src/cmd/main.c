/* refrender: command line, progress and orchestration only. */
#include <getopt.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cmd/cli.h"
#include "cmd/commands.h"
#include "cmd/noise_report.h"
#include "render/exact.h"
#include "io/output.h"
#include "io/render_attrs.h"
#include "io/preview.h"
#include "scenexml/scene_xml.h"

#ifndef RR_SOURCE_SCENE
#define RR_SOURCE_SCENE "scenes/default.xml"
#endif

static volatile sig_atomic_t interrupted = 0;
static void on_signal(int sig) { (void)sig; interrupted = 1; }

static void usage(FILE *f)
{
    fputs(
"usage: refrender [options] [SCENE.xml]\n"
"       refrender merge STATE.exr [STATE.exr ...] -o OUT.exr   (see 'refrender merge --help')\n"
"       refrender gen SHAPE [options] -o FILE.ply              (see 'refrender gen --help')\n"
"       refrender surfels MESH|CLOUD [options] -o FILE.ply     (see 'refrender surfels --help')\n"
"       refrender export SCENE.xml [options] -o SCENE.json     (see 'refrender export --help')\n"
"       refrender splat METHOD SCENE.xml [options] -o OUT.exr  (the thesis's splatting; 'refrender splat --help')\n"
"\n"
"Renders a ground-truth motion-blurred image of a point-based scene by Monte\n"
"Carlo ray tracing (Wolf 2008, sec. 4.5) into a 32-bit float EXR. Without SCENE\n"
"the bundled scenes/default.xml is rendered. Details of every option: README.md.\n"
"\n"
"Sampling:\n"
"  --spp N            spatial samples per pixel, a KxK grid (default 4)\n"
"  --pixel-filter F   box (default): samples over the pixel; point: at its centre\n"
"  --tspp N           temporal samples per spatial sample (default 100)\n"
"  --sampler S        sobol (default), jittered3d or thesis (Wolf 2008 sec. 4.5)\n"
"  --seed N           random seed: same seed, same image, any threads (default 1)\n"
"  --batches B        independent batches; B >= 2 adds standard errors (default 1)\n"
"  --target-error X   more batches where a pixel's RGB standard error exceeds X, in value\n"
"                     units (0.002) or 8-bit levels (0.5lv); B 4 unless given\n"
"  --max-batches N    batch cap for --target-error (default 8*B)\n"
"Time:\n"
"  --time-integration M  sampled (default) or exact (src/EXACT.md)\n"
"  --time-factor F    thesis sampler: tspp*F time strata (default: scene, else 4)\n"
"  --shutter O,C      shutter interval (frame 0's with <frames>)\n"
"  --frame N          render frame N of a scene with <frames rate>\n"
"  --frames A-B       render frames A to B into -o out.%04d.exr\n"
"  --time T           a sharp image at the instant T (default --tspp 1); a rolling\n"
"                     shutter's lines at T plus their readout offsets\n"
"  --blur-space S     model (default): average colours as given; linear: decode sRGB first;\n"
"                     clamped: clamp each instant to [0, 1] (as SpacetimeGaussians scores)\n"
"Output:\n"
"  -o, --output F     output EXR (default render.exr), written atomically\n"
"  --preview F        also an 8-bit sRGB preview (PNG, by extension)\n"
"  --crop-window X0,X1,Y0,Y1  only this fraction of the image (pbrt's rounding)\n"
"Distributed and long renders:\n"
"  --pass K/N         render batches [K*B/N, (K+1)*B/N) as a state for 'merge'\n"
"  --checkpoint F     write the render state to F periodically and on SIGINT/SIGTERM\n"
"  --checkpoint-every S  seconds between checkpoints (default 60; 0: only when interrupted)\n"
"  --resume F         continue the render state F (same scene and settings)\n"
"Scene overrides:\n"
"  --res WxH          image size\n"
"  --eps X            epsilon-blending distance, world units (default: scene, else 0.01)\n"
"  --sigma X          kernel sigma in splat radii (default: scene, else 0.5)\n"
"  -D name=value      scene parameter: replaces $name in attribute values (repeatable)\n"
"Running:\n"
"  --threads N        render threads (default: all cores)\n"
"  --quiet            no progress bar and no summary line (warnings still)\n"
"  --progress-every S  a progress line every S seconds, also into a log (no terminal)\n"
"  --no-static-reuse  trace every time sample on its own (same image; for benchmarks)\n"
"  --version, -h, --help\n"
"\n"
"Exit status: 0 success, 1 bad input or render error, 2 usage error, 130\n"
"interrupted (no output is written; a checkpoint is, if asked).\n", f);
}

typedef struct {
    int spp, tspp, time_factor, threads, quiet, width, height, batches, max_batches;
    int pass, passes; /* passes > 0: --pass pass/passes */
    int no_static_reuse;
    int exact_time, tspp_given, batches_given; /* --time-integration exact; --target-error's B */
    int shutter_set;                            /* --shutter OPEN,CLOSE */
    int instant_set;                            /* --time T */
    double instant;
    pixel_filter filter;                        /* --pixel-filter */
    blur_space blur;                            /* --blur-space */
    scene_params params;                        /* -D name=value */
    int crop_set;                               /* --crop-window X0,X1,Y0,Y1 (fractions) */
    double crop[4];
    double shutter_open, shutter_close;
    int frames, first_frame, last_frame; /* frames: 0 none, 1 --frame, 2 --frames */
    sampler_kind sampler;
    double eps, sigma, target_error, checkpoint_every; /* eps, sigma < 0: from the scene */
    double progress_every;                      /* --progress-every S; 0: a bar on a terminal only */
    uint64_t seed;
    const char *scene, *output, *preview, *checkpoint, *resume;
} render_options;

enum { OPT_SPP = 256, OPT_TSPP, OPT_RES, OPT_THREADS, OPT_SEED, OPT_EPS, OPT_SIGMA, OPT_TFACTOR,
       OPT_PREVIEW, OPT_QUIET, OPT_VERSION, OPT_SAMPLER, OPT_BATCHES, OPT_TARGET, OPT_MAXB, OPT_PASS,
       OPT_CKPT, OPT_CKPT_EVERY, OPT_RESUME, OPT_NO_REUSE, OPT_FRAME, OPT_FRAMES,
       OPT_TIME_INTEGRATION, OPT_SHUTTER, OPT_CROP, OPT_TIME, OPT_PIXEL_FILTER, OPT_BLUR_SPACE,
       OPT_PROGRESS_EVERY };

static int parse_pass(const char *arg, render_options *o, rr_error *err)
{
    char extra;
    if (sscanf(arg, "%d/%d%c", &o->pass, &o->passes, &extra) != 2 || o->passes < 1 || o->pass < 0 ||
        o->pass >= o->passes)
        return rr_fail(err, "--pass: expected K/N with 0 <= K < N, got '%s'", arg);
    return 0;
}

static int parse_frames(const char *arg, render_options *o, rr_error *err)
{
    char extra;
    if (sscanf(arg, "%d-%d%c", &o->first_frame, &o->last_frame, &extra) != 2 || o->last_frame < o->first_frame)
        return rr_fail(err, "--frames: expected A-B with A <= B, got '%s'", arg);
    o->frames = 2;
    return 0;
}

static int parse_option(int c, const char *arg, render_options *o, rr_error *err)
{
    switch (c) {
    case OPT_SPP: return cli_int("--spp", arg, 1, 4096, &o->spp, err);
    case OPT_TSPP: o->tspp_given = 1; return cli_int("--tspp", arg, 1, 1000000, &o->tspp, err);
    case OPT_TFACTOR: return cli_int("--time-factor", arg, 1, 1024, &o->time_factor, err);
    case OPT_RES: return cli_resolution("--res", arg, &o->width, &o->height, err);
    case OPT_THREADS: return cli_int("--threads", arg, 1, 1024, &o->threads, err);
    case OPT_SEED: return cli_u64("--seed", arg, &o->seed, err);
    case OPT_EPS: return cli_double("--eps", arg, 0.0, &o->eps, err);
    case OPT_SIGMA: return cli_double("--sigma", arg, 1e-6, &o->sigma, err);
    case OPT_BATCHES: o->batches_given = 1; return cli_int("--batches", arg, 1, FILM_MAX_BATCHES, &o->batches, err);
    case OPT_MAXB: return cli_int("--max-batches", arg, 1, FILM_MAX_BATCHES, &o->max_batches, err);
    case OPT_TARGET: return noise_parse_target(arg, &o->target_error, err);
    case OPT_CKPT_EVERY: return cli_double("--checkpoint-every", arg, 0.0, &o->checkpoint_every, err);
    case OPT_PROGRESS_EVERY: return cli_double("--progress-every", arg, 0.0, &o->progress_every, err);
    case OPT_PASS: return parse_pass(arg, o, err);
    case OPT_FRAMES: return parse_frames(arg, o, err);
    case OPT_FRAME:
        o->frames = 1;
        if (cli_int("--frame", arg, INT_MIN, INT_MAX, &o->first_frame, err))
            return -1;
        o->last_frame = o->first_frame;
        return 0;
    case OPT_SHUTTER:
        o->shutter_set = 1;
        return cli_shutter(arg, &o->shutter_open, &o->shutter_close, err);
    case OPT_CROP: {
        char extra;
        double *c = o->crop;
        if (sscanf(arg, "%lf,%lf,%lf,%lf%c", &c[0], &c[1], &c[2], &c[3], &extra) != 4 || !(c[0] >= 0 && c[1] <= 1 &&
            c[0] < c[1] && c[2] >= 0 && c[3] <= 1 && c[2] < c[3]))
            return rr_fail(err, "--crop-window: expected X0,X1,Y0,Y1 with 0 <= X0 < X1 <= 1 and 0 <= Y0 < Y1 <= 1, "
                                "got '%s'", arg);
        o->crop_set = 1;
        return 0;
    }
    case OPT_TIME:
        o->instant_set = 1;
        return cli_double("--time", arg, -INFINITY, &o->instant, err);
    case OPT_PIXEL_FILTER:
        if (strcmp(arg, "box") && strcmp(arg, "point"))
            return rr_fail(err, "--pixel-filter: expected box or point, got '%s'", arg);
        o->filter = strcmp(arg, "point") ? PIXEL_FILTER_BOX : PIXEL_FILTER_POINT;
        return 0;
    case OPT_BLUR_SPACE:
        for (blur_space b = BLUR_SPACE_MODEL; b <= BLUR_SPACE_CLAMPED; b++)
            if (!strcmp(arg, blur_space_name(b)))
                return o->blur = b, 0;
        return rr_fail(err, "--blur-space: expected model, linear or clamped, got '%s'", arg);
    case OPT_TIME_INTEGRATION:
        if (strcmp(arg, "sampled") && strcmp(arg, "exact"))
            return rr_fail(err, "--time-integration: expected sampled or exact, got '%s'", arg);
        o->exact_time = !strcmp(arg, "exact");
        return 0;
    case OPT_SAMPLER:
        return sampler_from_name(arg, &o->sampler)
                   ? rr_fail(err, "--sampler: expected sobol, jittered3d or thesis, got '%s'", arg) : 0;
    case 'o': o->output = arg; return 0;
    case 'D': return scene_params_add(&o->params, arg, err);
    case OPT_PREVIEW: o->preview = arg; return 0;
    case OPT_CKPT: o->checkpoint = arg; return 0;
    case OPT_RESUME: o->resume = arg; return 0;
    case OPT_QUIET: o->quiet = 1; return 0;
    case OPT_NO_REUSE: o->no_static_reuse = 1; return 0;
    }
    return rr_fail(err, "unknown option");
}

static int check_combinations(const render_options *o, rr_error *err)
{
    if (o->crop_set && (o->passes || o->checkpoint || o->resume))
        return rr_fail(err, "--crop-window renders a final image only: it cannot be combined with --pass, "
                            "--checkpoint or --resume");
    if (o->exact_time && o->tspp_given && o->tspp != 1)
        return rr_fail(err, "--tspp %d: with --time-integration exact each spatial sample is integrated over "
                            "the whole shutter (no time samples); leave --tspp out", o->tspp);
    if (o->instant_set && (o->shutter_set || o->frames || o->exact_time))
        return rr_fail(err, "--time renders one instant: it cannot be combined with --shutter, --frame(s) or "
                            "--time-integration exact");
    if (render_check_exact_blur(o->exact_time, o->blur, err))
        return -1;
    if (o->passes && o->batches < o->passes)
        return rr_fail(err, "--pass %d/%d needs --batches >= %d (each pass renders whole batches)",
                       o->pass, o->passes, o->passes);
    if (o->passes && o->target_error > 0)
        return rr_fail(err, "--pass and --target-error cannot be combined");
    if (o->target_error > 0 && o->batches < 2)
        return rr_fail(err, "--target-error needs --batches >= 2 to estimate the error");
    if (o->max_batches && o->max_batches < o->batches)
        return rr_fail(err, "--max-batches %d must be at least the %d batches every pixel takes first%s", o->max_batches,
                       o->batches, o->batches_given ? "" : " (--target-error alone takes 4)");
    if (o->passes && o->preview)
        return rr_fail(err, "--preview is not available for --pass renders (refrender merge --preview writes it)");
    if (o->frames == 2 && (o->passes || o->checkpoint || o->resume))
        return rr_fail(err, "--frames renders whole frames: render each frame with --frame to use "
                            "--pass, --checkpoint or --resume");
    /* only a sequence needs a frame field; elsewhere a '%' is a literal one */
    if (o->frames == 2 && (!cli_frame_pattern_ok(o->output) || (o->preview && !cli_frame_pattern_ok(o->preview))))
        return rr_fail(err, "--frames needs -o (and --preview) with one frame-number field such as %%04d, "
                            "e.g. out.%%04d.exr");
    return 0;
}

/* Returns 0 to go on, 1 for a clean exit (help, version), 2 on usage error. */
static int parse_args(int argc, char **argv, render_options *o)
{
    static const struct option longopts[] = {
        {"spp", required_argument, 0, OPT_SPP}, {"tspp", required_argument, 0, OPT_TSPP},
        {"time-factor", required_argument, 0, OPT_TFACTOR}, {"res", required_argument, 0, OPT_RES},
        {"threads", required_argument, 0, OPT_THREADS}, {"seed", required_argument, 0, OPT_SEED},
        {"eps", required_argument, 0, OPT_EPS}, {"sigma", required_argument, 0, OPT_SIGMA},
        {"sampler", required_argument, 0, OPT_SAMPLER}, {"batches", required_argument, 0, OPT_BATCHES},
        {"target-error", required_argument, 0, OPT_TARGET}, {"max-batches", required_argument, 0, OPT_MAXB},
        {"pass", required_argument, 0, OPT_PASS}, {"checkpoint", required_argument, 0, OPT_CKPT},
        {"checkpoint-every", required_argument, 0, OPT_CKPT_EVERY}, {"resume", required_argument, 0, OPT_RESUME},
        {"output", required_argument, 0, 'o'}, {"preview", required_argument, 0, OPT_PREVIEW},
        {"quiet", no_argument, 0, OPT_QUIET}, {"version", no_argument, 0, OPT_VERSION},
        {"no-static-reuse", no_argument, 0, OPT_NO_REUSE}, {"frame", required_argument, 0, OPT_FRAME},
        {"frames", required_argument, 0, OPT_FRAMES},
        {"time-integration", required_argument, 0, OPT_TIME_INTEGRATION},
        {"shutter", required_argument, 0, OPT_SHUTTER}, {"crop-window", required_argument, 0, OPT_CROP},
        {"time", required_argument, 0, OPT_TIME}, {"pixel-filter", required_argument, 0, OPT_PIXEL_FILTER},
        {"blur-space", required_argument, 0, OPT_BLUR_SPACE},
        {"progress-every", required_argument, 0, OPT_PROGRESS_EVERY},
        {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    int c;
    rr_error err;
    while ((c = getopt_long(argc, argv, "hD:o:", longopts, NULL)) != -1) {
        if (c == 'h') { usage(stdout); return 1; }
        if (c == OPT_VERSION) { printf("refrender %s (build %s)\n", RR_VERSION, render_build_id()); return 1; }
        if (c == '?') {
            cli_suggest_option("refrender", argv[optind - 1], longopts);
            fputs("Try 'refrender --help'.\n", stderr);
            return 2;
        }
        if (parse_option(c, optarg, o, &err)) {
            fprintf(stderr, "refrender: %s\n", err.msg);
            return 2;
        }
    }
    if (optind < argc - 1) {
        fprintf(stderr, "refrender: expected one scene file, got %d arguments\n", argc - optind);
        return 2;
    }
    if (optind == argc - 1)
        o->scene = argv[optind];
    if (o->target_error > 0 && !o->batches_given)
        o->batches = 4; /* an error estimate needs batches (src/SAMPLING.md, Error bars) */
    if (check_combinations(o, &err)) {
        fprintf(stderr, "refrender: %s\n", err.msg);
        return 2;
    }
    return 0;
}

/* The bundled scene: beside the executable's tree first (build/../scenes),
 * then the source tree the binary was built from. */
static const char *default_scene(char *buf, size_t size)
{
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = 0;
        char *slash = strrchr(exe, '/');
        if (slash) {
            *slash = 0;
            snprintf(buf, size, "%s/../scenes/default.xml", exe);
            if (access(buf, R_OK) == 0)
                return buf;
        }
    }
    return RR_SOURCE_SCENE;
}

static void print_progress(void *user, double fraction, uint64_t rays, double seconds)
{
    (void)user;
    int width = 30, filled = (int)(fraction * width);
    double eta = fraction > 0 ? seconds * (1 - fraction) / fraction : 0;
    char bar[64];
    for (int i = 0; i < width; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[width] = 0;
    fprintf(stderr, "\r[%s] %5.1f%%  elapsed %5.1fs  ETA %5.1fs  %6.2f Mrays/s ", bar,
            100 * fraction, seconds, eta, seconds > 0 ? rays / seconds * 1e-6 : 0.0);
    if (fraction >= 1)
        fputc('\n', stderr);
    fflush(stderr);
}

/* The crop window's pixels, pbrt's rounding: indices in [ceil(f0 N),
 * ceil(f1 N)); px = x0, x1, y0, y1. */
static void crop_pixels(const render_options *o, int width, int height, int px[4])
{
    for (int k = 0; k < 4; k++)
        px[k] = (int)ceil(o->crop[k] * (k < 2 ? width : height));
}

static int apply_overrides(scene *s, const render_options *o, rr_error *err)
{
    if (o->width > 0) {
        s->cam.width = o->width;
        s->cam.height = o->height;
    }
    if (o->eps >= 0)
        s->epsilon = o->eps;
    if (o->sigma > 0)
        s->kernel_sigma = o->sigma;
    if (o->time_factor > 0)
        s->time_factor = o->time_factor;
    int px[4];
    crop_pixels(o, s->cam.width, s->cam.height, px);
    if (o->crop_set && (px[1] <= px[0] || px[3] <= px[2]))
        return rr_fail(err, "--crop-window holds no whole pixel of the %dx%d image", s->cam.width, s->cam.height);
    if (o->shutter_set) { /* a(t)'s own parameters (center, table) stay as the scene gives them */
        s->shut.open = o->shutter_open, s->shut.close = o->shutter_close;
        if (shutter_check(&s->shut, err))
            return -1;
    }
    if (o->instant_set) /* every line's exposure an instant; a rolling shutter's lines keep their offsets */
        shutter_at_instant(&s->shut, o->instant);
    rr_error why;
    if (camera_prepare(&s->cam, &why)) /* the scene's camera passed when it loaded: --res changed it */
        return rr_fail(err, "%s with --res %dx%d: %s", s->path, s->cam.width, s->cam.height, why.msg);
    return 0;
}

/* The command line as one string (malloc'd; NULL when out of memory), for
 * refrender:command: as long as the arguments are (a fixed 2 KB buffer once
 * cut it silently; the attribute itself says where it is cut: output.h). */
static char *join_args(int argc, char **argv)
{
    size_t size = 1;
    for (int i = 0; i < argc; i++)
        size += strlen(argv[i]) + 1;
    char *buf = malloc(size);
    if (!buf)
        return NULL;
    size_t len = 0;
    buf[0] = 0;
    for (int i = 0; i < argc; i++)
        len += (size_t)snprintf(buf + len, size - len, "%s%s", i ? " " : "", argv[i]);
    return buf;
}

static void install_signal_handlers(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

typedef struct {
    const render_options *o;
    render_settings rs;
    attr_list attrs;
    uint32_t total_batches;
    double last_progress; /* seconds into the render of the last progress line */
} render_run;

static int write_checkpoint(void *user, const image *img, rr_error *err)
{
    render_run *run = user;
    attrs_set(&run->attrs, ATTR_RENDER_SECONDS, "%.3f", img->seconds);
    attrs_set(&run->attrs, ATTR_RAYS, "%llu", (unsigned long long)img->rays);
    attrs_set(&run->attrs, ATTR_CLAMPED, "%llu", (unsigned long long)img->clamped);
    return output_write_state(run->o->checkpoint, img, run->rs.batch_begin,
                              run->rs.batch_begin + run->rs.batches, &run->attrs, err);
}

static void warn_checkpoint(void *user, const rr_error *err)
{
    (void)user;
    fprintf(stderr, "\nrefrender: warning: checkpoint not written, the previous one is kept; rendering goes on: %s\n",
            err->msg);
}

/* --progress-every without a terminal (a batch job's log): a line at most
 * every S seconds, and the last one. */
static void print_progress_line(void *user, double fraction, uint64_t rays, double seconds)
{
    render_run *run = user;
    if (fraction < 1 && seconds - run->last_progress < run->o->progress_every)
        return;
    run->last_progress = seconds;
    double eta = fraction > 0 ? seconds * (1 - fraction) / fraction : 0;
    fprintf(stderr, "refrender: %5.1f%% after %.1fs, ETA %.1fs, %.2f Mrays/s\n", 100 * fraction, seconds, eta,
            seconds > 0 ? rays / seconds * 1e-6 : 0.0);
    fflush(stderr);
}

/* No pixel of a resumed state may hold more batches than this render gives
 * one: its range, or with --target-error the batch cap. */
static int check_resumable_counts(const render_run *run, image *img, rr_error *err)
{
    uint32_t most = run->rs.target_error > 0 ? run->rs.max_batches : run->rs.batches;
    size_t n = (size_t)img->width * img->height;
    for (size_t i = 0; i < n; i++)
        if (img->px[i].batches > most) {
            rr_fail(err, "%s: pixel (%zu, %zu) holds %u batches, more than the %u this render gives a pixel",
                    run->o->resume, i % (size_t)img->width, i / (size_t)img->width, img->px[i].batches, most);
            image_free(img);
            return -1;
        }
    return 0;
}

/* Loads --resume into img after checking it is this very render. */
static int resume_state(render_run *run, image *img, rr_error *err)
{
    attr_list saved;
    uint32_t begin, end;
    if (output_read_state(run->o->resume, img, &saved, &begin, &end, err))
        return -1;
    if (attrs_check_identity(&saved, run->o->resume, &run->attrs, "this render", err)) {
        image_free(img);
        return -1;
    }
    if (begin != run->rs.batch_begin || end != run->rs.batch_begin + run->rs.batches) {
        image_free(img);
        return rr_fail(err, "%s holds batches %u-%u, this render %u-%u", run->o->resume, begin, end,
                       run->rs.batch_begin, run->rs.batch_begin + run->rs.batches);
    }
    if (check_resumable_counts(run, img, err))
        return -1;
    /* the work the state took goes on counting (render.c, checkpoint_paused) */
    const char *rays = attrs_get(&saved, ATTR_RAYS), *seconds = attrs_get(&saved, ATTR_RENDER_SECONDS);
    const char *clamped = attrs_get(&saved, ATTR_CLAMPED);
    img->rays = rays ? (uint64_t)strtod(rays, NULL) : 0;
    img->clamped = clamped ? (uint64_t)strtod(clamped, NULL) : 0;
    img->seconds = seconds ? strtod(seconds, NULL) : 0.0;
    if (!run->o->quiet) { /* a log then shows the work kept */
        uint64_t done = 0, n = (uint64_t)img->width * img->height;
        for (uint64_t i = 0; i < n; i++)
            done += img->px[i].batches;
        fprintf(stderr, "refrender: resuming %s: %llu of %llu pixel batches already done\n", run->o->resume,
                (unsigned long long)done, (unsigned long long)(n * run->rs.batches));
    }
    return 0;
}

/* --max-batches, by default 8 B (at most FILM_MAX_BATCHES). */
static uint32_t max_batches_of(const render_options *o)
{
    uint64_t eight = 8 * (uint64_t)o->batches;
    return o->max_batches ? (uint32_t)o->max_batches : (uint32_t)(eight < FILM_MAX_BATCHES ? eight : FILM_MAX_BATCHES);
}

static void setup_run(render_run *run, const scene *s, const shutter *shut, const render_options *o,
                      const char *cmdline)
{
    uint32_t total = (uint32_t)o->batches;
    uint32_t begin = o->passes ? (uint32_t)((uint64_t)o->pass * total / o->passes) : 0;
    uint32_t end = o->passes ? (uint32_t)((uint64_t)(o->pass + 1) * total / o->passes) : total;
    run->o = o;
    run->total_batches = total;
    run->last_progress = 0;
    run->rs = (render_settings){
        .smp = {.kind = o->sampler, .seed = o->seed, .grid = sampler_grid_for_spp(o->spp), .tspp = o->tspp,
                .time_factor = s->time_factor, .random_strata = total >= 2}, /* error bars (a target error needs B >= 2 too) */
        .shut = *shut,
        .threads = o->threads,
        .batch_begin = begin,
        .batches = end - begin,
        .max_batches = max_batches_of(o),
        .target_error = o->target_error,
        .exact_time = o->exact_time,
        .filter = o->filter,
        .blur = o->blur,
    };
    if (o->crop_set) {
        int px[4];
        crop_pixels(o, s->cam.width, s->cam.height, px);
        run->rs.crop_x0 = px[0], run->rs.crop_x1 = px[1], run->rs.crop_y0 = px[2], run->rs.crop_y1 = px[3];
    }
    run->attrs.n = 0;
    attrs_for_render(&run->attrs, s, &run->rs, total, cmdline);
}

/* The summary line (not with --quiet), and the warnings: those are no
 * progress output, so --quiet keeps them (a clamped estimate once left no
 * trace under --quiet; its count is in the header too). */
static void report(const render_options *o, const scene *s, const image *img, int tty)
{
    if (!o->quiet && !tty)
        fprintf(stderr, "refrender: %s: %dx%d, %llu rays in %.2fs (%.2f Mrays/s)\n", s->path, img->width,
                img->height, (unsigned long long)img->rays, img->seconds,
                img->seconds > 0 ? img->rays / img->seconds * 1e-6 : 0.0);
    if (img->kbuffer_overflows)
        fprintf(stderr, "refrender: warning: %llu samples had more than %d hits within epsilon; "
                        "the farthest were dropped\n", (unsigned long long)img->kbuffer_overflows, KBUFFER_MAX);
    if (img->clamped)
        fprintf(stderr, "refrender: warning: %llu batch estimates exceeded +-%g and were clamped "
                        "(refrender:clampedEstimates)\n", (unsigned long long)img->clamped, FILM_LIMIT);
}

/* Exact time: the share of the shutter, over all spatial samples, left in
 * pieces too short to certify (exact.h, EXACT_TIME_TOL): their blended set
 * is the one at their middle. In the header always; on stderr when above
 * 100 times the tolerance, since every coverage event leaves a few pieces
 * of the tolerance's length. */
static void report_unresolved(const render_options *o, const image *img, const shutter *shut, attr_list *attrs)
{
    double share = img->rays > 0 ? img->exact_unresolved / ((double)img->rays * (shut->close - shut->open)) : 0.0;
    attrs_set(attrs, ATTR_EXACT_UNRESOLVED_SHARE, "%.6g", share);
    if (share > 100 * EXACT_TIME_TOL && !o->quiet)
        fprintf(stderr, "refrender: warning: exact time left %.3g of the shutter (over all spatial samples) in pieces "
                        "shorter than %g of it, taken with the blended set at their middle\n",
                share, EXACT_TIME_TOL);
}

/* A keyframed scale through zero is held at 1e-9 (animation.h): the
 * object all but vanishes there, which must not pass unnoticed. */
static void warn_about_scales(const render_options *o, const scene *s, const shutter *shut)
{
    for (int i = 0; i < s->nobjects && !o->quiet; i++)
        if (animation_scale_clamped(&s->objects[i].anim, shut->open, shut->close))
            fprintf(stderr, "refrender: warning: object '%s': its keyframed scale reaches zero or below during the "
                            "shutter [%g, %g] and is held at 1e-9 there (the object vanishes; Maya would mirror it)\n",
                    s->objects[i].name, shut->open, shut->close);
}

static void warn_about_settings(const render_options *o, const render_settings *rs)
{
    int k = rs->smp.grid;
    int64_t n = sampler_count(&rs->smp);
    if (o->quiet)
        return;
    if (k * k != o->spp)
        fprintf(stderr, "refrender: --spp %d rounded to a %dx%d grid (%d samples)\n", o->spp, k, k, k * k);
    /* any count is first-class (src/SAMPLING.md, Counts that are no power of two); only the error
     * bars' two time halves need an even one */
    if (rs->smp.kind == SAMPLER_SOBOL && rs->smp.random_strata && n % 2)
        fprintf(stderr, "refrender: note: sobol's error bars want an even spp*tspp (now %lld): with an odd one a pixel "
                        "stepping in time can report too small an error\n", (long long)n);
}

/* The final image, only the crop window's pixels with --crop-window. */
static int write_final(atomic_set *set, const char *output, const image *img, render_run *run, rr_error *err)
{
    const render_settings *rs = &run->rs;
    exr_window win = {img->width, img->height, 0, 0, img->width, img->height};
    if (rs->crop_x1 > 0) {
        win = (exr_window){img->width, img->height, rs->crop_x0, rs->crop_y0, rs->crop_x1 - rs->crop_x0,
                           rs->crop_y1 - rs->crop_y0};
        const double *c = run->o->crop;
        attrs_set(&run->attrs, ATTR_CROP_WINDOW, "%.17g %.17g %.17g %.17g", c[0], c[1], c[2], c[3]);
    }
    return output_write_final_into(set, output, img, (int)sampler_count(&rs->smp), &run->attrs, &win, err);
}

/* The image (a pass's state with --pass) and the preview: both put in
 * place or neither, as every command's outputs. */
static int write_outputs(const image *img, render_run *run, const char *output, const char *preview, rr_error *err)
{
    atomic_set set = {0};
    int rc = run->o->passes ? output_write_state_into(&set, output, img, run->rs.batch_begin,
                                                      run->rs.batch_begin + run->rs.batches, &run->attrs, err)
                            : write_final(&set, output, img, run, err);
    if (!rc && preview)
        rc = output_write_preview_into(&set, preview, img, &run->attrs, err);
    if (rc) {
        atomic_set_discard(&set);
        return -1;
    }
    return atomic_set_commit(&set, err);
}

/* Says what the render was handed, not what was asked for: the period it
 * uses is the one stated (render.h: 0 means only when interrupted). */
static void announce_checkpoints(const render_options *o, const render_hooks *h)
{
    if (!o->checkpoint || o->quiet)
        return;
    if (h->checkpoint_every > 0)
        fprintf(stderr, "refrender: checkpoint %s: every %g s and when interrupted\n", o->checkpoint,
                h->checkpoint_every);
    else
        fprintf(stderr, "refrender: checkpoint %s: only when interrupted\n", o->checkpoint);
}

/* Renders one shutter interval (a frame) into output (and preview). */
static int render_one(const scene *s, const shutter *shut, long long frame, accel *acc, const render_options *o,
                      const char *cmdline, const char *output, const char *preview, rr_error *err)
{
    render_run run;
    setup_run(&run, s, shut, o, cmdline);
    warn_about_settings(o, &run.rs);
    warn_about_scales(o, s, shut);
    image img;
    if (o->resume ? resume_state(&run, &img, err) : (image_alloc(&img, s->cam.width, s->cam.height)
                                                         ? rr_fail(err, "out of memory for the image") : 0))
        return -1;
    int tty = !o->quiet && isatty(STDERR_FILENO);
    void (*progress)(void *, double, uint64_t, double) =
        tty ? print_progress : !o->quiet && o->progress_every > 0 ? print_progress_line : NULL;
    render_hooks hooks = {progress, o->checkpoint ? write_checkpoint : NULL, warn_checkpoint, o->checkpoint_every,
                          &run};
    if (o->passes && !o->quiet)
        fprintf(stderr, "refrender: pass %d/%d: batches %u-%u of %u\n", o->pass, o->passes, run.rs.batch_begin,
                run.rs.batch_begin + run.rs.batches, run.total_batches);
    announce_checkpoints(o, &hooks);
    int rc = render_image(s, acc, &run.rs, &img, &hooks, &interrupted, err);
    if (!rc) {
        report(o, s, &img, tty);
        if (!o->passes) /* a final image: its noise (a pass's state has a share of the batches) */
            rc = noise_report(&img, o->target_error, max_batches_of(o), o->quiet, &run.attrs, err);
        attrs_set(&run.attrs, ATTR_RENDER_SECONDS, "%.3f", img.seconds);
        attrs_set(&run.attrs, ATTR_RAYS, "%llu", (unsigned long long)img.rays);
        attrs_set(&run.attrs, ATTR_CLAMPED, "%llu", (unsigned long long)img.clamped);
        if (run.rs.exact_time)
            report_unresolved(o, &img, &run.rs.shut, &run.attrs);
        if (o->frames && s->frame_rate > 0)
            attrs_set(&run.attrs, ATTR_FRAME_RATE, "%.17g", s->frame_rate);
        if (o->frames)
            attrs_set(&run.attrs, ATTR_FRAME, "%lld", frame);
        if (!rc)
            rc = write_outputs(&img, &run, output, preview, err);
    }
    image_free(&img);
    return rc;
}

/* No output may overwrite an input (scene, model, .anim, the resumed state)
 * or another output of the same run; the checkpoint may be the resumed
 * state (that is how a render is continued). */
static int check_distinct_files(const scene *s, const render_options *o, const char *out, const char *prev,
                                rr_error *err)
{
    const char *outputs[3] = {out, prev, o->checkpoint}, *names[3] = {"-o", "--preview", "--checkpoint"};
    for (int i = 0; i < 3; i++) {
        if (!outputs[i])
            continue;
        for (int k = 0; k < s->ninputs; k++)
            if (cli_same_file(outputs[i], s->inputs[k]))
                return rr_fail(err, "%s %s is an input of this render (%s): refusing to overwrite it", names[i],
                               outputs[i], s->inputs[k]);
        if (o->resume && i < 2 && cli_same_file(outputs[i], o->resume))
            return rr_fail(err, "%s %s is the state being resumed: refusing to overwrite it", names[i], outputs[i]);
        for (int j = 0; j < i; j++)
            if (outputs[j] && cli_same_file(outputs[i], outputs[j]))
                return rr_fail(err, "%s and %s name the same file %s", names[j], names[i], outputs[i]);
    }
    return 0;
}

/* Frame f's output and preview names (prev NULL without --preview); a '%'
 * that is no frame field stays literal. */
static const char *frame_names(const render_options *o, long long f, char *out, char *prev, size_t size)
{
    cli_frame_path(o->output, (int)f, out, size);
    if (!o->preview)
        return NULL;
    cli_frame_path(o->preview, (int)f, prev, size);
    return prev;
}

/* Every frame's outputs are checked before anything is built or rendered. */
static int check_frame_outputs(const scene *s, const render_options *o, rr_error *err)
{
    char out[PATH_MAX], prev[PATH_MAX];
    for (long long f = o->first_frame; f <= o->last_frame; f++)
        if (check_distinct_files(s, o, out, frame_names(o, f, out, prev, sizeof out), err))
            return -1;
    return 0;
}

/* Frame f's shutter; without --frame or --frames the scene's own (as
 * written, or as --time/--shutter set it), with frames at a rate or at a
 * trajectory's poses alike. */
static int frame_shutter(const scene *s, const render_options *o, long long f, shutter *out, rr_error *err)
{
    *out = s->shut;
    return o->frames ? scene_frame_shutter(s, (int)f, out, err) : 0;
}

/* Every frame's shutter is one the scene has, within its camera
 * trajectory, and its camera fits the header, before the first frame is
 * rendered (a sequence must not stop after writing some frames); a
 * refused frame is named. */
static int check_frame_shutters(const scene *s, const render_options *o, rr_error *err)
{
    for (long long f = o->first_frame; f <= o->last_frame; f++) {
        shutter shut;
        char frame[128];
        scene_frame_label(s, f, o->frames, frame, sizeof frame);
        if (frame_shutter(s, o, f, &shut, err) || scene_check_shutter_in_trajectory(s, &shut, frame, err) ||
            scene_check_frame_camera(s, &shut, frame, err))
            return -1;
    }
    return 0;
}

/* Says so when <frames at="trajectory"> moves the shutter as given onto
 * the poses (the header records each frame's; a run must not be silent
 * about a shutter it did not render as written). */
static void note_moved_shutter(const scene *s, const render_options *o, const shutter *first)
{
    char note[512];
    if (o->frames && !o->quiet && scene_frame_shutter_note(s, first, o->first_frame, note, sizeof note))
        fprintf(stderr, "refrender: note: %s\n", note);
}

/* One frame or a sequence, sharing the loaded models and their BVHs; only
 * the top levels are rebuilt for each frame's shutter. */
/* Frame f's shutter and the scene as it renders it (scene_for_shutter:
 * fs, which the BVHs were built for, is refilled in place); the previous
 * frame's scene is freed first. */
static int next_frame(const scene *s, const render_options *o, long long f, shutter *shut, scene *fs, rr_error *err)
{
    scene_for_shutter_free(fs, s);
    *fs = *s; /* (nothing of its own if the next call fails) */
    return frame_shutter(s, o, f, shut, err) || scene_for_shutter(s, shut, fs, err) ? -1 : 0;
}

static int render_and_write(const scene *s, const render_options *o, const char *cmdline, rr_error *err)
{
    accel *acc;
    shutter shut;
    scene fs = *s;
    if (check_frame_outputs(s, o, err) || check_frame_shutters(s, o, err) ||
        next_frame(s, o, o->first_frame, &shut, &fs, err))
        return -1;
    note_moved_shutter(s, o, &shut);
    double t0, t1; /* every line's exposure (a rolling shutter's reaches past [open, close]) */
    shutter_span(&shut, s->cam.width, s->cam.height, &t0, &t1);
    accel_settings set = {t0, t1, s->epsilon, s->kernel_sigma, !o->no_static_reuse};
    if (accel_build(&fs, &set, &acc, err)) {
        scene_for_shutter_free(&fs, s);
        return -1;
    }
    int rc = 0;
    if (interrupted) /* the build cannot be stopped midway; it is not rendered */
        rc = rr_fail(err, "interrupted while building the BVH");
    /* 64-bit: --frame 2147483647 must not wrap around into more frames */
    for (long long f = o->first_frame; !rc && f <= o->last_frame; f++) {
        char out[PATH_MAX], prev[PATH_MAX];
        if (f > o->first_frame &&
            (next_frame(s, o, f, &shut, &fs, err) ||
             (shutter_span(&shut, s->cam.width, s->cam.height, &t0, &t1), accel_set_shutter(acc, t0, t1, err)))) {
            rc = -1;
            break;
        }
        const char *preview = frame_names(o, f, out, prev, sizeof out);
        if (o->frames == 2 && !o->quiet)
            fprintf(stderr, "refrender: frame %lld: shutter [%g, %g] -> %s\n", f, shut.open, shut.close, out);
        rc = render_one(&fs, &shut, f, acc, o, cmdline, out, preview, err);
    }
    accel_free(acc);
    scene_for_shutter_free(&fs, s);
    return rc;
}

static void print_warnings(const rr_warnings *w)
{
    for (int i = 0; i < w->count && i < RR_WARNINGS_KEPT; i++)
        fprintf(stderr, "refrender: warning: %s\n", w->msg[i]);
    if (w->count > RR_WARNINGS_KEPT)
        fprintf(stderr, "refrender: warning: ... and %d more warnings\n", w->count - RR_WARNINGS_KEPT);
}

int cmd_render(int argc, char **argv)
{
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    render_options o;
    memset(&o, 0, sizeof o);
    o.spp = 4, o.tspp = 100, o.threads = cores > 0 ? (int)cores : 1, o.batches = 1;
    o.eps = o.sigma = -1.0, o.checkpoint_every = 60.0, o.seed = 1, o.output = "render.exr", o.sampler = SAMPLER_DEFAULT;
    int rc = parse_args(argc, argv, &o);
    if (rc)
        return rc == 1 ? 0 : 2;
    if (o.instant_set && !o.tspp_given)
        o.tspp = 1; /* one instant: more times per position would repeat it */
    if (o.exact_time) /* time is not sampled: one time per position */
        o.tspp = 1;
    /* before loading: a signal while a large model loads or its BVH builds
     * exits 130 as during the render, not 143 */
    install_signal_handlers();
    rr_interrupt_watch(&interrupted);
    char scene_buf[PATH_MAX + 64];
    if (!o.scene)
        o.scene = default_scene(scene_buf, sizeof scene_buf);
    rr_error err = {{0}};
    scene s;
    char *cmdline = join_args(argc, argv);
    if (!cmdline) {
        fputs("refrender: out of memory\n", stderr);
        return 1;
    }
    int bad = cli_check_exr_name("-o", o.output, 1, &err) ||
        (o.checkpoint && cli_check_exr_name("--checkpoint", o.checkpoint, 0, &err)) ||
        cli_check_writable("-o", o.output, &err) || (o.preview && cli_check_writable("--preview", o.preview, &err)) ||
        (o.preview && preview_check_format(o.preview, &err)) ||
        (o.checkpoint && cli_check_writable("--checkpoint", o.checkpoint, &err)) ||
        scene_load_file_params(o.scene, &o.params, &s, &err);
    if (bad) {
        free(cmdline);
        fprintf(stderr, "refrender: %s\n", err.msg);
        return interrupted ? 130 : 1;
    }
    if (interrupted) { /* the load ended before it saw the signal */
        free(cmdline);
        scene_free(&s);
        fputs("refrender: interrupted while loading the scene\n", stderr);
        return 130;
    }
    print_warnings(&s.warnings);
    rc = apply_overrides(&s, &o, &err) ? -1 : render_and_write(&s, &o, cmdline, &err);
    scene_free(&s);
    free(cmdline);
    if (rc) {
        fprintf(stderr, "refrender: %s\n", err.msg);
        return interrupted ? 130 : 1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && !strcmp(argv[1], "export"))
        return cmd_export(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "gen"))
        return cmd_gen(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "merge"))
        return cmd_merge(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "splat"))
        return cmd_splat(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "surfels"))
        return cmd_surfels(argc - 1, argv + 1);
    return cmd_render(argc, argv);
}
