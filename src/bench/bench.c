/* refrender-bench: speed and memory of the render path against Embree's
 * built-in oriented-disc primitive (closest hit only, no blending, no
 * motion) on the same splats and the same rays, measured in the same run.
 * Each case runs in a forked child so its peak memory (ru_maxrss) is its
 * own. Prints a markdown table and writes CSV. Not a test: no assertions. */
#include <embree3/rtcore.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bench/bench_gaussian.h"
#include "bench/bench_splat.h"
#include "render/render.h"
#include "surfels/shapes.h"

typedef struct {
    const char *motion;  /* static, linear, rotation */
    int elliptical;
    int splats, tspp, threads, res, reps;
    int background;      /* 1: add a static surfel wall filling the image behind (80% static) */
    double degrees;      /* rotation speed per time unit (shutter [0,1]); 0: the default 90 */
    int scaling;         /* 1: `threads` threads against 1 thread, alternated in one process */
    int floor;           /* 1: also the same discs as user geometry on the same rays (floor_build) */
} bench_case;

typedef struct {
    double build_ms, base_build_ms, mrays, base_mrays, peak_mb, bytes_per_splat;
    double same_rays_mrays; /* the baseline on refrender's object-space rays (0: not measured) */
    double floor_mrays;     /* the discs as user geometry on those rays (0: not measured) */
    double floor_eps_mrays; /* the same, the rays kept to the closest hit + epsilon */
    double floor_splats_px; /* distinct discs the user geometry's closest hits find per covered pixel */
    double moving_share; /* static80: pixel-center rays meeting the moving swept bounds */
    double base_splats_px, same_splats_px; /* distinct discs hit per covered pixel, each baseline */
    unsigned long long rays;
} bench_result;

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* A unit sphere of overlapping surfels (elliptical: axes 1.5 and 1/1.5 of
 * the circle's radius, same area) in front of a camera at distance 3.5. */
static void build_scene(const bench_case *c, scene *s, surfel **out, size_t *n)
{
    scene_init(s);
    s->cam.position = v3(0, 0, 3.5);
    s->cam.width = s->cam.height = c->res;
    s->cam.fov_degrees = 40;
    camera_prepare(&s->cam, NULL);
    s->epsilon = 0.01;
    shape_params p;
    shape_params_default(&p);
    p.count = (size_t)c->splats;
    rr_error err;
    shape_generate(&p, out, n, &err);
    scene_object *o = scene_add_object(s); /* a static point object, the default material */
    RR_CHECK(o != NULL);                   /* a benchmark: no recovery */
    if (!strcmp(c->motion, "linear"))
        o->anim.velocity = v3(0.3, 0.1, 0);
    if (!strcmp(c->motion, "rotation"))
        o->anim.has_rotation = 1, o->anim.axis = v3(0, 1, 0), o->anim.degrees_per_time = c->degrees ? c->degrees : 90;
    for (size_t i = 0; i < *n; i++) {
        surfel *f = &(*out)[i];
        vec3 u, v;
        splat_axes_from_normal(f->normal, f->radius, &u, &v);
        if (c->elliptical)
            u = v3_scale(u, 1.5), v = v3_scale(v, 1 / 1.5);
        pointmodel_add(&o->model, f->center, u, v, f->normal, f->color, &err);
    }
    /* as the scene loader does; the baseline gets the same splat order */
    size_t *order;
    if (pointmodel_sort_spatially(&o->model, &order, &err)) {
        fprintf(stderr, "bench: %s\n", err.msg);
        exit(1);
    }
    surfel *sorted = malloc(*n * sizeof *sorted);
    if (!sorted) {
        fprintf(stderr, "bench: out of memory\n");
        exit(1);
    }
    for (size_t i = 0; i < *n; i++)
        sorted[i] = (*out)[order[i]];
    free(order);
    free(*out);
    *out = sorted;
    if (c->background) { /* a static wall behind; the sphere covers about 15% of the image */
        s->cam.position = v3(0, 0, 6.5);
        scene_object *w = scene_add_object(s); /* the sphere's: the default material */
        RR_CHECK(w != NULL);
        w->anim.offset = v3(0, 0, -2);
        shape_params wall;
        shape_params_default(&wall);
        strcpy(wall.kind, "plane");
        wall.radius = 4;
        /* the same splat density (and size) as the sphere: 64 / (4 pi) times its count */
        wall.count = (size_t)((double)c->splats * 64.0 / (4.0 * M_PI));
        surfel *ws;
        size_t wn;
        shape_generate(&wall, &ws, &wn, &err);
        for (size_t i = 0; i < wn; i++)
            pointmodel_add_circle(&w->model, ws[i].center, ws[i].normal, ws[i].radius, ws[i].color, &err);
        pointmodel_sort_spatially(&w->model, NULL, &err);
        free(ws);
    }
    light sun = {LIGHT_DIRECTIONAL, v3(0, 0, 0), v3_normalize(v3(-1, -1, -1)), v3(1, 1, 1)};
    RR_CHECK(scene_add_light(s, sun) == 0);
}

/* ---- baseline: Embree's oriented discs, closest hit ------------------------ */

typedef struct {
    RTCScene scene;
    const scene *sc;
    const render_settings *rs;
    int same_rays; /* 1: trace each time's object-space ray (as refrender does), 0: the world ray */
    int count_distinct; /* an untimed run counting the discs hit (sorting would distort the timing) */
    int next_row;
    pthread_mutex_t lock;
    unsigned long long distinct, covered; /* distinct discs hit, summed over the pixels hitting any */
} baseline_job;

static int cmp_unsigned(const void *a, const void *b)
{
    unsigned x = *(const unsigned *)a, y = *(const unsigned *)b;
    return (x > y) - (x < y);
}

/* How many different discs the n hits prims[0..n) are: what a pixel's rays
 * must fetch (the same few discs at rest, a new one per time under fast
 * motion). */
static unsigned distinct_prims(unsigned *prims, int n)
{
    qsort(prims, (size_t)n, sizeof *prims, cmp_unsigned);
    unsigned d = 0;
    for (int i = 0; i < n; i++)
        d += i == 0 || prims[i] != prims[i - 1];
    return d;
}

static void *baseline_worker(void *arg)
{
    baseline_job *job = arg;
    const sampler *smp = &job->rs->smp;
    sampler_scratch ss;
    if (sampler_scratch_init(&ss, smp)) {
        fprintf(stderr, "refrender-bench: out of memory for the sampler's scratch\n");
        exit(1);
    }
    int n = (int)sampler_count(smp); /* the bench sets small counts */
    double *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y), *t = malloc(n * sizeof *t);
    double *w = malloc(n * sizeof *w); /* the weights: unused, the rays are what is measured */
    unsigned *prims = malloc(n * sizeof *prims);
    unsigned long long distinct = 0, covered = 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (;;) {
        pthread_mutex_lock(&job->lock);
        int row = job->next_row++;
        pthread_mutex_unlock(&job->lock);
        if (row >= job->sc->cam.height)
            break;
        for (int px = 0; px < job->sc->cam.width; px++) {
            sampler_batch(smp, job->sc->shut.open, job->sc->shut.close, (uint64_t)row * job->sc->cam.width + px, px,
                          row, 0, &ss, x, y, t, w);
            int nhits = 0;
            for (int i = 0; i < n; i++) { /* the same rays the render path traces */
                vec3 d = camera_ray_direction(&job->sc->cam, x[i], y[i]);
                vec3 o = job->sc->cam.position;
                if (job->same_rays) {
                    xform xf = animation_at(&job->sc->objects[0].anim, t[i]);
                    o = xform_inverse_point(&xf, o), d = xform_inverse_vector(&xf, d);
                }
                struct RTCRayHit rh;
                memset(&rh, 0, sizeof rh);
                rh.ray.org_x = (float)o.x, rh.ray.org_y = (float)o.y, rh.ray.org_z = (float)o.z;
                rh.ray.dir_x = (float)d.x, rh.ray.dir_y = (float)d.y, rh.ray.dir_z = (float)d.z;
                rh.ray.tfar = INFINITY;
                rh.ray.mask = 0xFFFFFFFFu;
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(job->scene, &ctx, &rh);
                if (job->count_distinct && rh.hit.geomID != RTC_INVALID_GEOMETRY_ID)
                    prims[nhits++] = rh.hit.primID;
            }
            if (job->count_distinct) {
                distinct += distinct_prims(prims, nhits);
                covered += nhits > 0;
            }
        }
    }
    pthread_mutex_lock(&job->lock);
    job->distinct += distinct;
    job->covered += covered;
    pthread_mutex_unlock(&job->lock);
    sampler_scratch_free(&ss);
    free(x), free(y), free(t), free(w), free(prims);
    return NULL;
}

