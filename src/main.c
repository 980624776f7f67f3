/* refrender: command line, progress and orchestration only. */
#include <getopt.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "exr.h"
#include "preview.h"
#include "render.h"
#include "sampler.h"
#include "scene_xml.h"

#ifndef RR_SOURCE_SCENE
#define RR_SOURCE_SCENE "scenes/default.xml"
#endif

static volatile sig_atomic_t interrupted = 0;
static void on_signal(int sig) { (void)sig; interrupted = 1; }

static void usage(FILE *f)
{
    fputs(
"usage: refrender [options] [SCENE.xml]\n"
"       refrender gen SHAPE [options] -o FILE.ply   (see 'refrender gen --help')\n"
"\n"
"Renders a ground-truth motion-blurred image of a point-based scene by Monte\n"
"Carlo ray tracing (Wolf 2008, sec. 4.5) and writes a 32-bit float RGBA EXR.\n"
"Without SCENE the bundled default scene (scenes/default.xml) is rendered.\n"
"\n"
"Sampling:\n"
"  --spp N          spatial samples per pixel on a jittered KxK grid; N is\n"
"                   rounded to the nearest square K*K, K = max(1, round(sqrt(N)))\n"
"                   (default 4)\n"
"  --tspp N         temporal samples per spatial sample (default 100)\n"
"  --time-factor F  the time grid has tspp*F jittered strata; each spatial\n"
"                   sample takes a random subset of tspp of them (thesis 4.5;\n"
"                   default: scene <render time_factor>, else 4)\n"
"  --seed N         random seed; same seed, same image, any thread count (default 1)\n"
"Scene overrides:\n"
"  --res WxH        image size (default: scene <camera width height>)\n"
"  --eps X          epsilon-blending distance in world units (default: scene\n"
"                   <render epsilon>, else 0.01)\n"
"  --sigma X        Gaussian kernel sigma in splat radii (default: scene\n"
"                   <render kernel_sigma>, else 0.5)\n"
"Output:\n"
"  -o, --output F   output EXR (default render.exr); written atomically\n"
"  --preview F      also write an sRGB 8-bit preview (PNG, by extension)\n"
"Running:\n"
"  --threads N      render threads (default: all cores)\n"
"  --quiet          no progress bar and no summary line\n"
"  --version        print the version and exit\n"
"  -h, --help       print this help and exit\n"
"\n"
"Progress is shown on stderr when it is a terminal; otherwise one summary line\n"
"is printed at the end. Exit status: 0 success, 1 bad input or render error,\n"
"2 usage error, 130 interrupted (no output is written).\n", f);
}

typedef struct {
    int spp, tspp, time_factor, threads, quiet, width, height;
    double eps, sigma; /* < 0: from the scene */
    uint64_t seed;
    const char *scene, *output, *preview;
} render_options;

enum { OPT_SPP = 256, OPT_TSPP, OPT_RES, OPT_THREADS, OPT_SEED, OPT_EPS, OPT_SIGMA, OPT_TFACTOR,
       OPT_PREVIEW, OPT_QUIET, OPT_VERSION };

static int parse_option(int c, const char *arg, render_options *o, rr_error *err)
{
    switch (c) {
    case OPT_SPP: return cli_int("--spp", arg, 1, 4096, &o->spp, err);
    case OPT_TSPP: return cli_int("--tspp", arg, 1, 1000000, &o->tspp, err);
    case OPT_TFACTOR: return cli_int("--time-factor", arg, 1, 1024, &o->time_factor, err);
    case OPT_RES: return cli_resolution("--res", arg, &o->width, &o->height, err);
    case OPT_THREADS: return cli_int("--threads", arg, 1, 1024, &o->threads, err);
    case OPT_SEED: return cli_u64("--seed", arg, &o->seed, err);
    case OPT_EPS: return cli_double("--eps", arg, 0.0, &o->eps, err);
    case OPT_SIGMA: return cli_double("--sigma", arg, 1e-6, &o->sigma, err);
    case 'o': o->output = arg; return 0;
    case OPT_PREVIEW: o->preview = arg; return 0;
    case OPT_QUIET: o->quiet = 1; return 0;
    }
    return rr_fail(err, "unknown option");
}

