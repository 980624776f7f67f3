#include "bench/bench_gaussian.h"

#include <embree3/rtcore.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "gaussians/gaussian_stg.h"
#include "render/gaussian_integrator.h"
#include "formats/gaussian_ply.h"
#include "render/render.h"
#include "surfels/shapes.h"

/* A unit sphere of 2DGS surfels or of 3DGS Gaussians 2% as thick (SH
 * degree 3, as trained models have) seen from 3.5 units by a camera
 * panning (0.3, 0.1, 0) per unit time over the shutter [0, 1]: a
 * deblurring benchmark's camera shake. */
typedef struct {
    size_t count;
    int res, threads, reps;
    gaussian_kind kind; /* 2D: 2DGS; 3D: the graphdeco-inria rasterizer's semantics (the default) */
} gs_case;

typedef struct {
    double build_ms, mrays, base_mrays, peak_mb, model_bytes, embree_bytes;
    double gathered, composited, base_hits; /* per ray */
} gs_result;

/* A model's own bytes per Gaussian: mean, scale, quaternion, opacity and
 * its SH coefficients, as floats (gaussian.h), and a moving model's
 * trbf_center, trbf_scale, motion, omega and rot (gaussian_dynamic.h). */
static double model_bytes_per_gaussian(const gaussian_model *m)
{
    size_t floats = 3 + 3 + 4 + 1 + 3 * (size_t)m->sh_coeffs;
    if (m->dynamic)
        floats += 1 + 1 + 9 + 4 + 4;
    return (double)(floats * sizeof(float));
}

/* A scene of one object: count Gaussians of kind and SH degree sh_degree
 * made from the default shape, seen from (0, 0, 3.5) with a 40 degree
 * field of view at width x height; exits on failure. */
static gaussian_model *one_model_scene(scene *s, int width, int height, size_t count, gaussian_kind kind,
                                       int sh_degree)
{
    scene_init(s);
    s->cam.position = v3(0, 0, 3.5);
    s->cam.width = width, s->cam.height = height;
    s->cam.fov_degrees = 40;
    camera_prepare(&s->cam, NULL);
    shape_params p;
    shape_params_default(&p);
    p.count = count;
    surfel *sf;
    size_t n;
    rr_error err;
    scene_object *o = scene_add_object(s);
    if (!o) {
        fprintf(stderr, "bench: out of memory\n");
        exit(1);
    }
    o->kind = OBJECT_GAUSSIANS;
    if (shape_generate(&p, &sf, &n, &err) || gaussian_from_surfels(sf, n, kind, sh_degree, &o->gaussians, &err)) {
        fprintf(stderr, "bench: %s\n", err.msg);
        exit(1);
    }
    free(sf);
    return &o->gaussians;
}

static void gs_scene(const gs_case *c, scene *s)
{
    one_model_scene(s, c->res, c->res, c->count, c->kind, 3);
    s->camera_motion.velocity = v3(0.3, 0.1, 0);
}

/* ---- baseline: built-in oriented discs, every hit gathered ------------ */

typedef struct {
    struct RTCIntersectContext rtc; /* first: Embree passes this pointer to the filter */
    float *t;
    size_t count, cap;
} all_hits;

/* Keeps the hit and rejects it, so the traversal goes on to the next. */
static void gather_filter(const struct RTCFilterFunctionNArguments *args)
{
    all_hits *h = (all_hits *)args->context;
    for (unsigned i = 0; i < args->N; i++) {
        if (!args->valid[i])
            continue;
        RR_CHECK(rr_grow((void **)&h->t, &h->cap, h->count + 1, sizeof *h->t) == 0); /* a benchmark: no recovery */
        h->t[h->count++] = ((const float *)args->ray)[8 * args->N + i]; /* tfar: SOA field 8 (rtcore_ray.h) */
        args->valid[i] = 0;
    }
}

/* Discs of the radius refrender's boxes hold for each Gaussian: the
 * kernel's 1/255 radius (3.33 scales) or the low-pass filter's footprint
 * at the camera's farthest distance over the shutter, so both find the
 * same candidates. */