static RTCScene baseline_build(RTCDevice dev, const surfel *f, size_t n)
{
    RTCScene scene = rtcNewScene(dev);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT);
    float *vtx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 16, n);
    float *nrm = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, 12, n);
    for (size_t i = 0; i < n; i++) {
        vtx[4 * i] = (float)f[i].center.x, vtx[4 * i + 1] = (float)f[i].center.y;
        vtx[4 * i + 2] = (float)f[i].center.z, vtx[4 * i + 3] = (float)f[i].radius;
        nrm[3 * i] = (float)f[i].normal.x, nrm[3 * i + 1] = (float)f[i].normal.y, nrm[3 * i + 2] = (float)f[i].normal.z;
    }
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    return scene;
}

/* ---- floor: the same discs as Embree user geometry, closest hit ------------
 * What refrender's design (splats as user primitives, each tested in a
 * callback) costs before any of its own work: the same disc test Embree's
 * built-in primitive does, one callback per candidate, no blending. */

typedef struct {
    const float *disc;   /* center xyz, radius (the built-in's vertex buffer) */
    const float *normal; /* xyz */
    float epsilon;       /* > 0: the ray is kept to the closest hit + epsilon, as blending needs */
} floor_discs;

/* The box Embree's built-in point primitives take (the centre +- the
 * radius on every axis), so both traverse alike-shaped BVHs; rounded
 * outward. */
