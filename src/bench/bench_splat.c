#include "bench/bench_splat.h"

#include "render/render.h"
#include "splatting/splatting.h"

typedef struct {
    const char *label;
    splat_method method;
    int samples, buckets;
} splat_row;

/* The ray tracer at the pixel centres, n instants each (seconds). */
static double truth_seconds(const accel *acc, int n, int res, unsigned long long *rays)
{
    render_settings rs = render_settings_default();
    rs.smp.tspp = n, rs.smp.grid = 1, rs.filter = PIXEL_FILTER_POINT, rs.threads = 1;
    image img;
    rr_error err;
    volatile sig_atomic_t never = 0;
    image_alloc(&img, res, res);
    render_image(acc, &rs, &img, NULL, &never, &err);
    double seconds = img.seconds;
    *rays = img.rays;
    image_free(&img);
    return seconds;
}

static double splat_seconds(const scene *s, const splat_row *row, unsigned long long *fragments)
{
    splat_settings set = {.method = row->method, .times = SPLAT_TIMES_MIDPOINT, .samples = row->samples,
                          .buckets = row->buckets, .seed = 1, .sigma_t = SPLAT_SIGMA_T_DEFAULT,
                          .instant = 0.5 * (s->shut.open + s->shut.close)};
    splat_result r;
    rr_error err;
    double t0 = rr_seconds();
    if (splat_render(s, &set, &r, &err)) {
        fprintf(stderr, "bench: splat %s: %s\n", row->label, err.msg);
        return -1;
    }
    double seconds = rr_seconds() - t0;
    *fragments = r.fragments;
    splat_result_free(&r);
    return seconds;
}

void bench_splat(const scene *s, const accel *acc, int res, FILE *csv)
{
    static const splat_row rows[] = {{"instant", SPLAT_INSTANT, 1, 1},       {"accum 10", SPLAT_ACCUM, 10, 10},
                                     {"accum 50", SPLAT_ACCUM, 50, 50},       {"bucket 50/5", SPLAT_BUCKET, 50, 5},
                                     {"volumetric 1", SPLAT_VOLUMETRIC, 1, 1}, {"volumetric 3", SPLAT_VOLUMETRIC, 3, 3},
                                     {"guan-mueller", SPLAT_GUAN_MUELLER, 1, 1}}; /* against one instant */
    printf("\nsplat: the splatting methods (refrender splat, one thread) against the ray tracer sampling as many\n"
           "instants at every pixel centre (one thread), on the same scene:\n\n"
           "| method | instants | splat s | fragments | truth s | rays | splat / truth |\n"
           "| --- | --- | --- | --- | --- | --- | --- |\n");
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        unsigned long long fragments = 0, rays = 0;
        double ours = splat_seconds(s, &rows[i], &fragments);
        double truth = truth_seconds(acc, rows[i].samples, res, &rays);
        if (ours < 0)
            continue;
        printf("| %s | %d | %.3f | %llu | %.3f | %llu | %.2fx |\n", rows[i].label, rows[i].samples, ours, fragments,
               truth, rays, ours / truth);
        fprintf(csv, "splat,%zu,rotation,90,%s,%d,1,%d,,,,,%.4f,,,,,,,,\n", s->objects[0].model.count, rows[i].label,
                rows[i].samples, res, ours / truth);
    }
    fflush(stdout);
}