static RTCScene disc_scene(RTCDevice dev, const scene *sc, const gaussian_model *m)
{
    camera_view v;
    camera_view_rest(&sc->cam, &v);
    aabb cam = animation_swept_bounds(&sc->camera_motion, (aabb){sc->cam.position, sc->cam.position}, 0, 1);
    RTCScene scene = rtcNewScene(dev);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT);
    float *vtx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 16, m->count);
    float *nrm = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, 12, m->count);
    for (size_t i = 0; i < m->count; i++) {
        const float *q = &m->rotation[4 * i], *s = &m->scale[3 * i];
        double w = q[0], x = q[1], y = q[2], z = q[3], k = sqrt(gaussian_alpha_reach2(m->opacity[i]));
        memcpy(&vtx[4 * i], &m->mean[3 * i], 3 * sizeof(float));
        const float *mu = &m->mean[3 * i];
        vec3 far = v3(fmax(fabs(mu[0] - cam.lo.x), fabs(mu[0] - cam.hi.x)),
                      fmax(fabs(mu[1] - cam.lo.y), fabs(mu[1] - cam.hi.y)),
                      fmax(fabs(mu[2] - cam.lo.z), fabs(mu[2] - cam.hi.z)));
        gaussian_view_bound vb = {v3_len(far), fmin(v.fx, v.fy), gaussian_view_stretch(&v), gaussian_filter_near(1, 1),
                                  v3(0, 0, 0), M_PI}; /* the disc's radius: the reach any way */
        vtx[4 * i + 3] = (float)fmax(k * fmax(s[0], fmax(s[1], s[2])), gaussian_view_reach(m, i, &vb));
        nrm[3 * i] = (float)(2 * (x * z + w * y)), nrm[3 * i + 1] = (float)(2 * (y * z - w * x));
        nrm[3 * i + 2] = (float)(1 - 2 * (x * x + y * y));
    }
    rtcSetGeometryIntersectFilterFunction(g, gather_filter);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    return scene;
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

typedef struct {
    RTCScene discs;
    const scene *sc;
    const render_settings *rs;
    int next_row;
    pthread_mutex_t lock;
    unsigned long long hits;
} disc_job;

/* The render's own rays (sampler, times, moving camera); each ray's hits
 * gathered and sorted by distance, as compositing needs them. */
static void *disc_worker(void *arg)
{
    disc_job *job = arg;
    const sampler *smp = &job->rs->smp;
    sampler_scratch ss;
    if (sampler_scratch_init(&ss, smp)) {
        fprintf(stderr, "refrender-bench: out of memory for the sampler's scratch\n");
        exit(1);
    }
    int n = (int)sampler_count(smp);
    double *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y), *t = malloc(n * sizeof *t);
    double *w = malloc(n * sizeof *w); /* the weights: unused, the rays are what is measured */
    all_hits h = {0};
    unsigned long long hits = 0;
    for (int row; (pthread_mutex_lock(&job->lock), row = job->next_row++, pthread_mutex_unlock(&job->lock),
                   row < job->sc->cam.height);)
        for (int px = 0; px < job->sc->cam.width; px++) {
            sampler_batch(smp, 0, 1, (uint64_t)row * job->sc->cam.width + px, px, row, 0, &ss, x, y, t, w);
            for (int i = 0; i < n; i++) {
                vec3 o, d;
                scene_camera_ray(job->sc, x[i], y[i], t[i], &o, &d);
                struct RTCRayHit rh;
                memset(&rh, 0, sizeof rh);
                rh.ray.org_x = (float)o.x, rh.ray.org_y = (float)o.y, rh.ray.org_z = (float)o.z;
                rh.ray.dir_x = (float)d.x, rh.ray.dir_y = (float)d.y, rh.ray.dir_z = (float)d.z;
                rh.ray.tfar = INFINITY, rh.ray.mask = 0xFFFFFFFFu, rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rtcInitIntersectContext(&h.rtc);
                h.count = 0;
                rtcIntersect1(job->discs, &h.rtc, &rh);
                qsort(h.t, h.count, sizeof *h.t, cmp_float);
                hits += h.count;
            }
        }
    pthread_mutex_lock(&job->lock);
    job->hits += hits;
    pthread_mutex_unlock(&job->lock);
    sampler_scratch_free(&ss);
    free(x), free(y), free(t), free(w), free(h.t);
    return NULL;
}