static void floor_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const floor_discs *d = args->geometryUserPtr;
    const float *c = &d->disc[4 * args->primID];
    struct RTCBounds *b = args->bounds_o;
    b->lower_x = rr_float_below(c[0] - c[3]), b->lower_y = rr_float_below(c[1] - c[3]);
    b->lower_z = rr_float_below(c[2] - c[3]);
    b->upper_x = rr_float_above(c[0] + c[3]), b->upper_y = rr_float_above(c[1] + c[3]);
    b->upper_z = rr_float_above(c[2] + c[3]);
}

static void floor_intersect(const struct RTCIntersectFunctionNArguments *args)
{
    if (!args->valid[0]) /* rtcIntersect1 only: N = 1 */
        return;
    const floor_discs *d = args->geometryUserPtr;
    const float *c = &d->disc[4 * args->primID], *n = &d->normal[3 * args->primID];
    struct RTCRayHit *rh = (struct RTCRayHit *)args->rayhit;
    float dn = rh->ray.dir_x * n[0] + rh->ray.dir_y * n[1] + rh->ray.dir_z * n[2];
    float t = ((c[0] - rh->ray.org_x) * n[0] + (c[1] - rh->ray.org_y) * n[1] + (c[2] - rh->ray.org_z) * n[2]) / dn;
    if (!(t > rh->ray.tnear && t < rh->ray.tfar))
        return;
    float px = rh->ray.org_x + t * rh->ray.dir_x - c[0], py = rh->ray.org_y + t * rh->ray.dir_y - c[1];
    float pz = rh->ray.org_z + t * rh->ray.dir_z - c[2];
    if (px * px + py * py + pz * pz > c[3] * c[3])
        return;
    if (d->epsilon > 0) { /* hit.u holds the closest hit so far (the ray was reset to u = 0) */
        if (rh->hit.geomID != RTC_INVALID_GEOMETRY_ID && rh->hit.u <= t)
            return; /* a hit within epsilon behind the closest: kept by blending, not closer */
        rh->ray.tfar = t + d->epsilon, rh->hit.u = t;
    } else
        rh->ray.tfar = t;
    rh->hit.primID = args->primID, rh->hit.geomID = args->geomID;
    rh->hit.Ng_x = n[0], rh->hit.Ng_y = n[1], rh->hit.Ng_z = n[2];
}

static void floor_occluded(const struct RTCOccludedFunctionNArguments *args) { (void)args; }

/* The built-in scene's own buffers serve the user geometry too (same discs,
 * same order). */
static RTCScene floor_build(RTCDevice dev, RTCScene builtin, size_t n, float epsilon, floor_discs *d)
{
    d->epsilon = epsilon;
    RTCGeometry src = rtcGetGeometry(builtin, 0);
    d->disc = rtcGetGeometryBufferData(src, RTC_BUFFER_TYPE_VERTEX, 0);
    d->normal = rtcGetGeometryBufferData(src, RTC_BUFFER_TYPE_NORMAL, 0);
    RTCScene scene = rtcNewScene(dev);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, (unsigned)n);
    rtcSetGeometryUserData(g, d);
    rtcSetGeometryBoundsFunction(g, floor_bounds, d);
    rtcSetGeometryIntersectFunction(g, floor_intersect);
    rtcSetGeometryOccludedFunction(g, floor_occluded);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    return scene;
}

