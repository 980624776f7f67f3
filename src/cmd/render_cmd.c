/* refrender's render command: its options, their checks, the scene
 * loaded and overridden; the frames are rendered in render_frames.c. */
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
#include "cmd/render_cmd.h"
#include "cmd/render_sink.h"
#include "io/preview.h"
#include "render/exact.h"
#include "io/render_attrs.h"


static volatile sig_atomic_t signalled = 0;
static void on_signal(int sig) { (void)sig; signalled = 1; }
/* the flag the render watches: the signal handlers' on the command line, a
 * library caller's (render_sink.h) in-process */
static volatile sig_atomic_t *interrupted = &signalled;
const render_sink *render_command_sink = NULL;
static const char default_output[] = "render.exr";

/* The line the command line prints before exiting non-zero; a library
 * caller gets the same text. */
static void say_failure(const char *msg)
{
    if (render_command_sink)
        render_command_sink->failed(render_command_sink->user, msg);
    else
        fprintf(stderr, "refrender: %s\n", msg);
}

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
    if (o->exact_time && exact_check_blur_space(o->blur, err))
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
        if (c == 'h') { refrender_usage(stdout); return 1; }
        if (c == OPT_VERSION) { printf("refrender %s (build %s)\n", RR_VERSION, render_build_id()); return 1; }
        if (c == '?' && render_command_sink) { /* (the caller set opterr 0: getopt said nothing) */
            say_failure("unrecognized option, or an option given a value it does not take or without one it needs "
                        "('refrender --help' lists them)");
            return 2;
        }
        if (c == '?') {
            cli_suggest_option("refrender", argv[optind - 1], longopts);
            fputs("Try 'refrender --help'.\n", stderr);
            return 2;
        }
        if (parse_option(c, optarg, o, &err)) {
            say_failure(err.msg);
            return 2;
        }
    }
    if (optind < argc - 1) {
        char msg[96];
        snprintf(msg, sizeof msg, "expected one scene file, got %d arguments", argc - optind);
        say_failure(msg);
        return 2;
    }
    if (optind == argc - 1)
        o->scene = argv[optind];
    if (o->target_error > 0 && !o->batches_given)
        o->batches = 4; /* an error estimate needs batches (src/SAMPLING.md, Error bars) */
    if (render_command_sink && (o->passes || o->checkpoint || o->resume || o->preview || o->frames == 2 ||
                                o->output != default_output)) {
        say_failure("a library render returns one image in memory: -o, --preview, --pass, --checkpoint, --resume "
                    "and --frames are the command line's");
        return 2;
    }
    if (check_combinations(o, &err)) {
        say_failure(err.msg);
        return 2;
    }
    return 0;
}

void render_options_crop_pixels(const render_options *o, int width, int height, int px[4])
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
    render_options_crop_pixels(o, s->cam.width, s->cam.height, px);
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
    o.eps = o.sigma = -1.0, o.checkpoint_every = 60.0, o.seed = 1, o.output = default_output, o.sampler = SAMPLER_DEFAULT;
    int rc = parse_args(argc, argv, &o);
    if (rc)
        return rc == 1 ? 0 : 2;
    if (o.instant_set && !o.tspp_given)
        o.tspp = 1; /* one instant: more times per position would repeat it */
    if (o.exact_time) /* time is not sampled: one time per position */
        o.tspp = 1;
    /* before loading: a signal while a large model loads or its BVH builds
     * exits 130 as during the render, not 143 */
    if (render_command_sink)
        interrupted = render_command_sink->interrupt;
    else
        install_signal_handlers();
    char scene_buf[PATH_MAX + 64];
    if (!o.scene)
        o.scene = cli_tree_file("scenes/default.xml", scene_buf, sizeof scene_buf);
    rr_error err = {{0}};
    scene s;
    char *cmdline = join_args(argc, argv);
    if (!cmdline) {
        say_failure("out of memory");
        return 1;
    }
    /* a library caller's image stays in memory: no -o is written */
    int bad = (!render_command_sink && cli_check_exr_name("-o", o.output, 1, &err)) ||
        (o.checkpoint && cli_check_exr_name("--checkpoint", o.checkpoint, 0, &err)) ||
        (!render_command_sink && cli_check_writable("-o", o.output, &err)) ||
        (o.preview && cli_check_writable("--preview", o.preview, &err)) ||
        (o.preview && preview_check_format(o.preview, &err)) ||
        (o.checkpoint && cli_check_writable("--checkpoint", o.checkpoint, &err)) ||
        scene_load_file_params(o.scene, &(scene_load_options){&o.params, interrupted}, &s, &err);
    if (bad) {
        free(cmdline);
        say_failure(err.msg);
        return *interrupted ? 130 : 1;
    }
    if (*interrupted) { /* the load ended before it saw the signal */
        free(cmdline);
        scene_free(&s);
        say_failure("interrupted while loading the scene");
        return 130;
    }
    print_warnings(&s.warnings);
    rc = apply_overrides(&s, &o, &err) ? -1 : render_frames(&s, &o, cmdline, interrupted, &err);
    scene_free(&s);
    free(cmdline);
    if (rc) {
        say_failure(err.msg);
        return *interrupted ? 130 : 1;
    }
    return 0;
}