static double disc_seconds(RTCScene discs, const scene *s, const render_settings *rs, unsigned long long *hits)
{
    disc_job job = {discs, s, rs, 0, PTHREAD_MUTEX_INITIALIZER, 0};
    pthread_t tids[64];
    int threads = rs->threads < 64 ? rs->threads : 64;
    double t0 = rr_seconds();
    for (int i = 0; i < threads; i++)
        pthread_create(&tids[i], NULL, disc_worker, &job);
    for (int i = 0; i < threads; i++)
        pthread_join(tids[i], NULL);
    *hits = job.hits;
    return rr_seconds() - t0;
}

/* ---- refrender ---------------------------------------------------------- */

/* Hits evaluated and composited per ray, over the pixel centres at mid-shutter (untimed). */
static void count_hits(const scene *s, const accel *a, gs_result *r)
{
    gaussian_integrator g;
    gaussian_integrator_init(&g, NULL);
    double gathered = 0, composited = 0;
    for (int y = 0; y < s->cam.height; y++)
        for (int x = 0; x < s->cam.width; x++) {
            vec3 o, d;
            camera_view v;
            scene_camera_ray(s, x + 0.5, y + 0.5, 0.5, &o, &d);
            scene_camera_view(s, 0.5, &v);
            gaussian_integrator_reset(&g);
            g.hits.added = 0;
            gaussian_blend b;
            gaussian_blend_init(&b);
            gaussian_sample smp = {&v, x + 0.5, y + 0.5, o, d, 0.5};
            gaussian_integrate(s, a, &smp, INFINITY, &g, &b);
            gathered += (double)g.hits.added;
            composited += (double)b.composited;
        }
    double rays = (double)s->cam.width * s->cam.height;
    r->gathered = gathered / rays, r->composited = composited / rays;
    gaussian_integrator_free(&g);
}

/* One render of the scene's view: its seconds, and its Mrays/s in *mrays;
 * exits on failure. */
static double render_timed(const scene *s, const accel *a, const render_settings *rs, double *mrays)
{
    image img;
    rr_error err;
    volatile sig_atomic_t never = 0;
    image_alloc(&img, s->cam.width, s->cam.height);
    if (render_image(a, rs, &img, NULL, &never, &err)) {
        fprintf(stderr, "bench: %s\n", err.msg);
        exit(1);
    }
    double seconds = img.seconds;
    *mrays = (double)img.rays / img.seconds * 1e-6;
    image_free(&img);
    return seconds;
}

static double median3(double *v, int n)
{
    for (int i = 1; i < n; i++) /* n is small */
        for (int j = i; j > 0 && v[j] < v[j - 1]; j--) {
            double tmp = v[j];
            v[j] = v[j - 1], v[j - 1] = tmp;
        }
    return v[n / 2];
}

/* The scene's acceleration structure over its shutter; exits on failure. */
static accel *build_timed(const scene *s, double *build_ms)
{
    accel_settings set = {s->epsilon, s->kernel_sigma, 1};
    accel *a;
    rr_error err;
    double t0 = rr_seconds();
    if (accel_build(s, &set, &a, &err)) {
        fprintf(stderr, "bench: %s\n", err.msg);
        exit(1);
    }
    *build_ms = 1e3 * (rr_seconds() - t0);
    return a;
}