/* The baseline's time; with count_distinct (not for timing), *splats_px gets
 * the distinct discs hit per covered pixel. */
static double baseline_seconds(RTCScene rtc_scene, const scene *s, const render_settings *rs, int same_rays,
                               int count_distinct, double *splats_px)
{
    baseline_job job = {rtc_scene, s, rs, same_rays, count_distinct, 0, PTHREAD_MUTEX_INITIALIZER, 0, 0};
    pthread_t *tids = calloc((size_t)rs->threads, sizeof *tids);
    if (!tids) {
        fprintf(stderr, "bench: out of memory\n");
        exit(1);
    }
    int started = 0;
    double t0 = rr_seconds();
    while (started < rs->threads && pthread_create(&tids[started], NULL, baseline_worker, &job) == 0)
        started++;
    for (int i = 0; i < started; i++)
        pthread_join(tids[i], NULL);
    free(tids);
    if (started < rs->threads) {
        fprintf(stderr, "bench: could start only %d of %d threads\n", started, rs->threads);
        exit(1);
    }
    double seconds = rr_seconds() - t0;
    if (count_distinct)
        *splats_px = job.covered ? (double)job.distinct / (double)job.covered : 0.0;
    return seconds;
}

/* ---- one case, in a child process --------------------------------------- */

static double render_mrays(const accel *acc, const render_settings *rs, int res,
                           unsigned long long *rays)
{
    image img;
    rr_error err;
    volatile sig_atomic_t never = 0;
    image_alloc(&img, res, res);
    render_image(acc, rs, &img, NULL, &never, &err);
    *rays = img.rays;
    image_free(&img);
    return img.rays / img.seconds * 1e-6;
}

static int may_hit_moving(const accel *a, vec3 org, vec3 dir)
{
    accel_ray ray;
    accel_ray_begin(a, org, dir, &ray);
    return ray.may_hit_moving;
}

static render_settings bench_settings(const bench_case *c)
{
    render_settings rs = render_settings_default();
    /* the thesis sampler, as these rows were always measured: the rays stay comparable */
    rs.smp.kind = SAMPLER_THESIS;
    rs.smp.grid = 2, rs.smp.tspp = c->tspp, rs.smp.time_factor = 4;
    rs.threads = c->threads;
    return rs;
}

static accel *build_or_die(const scene *s, int reuse_static)
{
    accel *acc;
    rr_error err;
    accel_settings set = {s->epsilon, s->kernel_sigma, reuse_static};
    if (accel_build(s, &set, &acc, &err)) {
        fprintf(stderr, "bench: %s\n", err.msg);
        exit(1);
    }
    return acc;
}

/* The case's scene and settings, and its BVHs (with static reuse), timed. */
static accel *setup_case(const bench_case *c, scene *s, surfel **surfels, size_t *n, render_settings *rs,
                         bench_result *r)
{
    build_scene(c, s, surfels, n);
    *rs = bench_settings(c);
    double t0 = rr_seconds();
    accel *acc = build_or_die(s, 1);
    r->build_ms = 1e3 * (rr_seconds() - t0);
    return acc;
}

/* Two renders of one scene alternated, the medians compared (mrays against
 * base_mrays): static80's reuse against tracing every time sample
 * separately, or the thread scaling's N threads against 1. */
static void run_pair_case(const bench_case *c, bench_result *r)
{
    scene s;
    surfel *surfels;
    size_t n;
    render_settings rs;
    accel *with = setup_case(c, &s, &surfels, &n, &rs, r);
    accel *without = c->scaling ? with : build_or_die(&s, 0);
    render_settings base_rs = rs;
    if (c->scaling)
        base_rs.threads = 1;
    double a[16], b[16];
    for (int k = 0; k < c->reps; k++) {
        a[k] = render_mrays(with, &rs, c->res, &r->rays);
        b[k] = render_mrays(without, &base_rs, c->res, &r->rays);
    }
    r->mrays = median(a, c->reps);
    r->base_mrays = median(b, c->reps);
    r->base_build_ms = 0;
    r->same_rays_mrays = 0;
    r->base_splats_px = r->same_splats_px = 0;
    r->peak_mb = bench_peak_mb();
    r->bytes_per_splat = 0;
    int meets = 0;
    for (int y = 0; y < c->res; y++)
        for (int x = 0; x < c->res; x++)
            meets += may_hit_moving(with, s.cam.position, camera_ray_direction(&s.cam, x + 0.5, y + 0.5));
    r->moving_share = meets / ((double)c->res * c->res);
    if (without != with)
        accel_free(without);
    accel_free(with);
    scene_free(&s);
    free(surfels);
}

