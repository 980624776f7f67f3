/* 'refrender splat': the thesis's splatting methods (src/splatting/,
 * src/SPLAT.md) rendered into the ground truth's EXR layout, so that
 * compare.py and the tables take them like any method's image. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cmd/cli.h"
#include "cmd/commands.h"
#include "io/output.h"
#include "io/preview.h"
#include "io/render_attrs.h"
#include "scenexml/scene_xml.h"
#include "splatting/splatting.h"

static void splat_usage(FILE *f)
{
    fputs(
"usage: refrender splat METHOD SCENE.xml [options] -o OUT.exr\n"
"\n"
"Renders a scene's point models with one of the splatting methods of Wolf 2008\n"
"(src/SPLAT.md), pixel centres only, into refrender's EXR layout (R G B A,\n"
"samples; refrender:method, refrender:methodParameters, refrender:fragments).\n"
"Surfel (pointModel) objects only: scenes with Gaussian models or spheres are\n"
"refused; so are the times the ray tracer refuses (an object out of reach).\n"
"Methods:\n"
"  instant     the static three-pass splatting of one instant (thesis 4.1.1,\n"
"              4.2.1, 4.2.3); with --filter none it equals\n"
"              'refrender --time T --pixel-filter point --spp 1'\n"
"  accum       N instants accumulated with weights a(t) (3.6.1, 4.3, eq. 4.14)\n"
"  bucket      N instants in B time buckets, one visibility and one\n"
"              normalisation pass per bucket (3.6.2, 4.4); a bucket is opaque\n"
"              wherever any of its instants covers the pixel\n"
"  volumetric  N instants of volumetric kernels: each splat convolved with a 1D\n"
"              Gaussian along its velocity relative to the camera (3.6.3, 4.1.2,\n"
"              4.2.2, App. C), depth tested at its source point, shaded per kernel\n"
"  guan-mueller  Guan and Mueller 2004's motion hints (not the thesis's): the\n"
"              object sharp at the shutter's close, composited front to back,\n"
"              over one trail splat per front-facing point (the disk's screen\n"
"              covariance plus its motion vector's, centred mid-vector)\n"
"Options:\n"
"  --filter F         none (default), botsch (the EWA approximation, eq. 4.13) or\n"
"                     ewa (Ren, Pfister, Zwicker 2002, eq. 7, per-pixel normalised)\n"
"  --time T           instant: the time splatted (default: the shutter's middle)\n"
"  --samples N        accum, bucket, volumetric: instants (default 10;\n"
"                     volumetric 1)\n"
"  --buckets B        bucket: buckets, 1 <= B <= N (default 1)\n"
"  --alpha A          volumetric: thesis (default: the weighted sum of every\n"
"                     fragment, clamped to [0, 1]) or normalized (each instant's\n"
"                     a weighted average, then summed: the thesis's sec. 6.2)\n"
"  --sigma-t X        volumetric: the 1D Gaussian's standard deviation in units\n"
"                     of the slice |v| dt a kernel stands for (default 0.2887 =\n"
"                     1/sqrt 12, a uniform slice's)\n"
"  --trails T         guan-mueller: blend (default: the trails composited front\n"
"                     to back) or add (summed, alpha the clamped sum)\n"
"  --times M          midpoint (default: (k + 1/2) / N of the shutter, as\n"
"                     scripts/nframe_average.py), stratified or random\n"
"  --seed N           stratified and random instants (default 1)\n"
"  --shutter O,C      shutter interval (default: the scene's)\n"
"  --res WxH          image size (default: the scene's camera)\n"
"  --eps X            epsilon-blending distance (default: the scene's, else 0.01)\n"
"  --sigma X          kernel sigma in splat radii (default: the scene's, else 0.5)\n"
"  -D name=value      scene parameter (repeatable)\n"
"  -o, --output F     output EXR (default splat.exr)\n"
"  --preview F        8-bit sRGB preview (format from the extension)\n"
"  --quiet            no summary line\n"
"  -h, --help\n"
"Exit status: 0 success, 1 bad input or render error, 2 usage error.\n", f);
}

typedef struct {
    splat_settings set;
    const char *scene, *output, *preview;
    int width, height, quiet, time_set, samples_set, buckets_set, shutter_set, filter_set, alpha_set, sigma_t_set;
    int trails_set, times_set, seed_set;
    double eps, sigma, shutter_open, shutter_close;
    scene_params params;
} splat_options;

enum { OPT_ALPHA = 300, OPT_SIGMA_T, OPT_TRAILS, OPT_FILTER = 256, OPT_TIME, OPT_SAMPLES, OPT_BUCKETS, OPT_TIMES, OPT_SEED, OPT_SHUTTER, OPT_RES, OPT_EPS,
       OPT_SIGMA, OPT_PREVIEW, OPT_QUIET };

static int parse_choice(const char *opt, const char *arg, const char *const *names, int n, int *out, rr_error *err)
{
    for (int i = 0; i < n; i++)
        if (!strcmp(arg, names[i]))
            return *out = i, 0;
    if (n == 3)
        return rr_fail(err, "%s: expected %s, %s or %s, got '%s'", opt, names[0], names[1], names[2], arg);
    return rr_fail(err, "%s: expected %s or %s, got '%s'", opt, names[0], names[1], arg);
}

static int parse_option(int c, const char *arg, splat_options *o, rr_error *err)
{
    static const char *const filters[] = {"none", "botsch", "ewa"}, *const times[] = {"midpoint", "stratified", "random"};
    static const char *const alphas[] = {"thesis", "normalized"}, *const trails[] = {"blend", "add"};
    int v = 0;
    switch (c) {
    case OPT_FILTER:
        o->filter_set = 1;
        return parse_choice("--filter", arg, filters, 3, &v, err) ? -1 : (o->set.filter = v, 0);
    case OPT_ALPHA:
        o->alpha_set = 1;
        return parse_choice("--alpha", arg, alphas, 2, &v, err) ? -1 : (o->set.alpha = v, 0);
    case OPT_TRAILS:
        o->trails_set = 1;
        return parse_choice("--trails", arg, trails, 2, &v, err) ? -1 : (o->set.trails = v, 0);
    case OPT_SIGMA_T: o->sigma_t_set = 1; return cli_double("--sigma-t", arg, 1e-6, &o->set.sigma_t, err);
    case OPT_TIMES: o->times_set = 1; return parse_choice("--times", arg, times, 3, &v, err) ? -1 : (o->set.times = v, 0);
    case OPT_TIME: o->time_set = 1; return cli_double("--time", arg, -INFINITY, &o->set.instant, err);
    case OPT_SAMPLES: o->samples_set = 1; return cli_int("--samples", arg, 1, 100000, &o->set.samples, err);
    case OPT_BUCKETS: o->buckets_set = 1; return cli_int("--buckets", arg, 1, 100000, &o->set.buckets, err);
    case OPT_SEED: o->seed_set = 1; return cli_u64("--seed", arg, &o->set.seed, err);
    case OPT_SHUTTER: o->shutter_set = 1; return cli_shutter(arg, &o->shutter_open, &o->shutter_close, err);
    case OPT_RES: return cli_resolution("--res", arg, &o->width, &o->height, err);
    case OPT_EPS: return cli_double("--eps", arg, 0.0, &o->eps, err);
    case OPT_SIGMA: return cli_double("--sigma", arg, 1e-6, &o->sigma, err);
    case OPT_PREVIEW: o->preview = arg; return 0;
    case OPT_QUIET: o->quiet = 1; return 0;
    case 'o': o->output = arg; return 0;
    case 'D': return scene_params_add(&o->params, arg, err);
    }
    return rr_fail(err, "unknown option");
}

static int parse_method(const char *name, splat_method *m, rr_error *err)
{
    static const char *const names[] = {"instant", "accum", "bucket", "volumetric", "guan-mueller"};
    for (int i = 0; i < (int)(sizeof names / sizeof *names); i++)
        if (!strcmp(name, names[i]))
            return *m = (splat_method)i, 0;
    return rr_fail(err, "unknown method '%s': expected instant, accum, bucket, volumetric or guan-mueller", name);
}

/* Options that mean nothing for the method chosen are refused, not ignored. */
static int check_combinations(const splat_options *o, rr_error *err)
{
    splat_method m = o->set.method;
    if (m == SPLAT_GUAN_MUELLER && (o->samples_set || o->buckets_set || o->time_set || o->filter_set || o->alpha_set ||
                                    o->sigma_t_set || o->times_set || o->seed_set))
        return rr_fail(err, "guan-mueller draws the object at the shutter's close and one trail per point over the "
                            "shutter: it takes --trails and --shutter, not --samples, --buckets, --time, --filter, "
                            "--alpha, --sigma-t, --times or --seed");
    if (m != SPLAT_GUAN_MUELLER && o->trails_set)
        return rr_fail(err, "--trails is for guan-mueller");
    if (m == SPLAT_INSTANT && (o->samples_set || o->buckets_set))
        return rr_fail(err, "instant splats one instant: --samples and --buckets are for accum and bucket");
    if (m != SPLAT_INSTANT && o->time_set)
        return rr_fail(err, "--time is the instant of 'instant'; %s spans the shutter (--shutter)",
                       splat_method_name(m));
    if (m != SPLAT_VOLUMETRIC && (o->alpha_set || o->sigma_t_set))
        return rr_fail(err, "--alpha and --sigma-t are for volumetric");
    if (m == SPLAT_VOLUMETRIC && (o->buckets_set || o->filter_set))
        return rr_fail(err, "volumetric kernels have no --buckets or --filter (sec. 4.2.2 weighs the kernel itself)");
    if (m == SPLAT_ACCUM && o->buckets_set)
        return rr_fail(err, "--buckets is for bucket (accum is bucket with B = N)");
    if (m == SPLAT_BUCKET && o->set.buckets > o->set.samples)
        return rr_fail(err, "--buckets %d: at most --samples (%d)", o->set.buckets, o->set.samples);
    return 0;
}