/* Returns 0 to go on, 1 for a clean exit (help, version), 2 on usage error. */
static int parse_args(int argc, char **argv, render_options *o)
{
    static const struct option longopts[] = {
        {"spp", required_argument, 0, OPT_SPP}, {"tspp", required_argument, 0, OPT_TSPP},
        {"time-factor", required_argument, 0, OPT_TFACTOR}, {"res", required_argument, 0, OPT_RES},
        {"threads", required_argument, 0, OPT_THREADS}, {"seed", required_argument, 0, OPT_SEED},
        {"eps", required_argument, 0, OPT_EPS}, {"sigma", required_argument, 0, OPT_SIGMA},
        {"output", required_argument, 0, 'o'}, {"preview", required_argument, 0, OPT_PREVIEW},
        {"quiet", no_argument, 0, OPT_QUIET}, {"version", no_argument, 0, OPT_VERSION},
        {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    int c;
    while ((c = getopt_long(argc, argv, "ho:", longopts, NULL)) != -1) {
        rr_error err;
        if (c == 'h') { usage(stdout); return 1; }
        if (c == OPT_VERSION) { printf("refrender %s\n", RR_VERSION); return 1; }
        if (c == '?') { fputs("Try 'refrender --help'.\n", stderr); return 2; }
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
    return camera_prepare(&s->cam, err);
}

static void describe_weight(const shutter *sh, char *buf, size_t size)
{
    const char *name = shutter_weight_name(sh->kind);
    if (sh->kind == WEIGHT_LINEAR)
        snprintf(buf, size, "linear center=%.17g", sh->center);
    else if (sh->kind == WEIGHT_EXP)
        snprintf(buf, size, "exp center=%.17g rate=%.17g", sh->center, sh->rate);
    else if (sh->kind == WEIGHT_TABLE) {
        size_t len = (size_t)snprintf(buf, size, "table");
        for (int i = 0; i < sh->table_size && len < size; i++)
            len += (size_t)snprintf(buf + len, size - len, " %.17g %.17g", sh->table_t[i], sh->table_w[i]);
    } else
        snprintf(buf, size, "%s", name);
}

enum { ATTR_COUNT = 14 };

static int write_output(const scene *s, const render_settings *rs, const render_options *o,
                        const image *img, const char *cmdline, rr_error *err)
{
    char vals[ATTR_COUNT][4200];
    snprintf(vals[0], 4200, "%s", s->path);
    snprintf(vals[1], 4200, "%d", rs->spp_grid * rs->spp_grid);
    snprintf(vals[2], 4200, "%d", rs->tspp);
    snprintf(vals[3], 4200, "thesis");
    snprintf(vals[4], 4200, "%llu", (unsigned long long)rs->seed);
    snprintf(vals[5], 4200, "%.17g", s->epsilon);
    snprintf(vals[6], 4200, "%.17g", s->kernel_sigma);
    snprintf(vals[7], 4200, "%.17g %.17g", s->shut.open, s->shut.close);
    describe_weight(&s->shut, vals[8], sizeof vals[8]);
    snprintf(vals[9], 4200, "%d", rs->time_factor);
    snprintf(vals[10], 4200, "%.3f", img->seconds);
    snprintf(vals[11], 4200, "refrender %s", RR_VERSION);
    snprintf(vals[12], 4200, "%s", cmdline);
    snprintf(vals[13], 4200, "%llu", (unsigned long long)img->rays);
    static const char *const keys[ATTR_COUNT] = {
        "refrender:scene", "refrender:spp", "refrender:tspp", "refrender:sampler", "refrender:seed",
        "refrender:epsilon", "refrender:kernelSigma", "refrender:shutter", "refrender:weightFunction",
        "refrender:timeFactor", "refrender:renderSeconds", "software", "refrender:command", "refrender:rays"};
    exr_string_attr attrs[ATTR_COUNT];
    for (int i = 0; i < ATTR_COUNT; i++)
        attrs[i] = (exr_string_attr){keys[i], vals[i]};
    if (exr_write_rgba(o->output, img->width, img->height, img->rgba, attrs, ATTR_COUNT, err))
        return -1;
    if (o->preview &&
        preview_write_srgb(o->preview, img->width, img->height, img->rgba, err->msg, (int)sizeof err->msg))
        return -1;
    return 0;
}

static void join_args(int argc, char **argv, char *buf, size_t size)
{
    size_t len = 0;
    buf[0] = 0;
    for (int i = 0; i < argc && len + 1 < size; i++)
        len += (size_t)snprintf(buf + len, size - len, "%s%s", i ? " " : "", argv[i]);
}

static void install_signal_handlers(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

static int render_and_write(scene *s, const render_options *o, const char *cmdline, rr_error *err)
{
    render_settings rs = {sampler_grid_for_spp(o->spp), o->tspp, s->time_factor, o->seed, o->threads};
    if (rs.spp_grid * rs.spp_grid != o->spp && !o->quiet)
        fprintf(stderr, "refrender: --spp %d rounded to a %dx%d jittered grid (%d samples)\n", o->spp,
                rs.spp_grid, rs.spp_grid, rs.spp_grid * rs.spp_grid);
    accel *acc;
    if (accel_build(s, s->epsilon, s->kernel_sigma, &acc, err))
        return -1;
    image img;
    int progress = !o->quiet && isatty(STDERR_FILENO);
    install_signal_handlers();
    int rc = render_image(s, acc, &rs, &img, progress ? print_progress : NULL, NULL, &interrupted, err);
    accel_free(acc);
    if (rc)
        return -1;
    if (!o->quiet && !progress)
        fprintf(stderr, "refrender: %s: %dx%d, %llu rays in %.2fs (%.2f Mrays/s)\n", s->path, img.width,
                img.height, (unsigned long long)img.rays, img.seconds,
                img.seconds > 0 ? img.rays / img.seconds * 1e-6 : 0.0);
    if (img.kbuffer_overflows && !o->quiet)
        fprintf(stderr, "refrender: warning: %llu samples had more than %d hits within epsilon; "
                        "the farthest were dropped\n", (unsigned long long)img.kbuffer_overflows, KBUFFER_MAX);
    rc = write_output(s, &rs, o, &img, cmdline, err);
    image_free(&img);
    return rc;
}

int cmd_render(int argc, char **argv)
{
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    render_options o = {4, 100, 0, cores > 0 ? (int)cores : 1, 0, 0, 0, -1.0, -1.0, 1, NULL,
                        "render.exr", NULL};
    int rc = parse_args(argc, argv, &o);
    if (rc)
        return rc == 1 ? 0 : 2;
    char scene_buf[PATH_MAX + 64];
    if (!o.scene)
        o.scene = default_scene(scene_buf, sizeof scene_buf);
    rr_error err;
    scene s;
    char cmdline[2048];
    join_args(argc, argv, cmdline, sizeof cmdline);
    if (cli_check_writable(o.output, &err) || (o.preview && cli_check_writable(o.preview, &err)) ||
        scene_load_file(o.scene, &s, &err)) {
        fprintf(stderr, "refrender: %s\n", err.msg);
        return 1;
    }
    rc = apply_overrides(&s, &o, &err) ? -1 : render_and_write(&s, &o, cmdline, &err);
    scene_free(&s);
    if (rc) {
        fprintf(stderr, "refrender: %s\n", err.msg);
        return interrupted ? 130 : 1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && !strcmp(argv[1], "gen"))
        return cmd_gen(argc - 1, argv + 1);
    return cmd_render(argc, argv);
}