static void run_case(const bench_case *c, bench_result *r)
{
    if (c->background || c->scaling) {
        run_pair_case(c, r);
        return;
    }
    scene s;
    surfel *surfels;
    size_t n;
    render_settings rs;
    accel *acc = setup_case(c, &s, &surfels, &n, &rs, r);
    /* splat arrays (pointmodel.h: 48 + 6 * 4 + 3 * 4 bytes) plus Embree's peak for the BVHs */
    r->bytes_per_splat = 84.0 + (double)accel_embree_peak_bytes(acc) / (double)n;
    RTCDevice dev = rtcNewDevice(NULL);
    double t0 = rr_seconds();
    RTCScene base = baseline_build(dev, surfels, n);
    r->base_build_ms = 1e3 * (rr_seconds() - t0);
    floor_discs discs, discs_eps;
    RTCScene user = c->floor ? floor_build(dev, base, n, 0, &discs) : NULL;
    RTCScene user_eps = c->floor ? floor_build(dev, base, n, (float)s.epsilon, &discs_eps) : NULL;
    double ours[16], theirs[16], same[16], floor[16], floor_eps[16], rays = (double)c->res * c->res * 4 * c->tspp;
    for (int k = 0; k < c->reps; k++) { /* interleaved repetitions */
        ours[k] = render_mrays(acc, &rs, c->res, &r->rays);
        theirs[k] = rays / baseline_seconds(base, &s, &rs, 0, 0, NULL) * 1e-6;
        same[k] = rays / baseline_seconds(base, &s, &rs, 1, 0, NULL) * 1e-6;
        floor[k] = user ? rays / baseline_seconds(user, &s, &rs, 1, 0, NULL) * 1e-6 : 0;
        floor_eps[k] = user ? rays / baseline_seconds(user_eps, &s, &rs, 1, 0, NULL) * 1e-6 : 0;
    }
    r->floor_mrays = median(floor, c->reps);
    r->floor_eps_mrays = median(floor_eps, c->reps);
    r->floor_splats_px = 0;
    if (user) { /* (untimed) the same discs found as the built-in ones? */
        baseline_seconds(user, &s, &rs, 1, 1, &r->floor_splats_px);
        rtcReleaseScene(user), rtcReleaseScene(user_eps);
    }
    baseline_seconds(base, &s, &rs, 0, 1, &r->base_splats_px);
    baseline_seconds(base, &s, &rs, 1, 1, &r->same_splats_px);
    r->mrays = median(ours, c->reps);
    r->base_mrays = median(theirs, c->reps);
    r->same_rays_mrays = median(same, c->reps);
    r->peak_mb = bench_peak_mb();
    rtcReleaseScene(base);
    rtcReleaseDevice(dev);
    accel_free(acc);
    scene_free(&s);
    free(surfels);
}

static void run_case_child(const void *in, void *out) { run_case(in, out); }

static int run_in_child(const bench_case *c, bench_result *r)
{
    return bench_in_child(run_case_child, c, r, sizeof *r);
}

static int wanted(const char *only, const char *series)
{
    return !only || !strcmp(only, series);
}

static void print_csv_row(FILE *csv, const char *series, const bench_case *c, const bench_result *r)
{
    double deg = strcmp(c->motion, "rotation") ? 0 : c->degrees ? c->degrees : 90;
    double same = r->same_rays_mrays > 0 ? r->mrays / r->same_rays_mrays : 0;
    fprintf(csv, "%s,%d,%s,%.1f,%s,%d,%d,%d,%.1f,%.1f,%.4f,%.4f,%.4f,%.4f,%.4f,%.1f,%.1f,%.2f,%.2f,%.4f,%.4f\n", series,
            c->splats, c->motion, deg, c->elliptical ? "elliptical" : "circular", c->tspp, c->threads, c->res,
            r->build_ms, r->base_build_ms, r->mrays, r->base_mrays, r->mrays / r->base_mrays, r->same_rays_mrays,
            same, r->peak_mb, r->bytes_per_splat, r->base_splats_px, r->same_splats_px, r->floor_mrays,
            r->floor_eps_mrays);
}