/* 0 to go on, 1 after --help, 2 on a usage error. */
static int parse_args(int argc, char **argv, splat_options *o)
{
    static const struct option longopts[] = {
        {"filter", required_argument, 0, OPT_FILTER}, {"time", required_argument, 0, OPT_TIME},
        {"samples", required_argument, 0, OPT_SAMPLES}, {"buckets", required_argument, 0, OPT_BUCKETS},
        {"times", required_argument, 0, OPT_TIMES}, {"seed", required_argument, 0, OPT_SEED},
        {"shutter", required_argument, 0, OPT_SHUTTER}, {"res", required_argument, 0, OPT_RES},
        {"eps", required_argument, 0, OPT_EPS}, {"sigma", required_argument, 0, OPT_SIGMA},
        {"output", required_argument, 0, 'o'}, {"preview", required_argument, 0, OPT_PREVIEW},
        {"alpha", required_argument, 0, OPT_ALPHA}, {"sigma-t", required_argument, 0, OPT_SIGMA_T},
        {"trails", required_argument, 0, OPT_TRAILS}, {"quiet", no_argument, 0, OPT_QUIET}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    rr_error err;
    int c;
    while ((c = getopt_long(argc, argv, "hD:o:", longopts, NULL)) != -1) {
        if (c == 'h') {
            splat_usage(stdout);
            return 1;
        }
        if (c == '?') {
            cli_suggest_option("refrender splat", argv[optind - 1], longopts);
            fputs("Try 'refrender splat --help'.\n", stderr);
            return 2;
        }
        if (parse_option(c, optarg, o, &err)) {
            fprintf(stderr, "refrender splat: %s\n", err.msg);
            return 2;
        }
    }
    if (argc - optind != 2) {
        fprintf(stderr, "refrender splat: expected a method and a scene file, got %d arguments\n"
                        "Try 'refrender splat --help'.\n", argc - optind);
        return 2;
    }
    o->scene = argv[optind + 1];
    int bad = parse_method(argv[optind], &o->set.method, &err);
    if (!bad && o->set.method == SPLAT_VOLUMETRIC && !o->samples_set)
        o->set.samples = 1; /* Table 5.1 row d */
    if (bad || check_combinations(o, &err)) {
        fprintf(stderr, "refrender splat: %s\n", err.msg);
        return 2;
    }
    return 0;
}

static int apply_overrides(scene *s, splat_options *o, rr_error *err)
{
    if (o->width > 0)
        s->cam.width = o->width, s->cam.height = o->height;
    if (o->eps >= 0)
        s->epsilon = o->eps;
    if (o->sigma > 0)
        s->kernel_sigma = o->sigma;
    if (o->shutter_set) {
        s->shut.open = o->shutter_open, s->shut.close = o->shutter_close;
        if (shutter_check(&s->shut, err))
            return -1;
    }
    if (!o->time_set)
        o->set.instant = 0.5 * (s->shut.open + s->shut.close);
    rr_error why;
    if (camera_prepare(&s->cam, &why))
        return rr_fail(err, "%s with --res %dx%d: %s", s->path, s->cam.width, s->cam.height, why.msg);
    if (cli_refuse_overwriting_inputs(o->output, s->inputs, s->ninputs, err) ||
        (o->preview && cli_refuse_overwriting_inputs(o->preview, s->inputs, s->ninputs, err)))
        return -1;
    if (o->preview && cli_same_file(o->output, o->preview))
        return rr_fail(err, "-o and --preview name the same file %s", o->output);
    return 0;
}

/* The method and its parameters, in the header beside the render's identity. */
static void method_attrs(attr_list *a, const splat_options *o, const splat_result *r, double seconds)
{
    const splat_settings *set = &o->set;
    char params[256];
    int len = snprintf(params, sizeof params, "filter=%s", splat_filter_name(set->filter));
    if (set->method == SPLAT_GUAN_MUELLER)
        snprintf(params, sizeof params, "trails=%s flash=close", splat_trails_name(set->trails));
    else if (set->method == SPLAT_INSTANT)
        snprintf(params + len, sizeof params - (size_t)len, " time=%.17g", set->instant);
    else
        len += snprintf(params + len, sizeof params - (size_t)len, " samples=%d times=%s seed=%llu", set->samples,
                        splat_times_name(set->times), (unsigned long long)set->seed);
    if (set->method == SPLAT_BUCKET)
        snprintf(params + len, sizeof params - (size_t)len, " buckets=%d", set->buckets);
    if (set->method == SPLAT_VOLUMETRIC)
        snprintf(params + len, sizeof params - (size_t)len, " alpha=%s sigma_t=%.17g", splat_alpha_name(set->alpha),
                 set->sigma_t);
    attrs_set(a, ATTR_SAMPLER, "none (refrender splat: %s)", splat_method_name(set->method));
    attrs_set(a, ATTR_METHOD, "%s", splat_method_name(set->method));
    attrs_set(a, ATTR_METHOD_PARAMETERS, "%s", params);
    attrs_set(a, ATTR_FRAGMENTS, "%llu", (unsigned long long)r->fragments);
    attrs_set(a, ATTR_RENDER_SECONDS, "%.3f", seconds);
}

/* The image and the preview, both put in place or neither. */
static int write_outputs(const splat_options *o, const scene *s, const splat_result *r, const char *cmdline,
                         double seconds, rr_error *err)
{
    render_settings rs = render_settings_default();
    scene drawn = *s; /* the scene as the method drew it: the instant method's shutter is its instant */
    if (o->set.method == SPLAT_INSTANT)
        shutter_at_instant(&drawn.shut, o->set.instant);
    rs.filter = PIXEL_FILTER_POINT; /* pixel centres only */
    rs.smp.tspp = o->set.method == SPLAT_INSTANT || o->set.method == SPLAT_GUAN_MUELLER ? 1 : o->set.samples;
    attr_list attrs = {0};
    attrs_for_render(&attrs, &drawn, &rs, 1, cmdline);
    method_attrs(&attrs, o, r, seconds);
    image img;
    if (image_alloc(&img, r->width, r->height))
        return rr_fail(err, "out of memory for the image");
    for (size_t i = 0; i < (size_t)r->width * r->height; i++) {
        double est[4] = {r->rgba[4 * i], r->rgba[4 * i + 1], r->rgba[4 * i + 2], r->rgba[4 * i + 3]};
        film_add_batch(&img.px[i], est);
    }
    img.seconds = seconds;
    atomic_set set = {0};
    exr_window win = {r->width, r->height, 0, 0, r->width, r->height};
    int rc = output_write_final_into(&set, o->output, &img, rs.smp.tspp, &attrs, &win, err);
    if (!rc && o->preview)
        rc = preview_write_srgb_into(&set, o->preview, r->width, r->height, r->rgba,
                                     attrs_get(&attrs, ATTR_COLOR_SPACE), err);
    image_free(&img);
    if (rc) {
        atomic_set_discard(&set);
        return -1;
    }
    return atomic_set_commit(&set, err);
}

static void join_args(int argc, char **argv, char *buf, size_t size)
{
    size_t len = 0;
    buf[0] = 0;
    for (int i = 0; i < argc && len + 1 < size; i++)
        len += (size_t)snprintf(buf + len, size - len, "%s%s", i ? " " : "refrender ", argv[i]);
}

static int run(splat_options *o, const char *cmdline, rr_error *err)
{
    scene s;
    if (cli_check_exr_name("-o", o->output, 1, err) || cli_check_writable("-o", o->output, err) ||
        (o->preview && (cli_check_writable("--preview", o->preview, err) || preview_check_format(o->preview, err))) ||
        scene_load_file_params(o->scene, &(scene_load_options){&o->params, NULL}, &s, err))
        return -1;
    for (int i = 0; i < s.warnings.count && i < RR_WARNINGS_KEPT && !o->quiet; i++)
        fprintf(stderr, "refrender splat: warning: %s\n", s.warnings.msg[i]);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    splat_result r;
    int rc = apply_overrides(&s, o, err) || splat_render(&s, &o->set, &r, err) ? -1 : 0;
    if (!rc) {
        clock_gettime(CLOCK_MONOTONIC, &t1);
        double seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
        rc = write_outputs(o, &s, &r, cmdline, seconds, err);
        if (!rc && !o->quiet)
            fprintf(stderr, "refrender splat: %s: %s, %dx%d, %llu fragments in %.2fs\n", s.path,
                    splat_method_name(o->set.method), r.width, r.height, (unsigned long long)r.fragments, seconds);
        splat_result_free(&r);
    }
    scene_free(&s);
    return rc;
}

int cmd_splat(int argc, char **argv)
{
    splat_options o;
    memset(&o, 0, sizeof o);
    o.set.samples = 10, o.set.buckets = 1, o.set.sigma_t = SPLAT_SIGMA_T_DEFAULT, o.set.seed = 1, o.eps = o.sigma = -1.0, o.output = "splat.exr";
    int rc = parse_args(argc, argv, &o);
    if (rc)
        return rc == 1 ? 0 : 2;
    char cmdline[2048];
    join_args(argc, argv, cmdline, sizeof cmdline);
    rr_error err = {{0}};
    if (run(&o, cmdline, &err)) {
        fprintf(stderr, "refrender splat: %s\n", err.msg);
        return 1;
    }
    return 0;
}