static void gs_run(const gs_case *c, gs_result *r)
{
    scene s;
    gs_scene(c, &s);
    const gaussian_model *m = &s.objects[0].gaussians;
    r->model_bytes = model_bytes_per_gaussian(m);
    render_settings rs = render_settings_default();
    /* the thesis sampler, as these rows were always measured: the rays stay comparable */
    rs.smp.kind = SAMPLER_THESIS;
    rs.smp.grid = 2, rs.smp.tspp = 4, rs.smp.time_factor = 4;
    rs.threads = c->threads;
    accel *a = build_timed(&s, &r->build_ms);
    r->embree_bytes = (double)accel_embree_peak_bytes(a) / (double)m->count;
    RTCDevice dev = rtcNewDevice(NULL);
    RTCScene discs = disc_scene(dev, &s, m);
    double ours[16], theirs[16], rays = (double)c->res * c->res * 4 * 4;
    unsigned long long hits = 0;
    for (int k = 0; k < c->reps; k++) {
        render_timed(&s, a, &rs, &ours[k]);
        theirs[k] = rays / disc_seconds(discs, &s, &rs, &hits) * 1e-6;
    }
    r->mrays = median3(ours, c->reps), r->base_mrays = median3(theirs, c->reps);
    r->base_hits = (double)hits / rays;
    count_hits(&s, a, r);
    r->peak_mb = bench_peak_mb();
    rtcReleaseScene(discs);
    rtcReleaseDevice(dev);
    accel_free(a);
    scene_free(&s);
}

double bench_peak_mb(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss / 1024.0;
}

int bench_in_child(void (*run)(const void *in, void *out), const void *in, void *out, size_t size)
{
    int fd[2];
    if (pipe(fd))
        return -1;
    pid_t pid = fork();
    if (pid == 0) {
        close(fd[0]);
        run(in, out);
        _exit(write(fd[1], out, size) == (ssize_t)size ? 0 : 1);
    }
    close(fd[1]);
    ssize_t got = read(fd[0], out, size);
    close(fd[0]);
    int status;
    waitpid(pid, &status, 0);
    return got == (ssize_t)size && WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : -1;
}

static void gs_run_child(const void *in, void *out) { gs_run(in, out); }

/* ---- loading ------------------------------------------------------------ */

typedef struct {
    const char *path;
    size_t count;
} load_case;

typedef struct {
    double peak_bytes, model_bytes; /* per Gaussian */
} load_result;

static double resident_bytes(void)
{
    long pages = 0, resident = 0;
    FILE *f = fopen("/proc/self/statm", "r");
    if (f && fscanf(f, "%ld %ld", &pages, &resident) != 2)
        resident = 0;
    if (f)
        fclose(f);
    return (double)resident * (double)sysconf(_SC_PAGESIZE);
}

/* In a child: the peak resident memory gaussian_read adds, per Gaussian. */
static void load_child(const void *in, void *out)
{
    const load_case *c = in;
    load_result *r = out;
    double before = resident_bytes();
    gaussian_model m;
    rr_error err;
    uint64_t hash = 0;
    gaussian_model_init(&m);
    if (gaussian_read(c->path, GAUSSIAN_AUTO, &m, &hash, NULL, &err)) {
        fprintf(stderr, "bench: %s\n", err.msg);
        _exit(1);
    }
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    r->peak_bytes = (ru.ru_maxrss * 1024.0 - before) / (double)m.count;
    r->model_bytes = model_bytes_per_gaussian(&m);
    gaussian_model_free(&m);
}

/* A 1M 3DGS model (SH degree 3) written as the official PLY, then read. */
static int gs_load_row(size_t count)
{
    gs_case c = {count, 64, 1, 1, GAUSSIAN_3D};
    scene s;
    gs_scene(&c, &s);
    char path[] = "/tmp/refrender-bench-XXXXXX.ply";
    int fd = mkstemps(path, 4);
    rr_error err;
    if (fd < 0 || gaussian_write_ply(path, &s.objects[0].gaussians, &err)) {
        fprintf(stderr, "bench: cannot write a model to load\n");
        scene_free(&s);
        return -1;
    }
    close(fd);
    scene_free(&s);
    load_case lc = {path, count};
    load_result r;
    int rc = bench_in_child(load_child, &lc, &r, sizeof r);
    unlink(path);
    if (rc)
        return -1;
    printf("\nloading a 3DGS PLY of %zu Gaussians (SH degree 3): peak %.0f B/Gaussian above the process "
           "(the model itself: %.0f)\n", count, r.peak_bytes, r.model_bytes);
    return 0;
}