static void print_row(FILE *csv, const char *series, const bench_case *c, const bench_result *r)
{
    double deg = strcmp(c->motion, "rotation") ? 0 : c->degrees ? c->degrees : 90;
    double same = r->same_rays_mrays > 0 ? r->mrays / r->same_rays_mrays : 0;
    printf("| %-9s | %8d | %-8s | %4.0f | %-10s | %4d | %2d | %8.0f | %8.0f | %6.2f | %6.2f | %5.2fx | %6.2f | %5.2fx "
           "| %7.0f | %6.0f | %5.1f | %6.1f |\n",
           series, c->splats, c->motion, deg, c->elliptical ? "elliptical" : "circular", c->tspp, c->threads,
           r->build_ms, r->base_build_ms, r->mrays, r->base_mrays, r->mrays / r->base_mrays, r->same_rays_mrays,
           same, r->peak_mb, r->bytes_per_splat, r->base_splats_px, r->same_splats_px);
    print_csv_row(csv, series, c, r);
    fflush(stdout);
    fflush(csv);
}

/* Surfels against the floor of their design: the same discs as user
 * geometry (floor_intersect) on the same rays, at each rotation speed and
 * at 4x the splats. refrender / floor is what its own work costs; floor /
 * discs what user primitives cost against Embree's built-in ones. */
static void bench_floor(int speeds, int splats, int tspp, int threads, int res, int reps, FILE *csv)
{
    static const double degrees[] = {90, 10, 1};
    printf("\nfloor: the same discs as Embree user geometry (one callback per candidate, the disc test) on the\n"
           "same rays, closest hit ('user'), and kept to the closest hit + epsilon as blending needs ('user eps'):\n"
           "what refrender's design and its definition cost before its own work. Mrays/s.\n\n"
           "| splats | deg/t | refrender | discs | user | user eps | refrender / discs | user / discs "
           "| user eps / discs | refrender / user eps | discs/px built-in, user |\n"
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for (int i = 0; i <= speeds; i++) {
        int last = i == speeds; /* then 4x the splats at the fastest speed */
        bench_case c = {.motion = "rotation", .splats = last ? 4 * splats : splats, .tspp = tspp, .threads = threads,
                        .res = res, .reps = reps, .degrees = degrees[last ? 0 : i], .floor = 1};
        bench_result r;
        if (run_in_child(&c, &r))
            continue;
        print_csv_row(csv, "floor", &c, &r);
        printf("| %d | %.0f | %.2f | %.2f | %.2f | %.2f | %.2fx | %.2fx | %.2fx | %.2fx | %.1f, %.1f |\n", c.splats,
               c.degrees, r.mrays, r.same_rays_mrays, r.floor_mrays, r.floor_eps_mrays, r.mrays / r.same_rays_mrays,
               r.floor_mrays / r.same_rays_mrays, r.floor_eps_mrays / r.same_rays_mrays, r.mrays / r.floor_eps_mrays,
               r.same_splats_px, r.floor_splats_px);
        fflush(stdout);
    }
}

/* What a run measures: the scale (quick or full), the image, the
 * repetitions, the threads, and which series (NULL: all of them). */
typedef struct {
    int quick, res, reps, threads;
    int big, small, tspp; /* splat counts of the large and small model; time samples */
    /* one series: cases, speed, splats, tspp, threads, static80, target, floor, splat, gaussians, scale, stg */
    const char *only;
    FILE *csv;
} bench_plan;

/* A rotating sphere of the plan's defaults: `splats` splats, 90 degrees a
 * unit time, circular splats, the plan's tspp and threads. */
static bench_case rotation_case(const bench_plan *p, int splats)
{
    return (bench_case){.motion = "rotation", .splats = splats, .tspp = p->tspp, .threads = p->threads,
                        .res = p->res, .reps = p->reps};
}

/* Runs one case in its own process and prints its row (nothing if it failed). */
static int run_and_print(const bench_plan *p, const char *series, const bench_case *c, bench_result *r)
{
    if (run_in_child(c, r))
        return -1;
    print_row(p->csv, series, c, r);
    return 0;
}

static FILE *open_csv(const char *path)
{
    FILE *csv = fopen(path, "w");
    if (!csv) {
        perror(path);
        return NULL;
    }
    fprintf(csv, "series,splats,motion,degrees_per_time,splat,tspp,threads,res,build_ms,baseline_build_ms,mrays,"
                 "baseline_mrays,ratio,same_rays_baseline_mrays,same_rays_ratio,peak_mb,bytes_per_splat,"
                 "base_splats_per_pixel,same_rays_splats_per_pixel,user_geometry_mrays,user_geometry_epsilon_mrays\n");
    return csv;
}

static void print_intro(const bench_plan *p)
{
    printf("refrender-bench: %dx%d pixels, 4 spatial samples, thesis sampler, median of %d interleaved runs\n\n"
           "'base': Embree's built-in discs, closest hit, on the world rays of the scene at rest (no motion);\n"
           "'same rays': the same discs on the object-space rays refrender traces (each time's ray moved by the\n"
           "inverse motion), which pay motion's cache misses too. Ratios are refrender / baseline.\n"
           "'splats/px': distinct discs the baseline's rays hit per covered pixel, at rest and on the same rays.\n\n"
           "| series | splats | motion | deg/t | splat | tspp | thr | build ms | base build ms | Mrays/s | base Mrays/s | ratio "
           "| same rays Mrays/s | ratio same rays | peak MB | B/splat | splats/px rest | splats/px same rays |\n"
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
           p->res, p->res, p->reps);
}

/* Every motion with circular and elliptical splats, at both model sizes. */
static void series_cases(const bench_plan *p)
{
    static const char *const motions[] = {"static", "linear", "rotation"};
    bench_result r;
    for (int size = 0; size < 2; size++)
        for (int m = 0; m < 3; m++)
            for (int e = 0; e < 2; e++) {
                bench_case c = rotation_case(p, size ? p->big : p->small);
                c.motion = motions[m], c.elliptical = e;
                run_and_print(p, "cases", &c, &r);
            }
}

/* The headline case alone (the large model rotating 90 degrees a unit),
 * for quick iterations on the surfel path. */
static void series_target(const bench_plan *p)
{
    bench_result r;
    bench_case c = rotation_case(p, p->big);
    run_and_print(p, "target", &c, &r);
}

/* Rotation speeds of 1, 10 and 90 degrees a unit (quick: 1 only). */
static void series_speed(const bench_plan *p)
{
    static const double speeds[] = {1, 10, 90};
    bench_result r;
    for (int i = 0; i < (p->quick ? 1 : 3); i++) {
        bench_case c = rotation_case(p, p->big);
        c.degrees = speeds[i];
        run_and_print(p, "speed", &c, &r);
    }
}

/* Model sizes from 10k to 4M splats (quick: 10k only). */
static void series_splats(const bench_plan *p)
{
    static const int counts[] = {10000, 100000, 1000000, 4000000};
    bench_result r;
    for (int i = 0; i < (p->quick ? 1 : 4); i++) {
        bench_case c = rotation_case(p, counts[i]);
        run_and_print(p, "splats", &c, &r);
    }
}

/* Time samples per spatial sample of 10, 30 and 100 (quick: 10 only). */
static void series_tspp(const bench_plan *p)
{
    static const int tspps[] = {10, 30, 100};
    bench_result r;
    for (int i = 0; i < (p->quick ? 1 : 3); i++) {
        bench_case c = rotation_case(p, p->big);
        c.tspp = tspps[i];
        run_and_print(p, "tspp", &c, &r);
    }
}

/* Each thread count from 1 to the cores, in separate processes; then all
 * cores against 1, alternated in one process. */
static void series_threads(const bench_plan *p)
{
    bench_result r;
    for (int t = 1; t <= p->threads; t++) {
        bench_case c = rotation_case(p, p->big);
        c.threads = t;
        run_and_print(p, "threads", &c, &r);
    }
    bench_case scaling = rotation_case(p, p->big);
    scaling.scaling = 1;
    if (p->threads > 1 && !run_and_print(p, "scaling", &scaling, &r))
        printf("\nscaling: %d threads against 1, alternated in one process ('base' = 1 thread): %.2fx\n\n", p->threads,
               r.mrays / r.base_mrays);
}

/* The small rotating sphere in front of a static wall that fills the image. */
static void series_static80(const bench_plan *p)
{
    bench_result r;
    bench_case c80 = rotation_case(p, p->small);
    c80.background = 1;
    printf("\nstatic80: a static wall fills the image, a rotating sphere covers about 15%% of it; 'base' is\n"
           "the same render tracing every time sample separately (--no-static-reuse), 'ratio' the speed-up.\n\n");
    if (!run_and_print(p, "static80", &c80, &r))
        printf("\nstatic80: %.1f%% of the pixels' rays meet the moving object's swept bounds\n", 100 * r.moving_share);
}

/* The splatting comparands on the small rotating sphere (bench_splat.h). */
static void series_splat(const bench_plan *p)
{
    bench_case c = rotation_case(p, p->small);
    scene s;
    surfel *surfels;
    size_t n;
    build_scene(&c, &s, &surfels, &n);
    accel *acc = build_or_die(&s, 1);
    bench_splat(&s, acc, p->res, p->csv);
    accel_free(acc);
    scene_free(&s);
    free(surfels);
}

/* Usage: refrender-bench [CSV [quick|full [SERIES]]]. */
static const char *const SERIES[] = {"cases", "target", "speed", "splats", "tspp", "threads", "floor",
                                     "static80", "splat", "gaussians", "scale", "stg", NULL};

static void bench_usage(FILE *f)
{
    fputs("usage: refrender-bench [OUT.csv [quick|full [SERIES]]]\n"
          "\n"
          "Measures refrender's render path against Embree's built-in disc primitive\n"
          "(src/bench/BENCH.md) and writes the CSV (default bench.csv). quick: a short\n"
          "smoke run; full (the default): the measurements. SERIES runs one series\n"
          "only: cases, target, speed, splats, tspp, threads, floor, static80,\n"
          "gaussians, scale or stg. Takes minutes (quick) to hours (full).\n"
          "  -h, --help   this text\n", f);
}

/* The arguments are positional: an option-looking one is --help or a
 * mistake, never a file name (--help once became a CSV named "--help" and
 * started the full benchmark). Returns -1 to go on, else the exit status. */
static int check_args(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help"))
            return bench_usage(stdout), 0;
        if (argv[i][0] == '-') {
            fprintf(stderr, "refrender-bench: unknown option '%s'; try 'refrender-bench --help'\n", argv[i]);
            return 2;
        }
    }
    int series_known = argc <= 3;
    for (int k = 0; !series_known && SERIES[k]; k++)
        series_known = !strcmp(argv[3], SERIES[k]);
    if (argc > 4 || (argc > 2 && strcmp(argv[2], "quick") && strcmp(argv[2], "full")) || !series_known) {
        fputs("refrender-bench: expected [OUT.csv [quick|full [SERIES]]]; try 'refrender-bench --help'\n", stderr);
        return 2;
    }
    return -1;
}