static int gs_row(const gs_case *c, FILE *csv)
{
    gs_result r;
    if (bench_in_child(gs_run_child, c, &r, sizeof r))
        return -1;
    const char *kind = c->kind == GAUSSIAN_3D ? "3dgs" : "2dgs";
    printf("| %s | %zu | %.0f | %.2f | %.2f | %.2fx | %.1f / %.1f | %.1f | %.0f | %.0f | %.0f | %.0f |\n", kind,
           c->count, r.build_ms, r.mrays, r.base_mrays, r.mrays / r.base_mrays, r.gathered, r.composited,
           r.base_hits, r.model_bytes, r.embree_bytes, r.model_bytes + r.embree_bytes, r.peak_mb);
    fprintf(csv, "gaussians,%zu,camera,0,%s,4,%d,%d,%.1f,0,%.4f,%.4f,%.4f,0,0,%.1f,%.1f,%.2f,%.2f\n", c->count, kind,
            c->threads, c->res, r.build_ms, r.mrays, r.base_mrays, r.mrays / r.base_mrays, r.peak_mb,
            r.model_bytes + r.embree_bytes, r.composited, r.base_hits);
    fflush(stdout);
    return 0;
}

/* ---- benchmark scale: a view the size trained models are judged at ----- */

/* Three concentric 2DGS spheres (radii 1, 0.75, 0.5: layers of depth
 * behind each other, each ray meets the front one's both sides and the
 * ones inside where the front lets light through) of `per_layer`
 * Gaussians each, SH degree 3, the bench's camera shake, at width x height. */
typedef struct {
    size_t per_layer;
    int width, height, tspp, threads;
} scale_case;

typedef struct {
    double build_ms, seconds, mrays, model_bytes, embree_bytes, peak_mb;
} scale_result;

/* The scale and STG rows' measurement, the same for both: build, one
 * render with --pixel-filter point and tspp x 4 time samples, the bytes
 * per Gaussian of the count, the peak RSS; frees the scene. */
static void point_filter_run(scene *s, int tspp, int threads, size_t count, scale_result *r)
{
    render_settings rs = render_settings_default();
    /* the thesis sampler, as these rows were always measured: the rays stay comparable */
    rs.smp.kind = SAMPLER_THESIS;
    rs.smp.tspp = tspp, rs.smp.time_factor = 4;
    rs.threads = threads;
    rs.filter = PIXEL_FILTER_POINT;
    accel *a = build_timed(s, &r->build_ms);
    r->embree_bytes = (double)accel_embree_peak_bytes(a) / (double)count;
    r->seconds = render_timed(s, a, &rs, &r->mrays);
    r->peak_mb = bench_peak_mb();
    accel_free(a);
    scene_free(s);
}

static void scale_scene(const scale_case *c, scene *s)
{
    static const double radii[3] = {1.0, 0.75, 0.5};
    scene_init(s);
    s->cam.position = v3(0, 0, 3.5);
    s->cam.width = c->width, s->cam.height = c->height;
    s->cam.fov_degrees = 40;
    camera_prepare(&s->cam, NULL);
    s->camera_motion.velocity = v3(0.3, 0.1, 0);
    rr_error err;
    for (int k = 0; k < 3; k++) {
        shape_params p;
        shape_params_default(&p);
        p.count = c->per_layer, p.radius = radii[k];
        surfel *sf;
        size_t n;
        scene_object *o = scene_add_object(s);
        RR_CHECK(o != NULL); /* a benchmark: no recovery */
        o->kind = OBJECT_GAUSSIANS;
        snprintf(o->name, sizeof o->name, "layer%d", k);
        if (shape_generate(&p, &sf, &n, &err) || gaussian_from_surfels(sf, n, GAUSSIAN_2D, 3, &o->gaussians, &err)) {
            fprintf(stderr, "bench: %s\n", err.msg);
            exit(1);
        }
        free(sf);
    }
}