int main(int argc, char **argv)
{
    int status = check_args(argc, argv);
    if (status >= 0)
        return status;
    int quick = argc > 2 && !strcmp(argv[2], "quick");
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    bench_plan p = {
        .quick = quick,
        .res = quick ? 48 : 128,
        .reps = quick ? 1 : 3,
        .threads = cores > 0 ? (int)cores : 1,
        .big = quick ? 20000 : 1000000,
        .small = quick ? 5000 : 100000,
        .tspp = quick ? 8 : 100,
        .only = argc > 3 ? argv[3] : NULL,
        .csv = open_csv(argc > 1 ? argv[1] : "bench.csv"),
    };
    if (!p.csv)
        return 1;
    print_intro(&p);
    if (wanted(p.only, "cases"))
        series_cases(&p);
    if (p.only && !strcmp(p.only, "target"))
        series_target(&p);
    if (wanted(p.only, "speed"))
        series_speed(&p);
    if (wanted(p.only, "splats"))
        series_splats(&p);
    if (wanted(p.only, "tspp"))
        series_tspp(&p);
    if (wanted(p.only, "threads"))
        series_threads(&p);
    if (wanted(p.only, "floor"))
        bench_floor(quick ? 1 : 3, quick ? p.small : p.big, p.tspp, p.threads, p.res, p.reps, p.csv);
    if (wanted(p.only, "static80"))
        series_static80(&p);
    if (wanted(p.only, "splat"))
        series_splat(&p);
    if (wanted(p.only, "gaussians") && bench_gaussians(quick, p.threads, p.csv))
        fprintf(stderr, "bench: the gaussians case failed\n");
    /* alone, for quick iterations */
    if (p.only && !strcmp(p.only, "scale") && bench_gaussian_scale(quick, p.threads, p.csv))
        fprintf(stderr, "bench: the scale case failed\n");
    if (p.only && !strcmp(p.only, "stg") && bench_gaussian_stg(quick, p.threads, p.csv))
        fprintf(stderr, "bench: the stg case failed\n");
    fclose(p.csv);
    return 0;
}