static void scale_run(const void *in, void *out)
{
    const scale_case *c = in;
    scale_result *r = out;
    scene s;
    scale_scene(c, &s);
    size_t count = 0;
    double model = 0;
    for (int k = 0; k < s.nobjects; k++)
        count += s.objects[k].gaussians.count,
            model += model_bytes_per_gaussian(&s.objects[k].gaussians) * (double)s.objects[k].gaussians.count;
    r->model_bytes = model / (double)count;
    point_filter_run(&s, c->tspp, c->threads, count, r);
}

int bench_gaussian_scale(int quick, int threads, FILE *csv)
{
    scale_case c = {quick ? 20000 : 1000000, quick ? 150 : 600, quick ? 100 : 400, quick ? 8 : 64, threads};
    scale_result r;
    printf("\nscale: a benchmark-scale view: three concentric 2DGS spheres (radii 1, 0.75, 0.5) of %zu Gaussians\n"
           "each (%zu in all, SH degree 3) under the same camera shake, %dx%d, --pixel-filter point, 1 x %d\n"
           "samples a pixel, %d threads, one run.\n\n"
           "| Gaussians | build ms | seconds per view | Mrays/s | model B/G | Embree peak B/G | peak RSS MB |\n"
           "| --- | --- | --- | --- | --- | --- | --- |\n", c.per_layer, 3 * c.per_layer, c.width, c.height, c.tspp,
           threads);
    fflush(stdout);
    if (bench_in_child(scale_run, &c, &r, sizeof r))
        return -1;
    printf("| %zu | %.0f | %.1f | %.3f | %.0f | %.0f | %.0f |\n", 3 * c.per_layer, r.build_ms, r.seconds, r.mrays,
           r.model_bytes, r.embree_bytes, r.peak_mb);
    fprintf(csv, "gaussians-scale,%zu,camera,0,2dgs,%d,%d,%dx%d,%.1f,0,%.4f,0,0,0,0,%.1f,%.1f,0,0\n", 3 * c.per_layer,
            c.tspp, threads, c.width, c.height, r.build_ms, r.mrays, r.peak_mb, r.model_bytes + r.embree_bytes);
    fflush(stdout);
    return 0;
}

/* ---- moving Gaussians: SpacetimeGaussians lite against itself frozen --- */

/* A sphere of `count` 3D Gaussians made a SpacetimeGaussians-lite model
 * (gaussian_stg.h) that passes through the sphere at mid-shutter,
 * seen by a fixed camera (STG's datasets are fixed multi-view rigs) over
 * frame 25 of a 50-frame segment at half a frame's exposure: the shutter
 * [0.5, 0.51] of model time. Frozen: the same Gaussians as a static model,
 * each gaussian_dynamic_at the shutter's middle. */
typedef struct {
    size_t count;
    int width, height, tspp, threads, frozen;
} stg_case;

#define STG_OPEN 0.5
#define STG_CLOSE 0.51
#define STG_MID (0.5 * (STG_OPEN + STG_CLOSE))

/* Uniform in [-1, 1), from a fixed 64-bit LCG (Knuth's MMIX constants):
 * the same model in every process. */
static double stg_uniform(uint64_t *state)
{
    *state = *state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*state >> 11) * 0x1.0p-52 - 1.0;
}

/* Gaussian i's motion. Moderate: a swirl about the vertical axis of 1.2
 * units a time unit at the equator plus a random 0.3 (about 3 pixels over
 * the 0.01 exposure at this view: 0.0045 units a pixel at the sphere's
 * front), acceleration and jerk terms, a quaternion rate of about 5 (a few
 * degrees over the exposure), peaks of opacity within 0.03 of mid-shutter
 * and temporal scales 0.03-0.1 (so the opacity changes by up to a third
 * over the exposure). The stored x and rot put it at the sphere's
 * Gaussian at STG_MID. */
static void stg_set_motion(gaussian_model *m, size_t i, uint64_t *rng)
{
    gaussian_stg *d = gaussian_stg_of(m);
    float *x = &m->mean[3 * i], *mo = &d->motion[9 * i];
    double p[3] = {x[0], x[1], x[2]};
    d->trbf_center[i] = (float)(STG_MID + 0.03 * stg_uniform(rng));
    d->trbf_scale[i] = (float)log(0.065 + 0.035 * stg_uniform(rng));
    double D = STG_MID - d->trbf_center[i];
    double swirl[3] = {-1.2 * p[2], 0, 1.2 * p[0]};
    for (int k = 0; k < 3; k++) {
        mo[k] = (float)(swirl[k] + 0.3 * stg_uniform(rng));
        mo[3 + k] = (float)(2.0 * stg_uniform(rng));
        mo[6 + k] = (float)(5.0 * stg_uniform(rng));
        x[k] = (float)(p[k] - (D * mo[k] + D * D * mo[3 + k] + D * D * D * mo[6 + k]));
    }
    double len2 = 0;
    for (int k = 0; k < 4; k++) {
        d->omega[4 * i + k] = (float)(5.0 * stg_uniform(rng));
        d->rot[4 * i + k] = (float)(m->rotation[4 * i + k] - D * d->omega[4 * i + k]);
        len2 += (double)d->rot[4 * i + k] * d->rot[4 * i + k];
    }
    for (int k = 0; k < 4; k++) /* the static array: normalize(rot), the state at D = 0 */
        m->rotation[4 * i + k] = (float)(d->rot[4 * i + k] / sqrt(len2));
    for (int k = 0; k < 3; k++) /* f_dc: the colour itself */
        m->sh[3 * i + k] = (float)(0.28209479177387814 * m->sh[3 * i + k] + 0.5);
}

/* The same Gaussians at STG_MID as a static model of SH degree 0 whose
 * colour is the same RGB (to float rounding: a static model's colour is
 * C0 dc + 0.5, gaussian_sh_color; the cost of that step is a few flops). */
static void stg_freeze(gaussian_model *m)
{
    gaussian_model f = *m;
    f.dynamic = NULL;
    if (gaussian_model_alloc(&f, m->count)) {
        fprintf(stderr, "bench: out of memory\n");
        exit(1);
    }
    for (size_t i = 0; i < m->count; i++) {
        gaussian_dynamic_state st;
        gaussian_dynamic_at(m, i, STG_MID, &st);
        for (int k = 0; k < 3; k++) {
            f.mean[3 * i + k] = (float)st.mean[k], f.scale[3 * i + k] = (float)st.scale[k];
            f.sh[3 * i + k] = (float)((st.rgb[k] - 0.5) / 0.28209479177387814);
        }
        for (int k = 0; k < 4; k++)
            f.rotation[4 * i + k] = (float)st.q[k];
        f.opacity[i] = (float)st.opacity;
    }
    f.count = m->count;
    gaussian_model_free(m);
    *m = f;
}

static void stg_scene(const stg_case *c, scene *s)
{
    gaussian_model *m = one_model_scene(s, c->width, c->height, c->count, GAUSSIAN_3D, 0);
    s->shut.open = STG_OPEN, s->shut.close = STG_CLOSE;
    if (!(m->dynamic = gaussian_stg_alloc(m->count))) {
        fprintf(stderr, "bench: out of memory\n");
        exit(1);
    }
    uint64_t rng = 1;
    for (size_t i = 0; i < m->count; i++)
        stg_set_motion(m, i, &rng);
    if (c->frozen)
        stg_freeze(m);
}

static void stg_run(const void *in, void *out)
{
    const stg_case *c = in;
    scale_result *r = out;
    scene s;
    stg_scene(c, &s);
    const gaussian_model *m = &s.objects[0].gaussians;
    r->model_bytes = model_bytes_per_gaussian(m);
    point_filter_run(&s, c->tspp, c->threads, m->count, r);
}

static void stg_print_row(const char *name, const stg_case *c, const double *seconds, int reps, const scale_result *r,
                          FILE *csv)
{
    double sorted[16];
    memcpy(sorted, seconds, (size_t)reps * sizeof *sorted);
    double median = median3(sorted, reps), rays = (double)c->width * c->height * c->tspp;
    printf("| %s | %zu | %.0f | **%.1f**", name, c->count, r->build_ms, median);
    for (int k = 0; k < reps && reps > 1; k++)
        printf("%s%.1f", k ? ", " : " (", seconds[k]);
    printf("%s | %.3f | %.0f | %.0f | %.0f |\n", reps > 1 ? ")" : "", rays / median * 1e-6, r->model_bytes, r->embree_bytes, r->peak_mb);
    fprintf(csv, "gaussians-stg-%s,%zu,gaussians,0,3dgs,%d,%d,%dx%d,%.1f,0,%.4f,0,0,0,0,%.1f,%.1f,0,0\n",
            c->frozen ? "frozen" : "moving", c->count, c->tspp, c->threads, c->width, c->height, r->build_ms,
            rays / median * 1e-6, r->peak_mb, r->model_bytes + r->embree_bytes);
}

int bench_gaussian_stg(int quick, int threads, FILE *csv)
{
    stg_case moving = {quick ? 20000 : 300000, quick ? 150 : 600, quick ? 100 : 400, quick ? 8 : 64, threads, 0};
    stg_case frozen = moving;
    frozen.frozen = 1;
    int reps = quick ? 1 : 3;
    printf("\nstg: a SpacetimeGaussians-lite model (a sphere of %zu 3D Gaussians, each moving on its own cubic\n"
           "path, turning and fading: src/bench/bench_gaussian.c) over a half-frame exposure [%.2f, %.2f], a fixed\n"
           "camera, %dx%d, --pixel-filter point, 1 x %d samples a pixel, %d threads; against the same Gaussians\n"
           "frozen at %.3f (a static model) on the same rays. Moving and frozen alternate, %d run(s) each,\n"
           "each in its own process; seconds: the median (each run).\n\n"
           "| model | Gaussians | build ms | seconds per view | Mrays/s | model B/G | Embree peak B/G | peak RSS MB |\n"
           "| --- | --- | --- | --- | --- | --- | --- | --- |\n", moving.count, STG_OPEN, STG_CLOSE, moving.width,
           moving.height, moving.tspp, threads, STG_MID, reps);
    fflush(stdout);
    double sec[2][16];
    scale_result r[2];
    for (int k = 0; k < reps; k++)
        for (int f = 0; f < 2; f++) {
            if (bench_in_child(stg_run, f ? &frozen : &moving, &r[f], sizeof r[f]))
                return -1;
            sec[f][k] = r[f].seconds;
        }
    stg_print_row("stg-lite, moving", &moving, sec[0], reps, &r[0], csv);
    stg_print_row("frozen at mid-shutter", &frozen, sec[1], reps, &r[1], csv);
    double m0 = median3(sec[0], reps), m1 = median3(sec[1], reps);
    printf("\nmoving / frozen: %.2fx the time (medians)\n", m0 / m1);
    fflush(stdout);
    return 0;
}

int bench_gaussians(int quick, int threads, FILE *csv)
{
    gs_case c = {quick ? 20000 : 1000000, quick ? 64 : 256, threads, quick ? 1 : 3, GAUSSIAN_2D};
    printf("\ngaussians: a sphere of 2DGS surfels, and of 3DGS Gaussians under the rasterizer's semantics (SH\n"
           "degree 3), under camera motion, %dx%d, 4 spatial x 4 temporal samples, %d threads; 'discs':\n"
           "Embree's built-in oriented discs of the radius refrender's boxes hold (kernel or screen footprint)\n"
           "gathering every hit with a filter function and sorting them, on the same rays.\n\n"
           "| model | Gaussians | build ms | Mrays/s | discs Mrays/s | ratio | hits gathered / composited per ray "
           "| disc hits per ray | model B/G | Embree peak B/G | total B/G | peak RSS MB |\n"
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n", c.res, c.res, c.threads);
    int failed = gs_row(&c, csv);
    c.kind = GAUSSIAN_3D;
    failed |= gs_row(&c, csv);
    failed |= gs_load_row(c.count);
    failed |= bench_gaussian_stg(quick, threads, csv);
    return bench_gaussian_scale(quick, threads, csv) || failed ? -1 : 0;
}
