#include "render/render.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "render/exact.h"
#include "render/gaussian_integrator.h"
#include "render/shade.h"

#define TILE 16

const char *pixel_filter_name(pixel_filter f) { return f == PIXEL_FILTER_POINT ? "point" : "box"; }
const char *blur_space_name(blur_space b)
{
    return b == BLUR_SPACE_LINEAR ? "linear" : b == BLUR_SPACE_CLAMPED ? "clamped" : "model";
}

render_settings render_settings_default(void)
{
    render_settings rs = {
        .smp = {.kind = SAMPLER_DEFAULT, .seed = 1, .grid = 1, .tspp = 1, .time_factor = 1},
        .threads = 1,
        .batch_begin = 0,
        .batches = 1,
        .max_batches = 1,
        .filter = PIXEL_FILTER_BOX,
        .blur = BLUR_SPACE_MODEL,
    };
    shutter_default(&rs.shut);
    return rs;
}

int render_check_exact_blur(int exact_time, blur_space b, rr_error *err)
{
    if (exact_time && b != BLUR_SPACE_MODEL)
        return rr_fail(err, "--blur-space %s %s each instant's colour before the time average, which exact time "
                            "cannot do (it integrates colours over time): use sampled time",
                       blur_space_name(b), b == BLUR_SPACE_LINEAR ? "decodes" : "clamps");
    return 0;
}

typedef struct {
    const scene *sc;
    const accel *acc;
    int camera_moves; /* every sample traces its own world ray */
    int gaussians;    /* the scene has Gaussian objects: so does every sample */
    camera_view rest_view; /* the camera at rest (Gaussian hits, still camera) */
    const render_settings *rs;
    exact_plan *exact; /* with rs->exact_time (the job owns it) */
    shutter_cdf time_cdf;    /* times drawn from a(t) (not used for a box) */
    image *img;
    int tiles_x, tiles_y, ntiles;
    uint32_t round; /* pixels holding `round` batches render batch batch_begin + round */
    atomic_int next_tile, workers_left;
    atomic_uint_fast64_t rays, overflows, clamped, pixel_batches, static_traversals;
    atomic_uint_fast64_t gaussians_short; /* samples that dropped Gaussians for lack of memory */
    atomic_int scratch_failed; /* a worker could not allocate its scratch */
    atomic_int exact_failed;   /* an exact sample failed (see exact_status): the render stops */
    int exact_status, exact_px, exact_py; /* under lock: the first such failure and its pixel */
    double exact_unresolved;   /* under lock: exact_stats.unresolved summed over tiles */
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int paused, active; /* under lock: pause requested; workers inside a tile */
    volatile sig_atomic_t *cancel;
} render_job;

typedef struct { /* per-thread scratch */
    sampler_scratch ss;
    double *x, *y, *t, *w;
    exact_scratch *exact;
    gaussian_integrator gaussian;
} thread_scratch;

/* The color and coverage of a k-buffer (background when empty). */
static void sample_color(const render_job *job, vec3 eye, vec3 dir, const kbuffer *kb, double rgba[4])
{
    const scene *s = job->sc;
    vec3 c = kb->count ? shade_hits(s, kb, eye, dir) : s->background;
    rgba[0] = c.x, rgba[1] = c.y, rgba[2] = c.z, rgba[3] = kb->count ? 1.0 : 0.0;
}

/* Per raster position (a fixed camera's world ray): its static hits from
 * accel, and their color, shaded once and reused for every time at which
 * no moving object is hit. */
typedef struct {
    double x, y;
    accel_ray ray;
    double rgba[4];
    int shaded;
    uint64_t traversals; /* accel_ray_begin calls */
} static_cache;

/* The color of one sample whose hits are `result`. */
static void fixed_camera_color(render_job *job, static_cache *sc, const kbuffer *result, double rgba[4],
                               uint64_t *overflows)
{
    *overflows += (uint64_t)kbuffer_overflowed(result);
    int is_static = result == &sc->ray.static_hits;
    if (is_static && sc->shaded) {
        memcpy(rgba, sc->rgba, sizeof sc->rgba);
        return;
    }
    sample_color(job, job->sc->cam.position, sc->ray.dir, result, rgba);
    if (is_static) {
        memcpy(sc->rgba, rgba, sizeof sc->rgba);
        sc->shaded = 1;
    }
}

/* A fixed camera: samples at the same raster position share one world ray
 * (accel_ray), whose n <= ACCEL_PACKET times are traced together. */
static void samples_fixed_camera(render_job *job, static_cache *sc, double x, double y, const double *t, int n,
                                 double (*rgba)[4], uint64_t *overflows)
{
    if (x != sc->x || y != sc->y) {
        sc->x = x, sc->y = y, sc->shaded = 0;
        sc->traversals++;
        accel_ray_begin(job->acc, job->sc->cam.position, camera_ray_direction(&job->sc->cam, x, y), &sc->ray);
    }
    kbuffer kbs[ACCEL_PACKET];
    const kbuffer *result[ACCEL_PACKET];
    accel_ray_trace_times(job->acc, &sc->ray, t, n, kbs, result);
    for (int i = 0; i < n; i++)
        fixed_camera_color(job, sc, result[i], rgba[i], overflows);
}

/* The Gaussian objects' hits on the ray, composited over the surfaces'
 * colour (the nearest surface hides what is behind it: a Gaussian behind
 * an opaque surface is not seen). */
static void composite_gaussians(render_job *job, double x, double y, double t, vec3 org, vec3 dir,
                                const kbuffer *kb, gaussian_integrator *scratch, double rgba[4])
{
    camera_view moved, *view = &job->rest_view;
    if (job->camera_moves)
        scene_camera_view(job->sc, t, view = &moved);
    gaussian_integrator_reset(scratch);
    gaussian_blend blend;
    gaussian_blend_init(&blend);
    gaussian_sample smp = {view, x, y, org, dir, t};
    gaussian_integrate(job->sc, job->acc, &smp, kb->count ? kb->closest : INFINITY, scratch, &blend);
    /* out of memory, not a full k-buffer: counted apart (a sample with
     * both was counted twice, and warned of as too many hits) */
    scratch->short_samples += scratch->hits.dropped > 0;
    vec3 rgb = gaussian_blend_over(&blend, v3(rgba[0], rgba[1], rgba[2]));
    rgba[0] = rgb.x, rgba[1] = rgb.y, rgba[2] = rgb.z;
    rgba[3] = kb->count ? 1.0 : 1.0 - blend.T;
}

/* A moving camera (thesis eq. 3.6), or a scene with Gaussian objects:
 * every sample has its own world ray. */
static void sample_own_ray(render_job *job, double x, double y, double t, gaussian_integrator *scratch, double rgba[4],
                           uint64_t *overflows)
{
    vec3 org, dir;
    kbuffer kb;
    scene_camera_ray(job->sc, x, y, t, &org, &dir);
    accel_trace(job->acc, org, dir, t, &kb);
    *overflows += (uint64_t)kbuffer_overflowed(&kb);
    sample_color(job, org, dir, &kb, rgba);
    if (job->gaussians)
        composite_gaussians(job, x, y, t, org, dir, &kb, scratch, rgba);
}

/* The next group of samples from `first`: those sharing its raster position
 * (fixed camera; the thesis sampler lists a position's times together), at
 * most ACCEL_PACKET. Returns the index after the group. */
static int next_group(const render_job *job, const thread_scratch *scr, int first, int count, double *t, int *n)
{
    int end = first + 1;
    if (!job->camera_moves && !job->gaussians)
        while (end < count && end - first < ACCEL_PACKET && scr->x[end] == scr->x[first] &&
               scr->y[end] == scr->y[first])
            end++;
    *n = 0;
    for (int i = first; i < end; i++)
        t[(*n)++] = scr->t[i];
    return end;
}

/* The positions and times of batch `batch` of pixel (px, py) into the
 * scratch; returns their count. The sampler's times are uniform over the
 * shutter; unless a(t) is a box they are moved to a(t)'s own distribution
 * (shutter_cdf), which keeps their stratification: the map is monotone. */
static int batch_samples(const render_job *job, int px, int py, uint32_t batch, thread_scratch *scr)
{
    const sampler *smp = &job->rs->smp;
    const shutter *sh = &job->rs->shut;
    uint64_t pixel = (uint64_t)py * (uint64_t)job->img->width + (uint64_t)px;
    sampler_batch(smp, sh->open, sh->close, pixel, px, py, batch, &scr->ss, scr->x, scr->y, scr->t, scr->w);
    int count = (int)sampler_count(smp); /* at most SAMPLER_MAX_TIME_STRATA (check_settings) */
    if (job->rs->filter == PIXEL_FILTER_POINT)
        for (int i = 0; i < count; i++)
            scr->x[i] = px + 0.5, scr->y[i] = py + 0.5;
    if (sh->kind != WEIGHT_BOX)
        for (int i = 0; i < count; i++)
            scr->t[i] = shutter_cdf_time(&job->time_cdf, (scr->t[i] - sh->open) / (sh->close - sh->open));
    if (sh->rolling.kind != ROLLING_OFF) { /* this pixel's line exposes at its own times */
        int lines, line = shutter_line(sh, px, py, job->img->width, job->img->height, &lines);
        for (int i = 0; i < count; i++)
            scr->t[i] = shutter_line_time(sh, line, lines, scr->t[i]);
    }
    return count;
}

static double clamp01(double v) { return fmin(fmax(v, 0.0), 1.0); }

/* The sRGB transfer function's inverse (IEC 61966-2-1) of a value clamped
 * to [0, 1], as an 8-bit frame would hold it. */
static double srgb_to_linear(double v)
{
    v = clamp01(v);
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

/* A sample's colour in the space the pixel averages (--blur-space). */
static void to_blur_space(const render_job *job, double rgba[4])
{
    if (job->rs->blur == BLUR_SPACE_LINEAR)
        for (int c = 0; c < 3; c++)
            rgba[c] = srgb_to_linear(rgba[c]);
    else if (job->rs->blur == BLUR_SPACE_CLAMPED)
        for (int c = 0; c < 3; c++)
            rgba[c] = clamp01(rgba[c]);
}

/* One batch of a pixel (thesis sec. 4.5): the weighted mean of its
 * samples' colors. The thesis weights each sample by a(t) and divides by
 * the sum of the weights; here the times are drawn from a(t) instead
 * (batch_samples), the same expectation without a ratio that is 0/0 for a
 * batch that drew only times of zero weight. The weights left are the
 * sampler's (its shifted time strata, sampler.h): never all 0, and summing
 * to the count whenever each time stratum holds one sample, when the ratio
 * is the plain unbiased mean; dividing by their sum keeps a pixel of one
 * constant colour exactly that colour in every batch.
 * Samples sharing a spatial position (the thesis sampler's s_t times) share
 * the static objects' hits: tracing them again would give the same hits. */
static void render_pixel_batch(render_job *job, int px, int py, uint32_t batch, thread_scratch *scr,
                               double est[4], uint64_t *rays, uint64_t *overflows, uint64_t *statics)
{
    int count = batch_samples(job, px, py, batch, scr);
    double acc[4] = {0, 0, 0, 0}, weight = 0;
    static_cache sc;
    sc.x = sc.y = NAN;
    sc.traversals = 0;
    for (int i = 0; i < count;) {
        double t[ACCEL_PACKET], rgba[ACCEL_PACKET][4];
        int n, first = i;
        i = next_group(job, scr, first, count, t, &n);
        if ((job->camera_moves || job->gaussians) && n)
            sample_own_ray(job, scr->x[first], scr->y[first], t[0], &scr->gaussian, rgba[0], overflows), (*statics)++;
        else if (n)
            samples_fixed_camera(job, &sc, scr->x[first], scr->y[first], t, n, rgba, overflows);
        *rays += (uint64_t)n;
        for (int k = 0; k < n; k++) {
            double w = scr->w[first + k];
            to_blur_space(job, rgba[k]);
            for (int c = 0; c < 4; c++)
                acc[c] += w * rgba[k][c];
            weight += w;
        }
    }
    *statics += sc.traversals;
    RR_DCHECK(count > 0 && weight > 0);
    for (int c = 0; c < 4; c++)
        est[c] = acc[c] / weight;
}

/* One batch of a pixel with exact time integration: the mean over the
 * batch's spatial positions of each one's exact time average. Returns an
 * EXACT_ status: a batch with a sample missing is no estimate, so on
 * failure the pixel gets no batch at all. */
static int render_pixel_batch_exact(render_job *job, int px, int py, uint32_t batch, thread_scratch *scr,
                                    double est[4], uint64_t *rays, uint64_t *overflows, double *unresolved)
{
    int count = batch_samples(job, px, py, batch, scr);
    exact_stats st = {0};
    for (int c = 0; c < 4; c++)
        est[c] = 0;
    for (int i = 0; i < count; i++) {
        double rgba[4];
        int rc = exact_sample(job->exact, scr->exact, scr->x[i], scr->y[i], rgba, &st);
        if (rc)
            return rc;
        for (int c = 0; c < 4; c++)
            est[c] += rgba[c] / count;
    }
    *rays += (uint64_t)count;
    *overflows += st.overflows;
    *unresolved += st.unresolved;
    return EXACT_OK;
}

/* Keeps the first failed exact sample (an interrupt is not a failure: the
 * cancel flag already stops the render). */
static void exact_failed(render_job *job, int status, int px, int py)
{
    if (status == EXACT_INTERRUPTED)
        return;
    pthread_mutex_lock(&job->lock);
    if (!job->exact_status)
        job->exact_status = status, job->exact_px = px, job->exact_py = py;
    pthread_mutex_unlock(&job->lock);
    atomic_store(&job->exact_failed, 1);
}

/* Does a pixel holding p->batches batches take another one? Every pixel
 * takes the first `batches`; with a target error it goes on while its error
 * is above it, up to the cap. Decided from the pixel's own batches only, so
 * the result does not depend on tile order, threads or resumes. */
static int pixel_wants_another(const render_settings *rs, const pixel_state *p)
{
    if (p->batches < rs->batches)
        return 1;
    return rs->target_error > 0 && p->batches < rs->max_batches && film_max_stderr(p) > rs->target_error;
}

/* Does this pixel take a batch in the current round? */
static int pixel_wants_batch(const render_job *job, const pixel_state *p)
{
    return p->batches == job->round && pixel_wants_another(job->rs, p);
}

/* Is the pixel inside the crop window (all are without one)? */
static int pixel_in_crop(const render_settings *rs, int x, int y)
{
    return rs->crop_x1 <= 0 || (x >= rs->crop_x0 && x < rs->crop_x1 && y >= rs->crop_y0 && y < rs->crop_y1);
}

static void render_tile(render_job *job, int tile, thread_scratch *scr)
{
    image *img = job->img;
    int tx = tile % job->tiles_x, ty = tile / job->tiles_x;
    int x1 = (tx + 1) * TILE < img->width ? (tx + 1) * TILE : img->width;
    int y1 = (ty + 1) * TILE < img->height ? (ty + 1) * TILE : img->height;
    uint64_t rays = 0, overflows = 0, clamped = 0, done = 0, statics = 0;
    double unresolved = 0;
    int stop = 0;
    for (int y = ty * TILE; y < y1 && !stop; y++)
        for (int x = tx * TILE; x < x1 && !stop; x++) {
            pixel_state *p = &img->px[(size_t)y * img->width + x];
            if (!pixel_in_crop(job->rs, x, y) || !pixel_wants_batch(job, p))
                continue;
            double est[4];
            uint32_t batch = job->rs->batch_begin + job->round;
            if (job->rs->exact_time) {
                int rc = render_pixel_batch_exact(job, x, y, batch, scr, est, &rays, &overflows, &unresolved);
                if (rc) { /* the pixel keeps the batches it had: a resumed render redoes this one */
                    exact_failed(job, rc, x, y);
                    stop = 1;
                    break;
                }
            } else
                render_pixel_batch(job, x, y, batch, scr, est, &rays, &overflows, &statics);
            clamped += (uint64_t)film_add_batch(p, est);
            done++;
        }
    pthread_mutex_lock(&job->lock);
    job->exact_unresolved += unresolved;
    pthread_mutex_unlock(&job->lock);
    atomic_fetch_add(&job->rays, rays);
    atomic_fetch_add(&job->overflows, overflows);
    atomic_fetch_add(&job->clamped, clamped);
    atomic_fetch_add(&job->pixel_batches, done);
    atomic_fetch_add(&job->static_traversals, statics);
}

/* Blocks while a checkpoint is being written; returns 1 when cancelled. */
static int enter_work(render_job *job)
{
    pthread_mutex_lock(&job->lock);
    while (job->paused && !*job->cancel)
        pthread_cond_wait(&job->cond, &job->lock);
    int stop = *job->cancel != 0 || atomic_load(&job->exact_failed);
    if (!stop)
        job->active++;
    pthread_mutex_unlock(&job->lock);
    return stop;
}

static void leave_work(render_job *job)
{
    pthread_mutex_lock(&job->lock);
    job->active--;
    pthread_cond_broadcast(&job->cond);
    pthread_mutex_unlock(&job->lock);
}

static int scratch_init(thread_scratch *scr, const sampler *s)
{
    size_t n = (size_t)sampler_count(s);
    scr->x = malloc(n * sizeof(double));
    scr->y = malloc(n * sizeof(double));
    scr->t = malloc(n * sizeof(double));
    scr->w = malloc(n * sizeof(double));
    scr->exact = exact_scratch_new();
    gaussian_integrator_init(&scr->gaussian);
    return sampler_scratch_init(&scr->ss, s) || !scr->x || !scr->y || !scr->t || !scr->w || !scr->exact ? -1 : 0;
}

static void scratch_free(thread_scratch *scr)
{
    sampler_scratch_free(&scr->ss);
    free(scr->x);
    free(scr->y);
    free(scr->t);
    free(scr->w);
    exact_scratch_free(scr->exact);
    gaussian_integrator_free(&scr->gaussian);
}

static void *worker(void *arg)
{
    render_job *job = arg;
    thread_scratch scr;
    if (scratch_init(&scr, &job->rs->smp))
        atomic_store(&job->scratch_failed, 1); /* the render fails: no silently black tiles */
    else
        while (!enter_work(job)) {
            int tile = atomic_fetch_add(&job->next_tile, 1);
            if (tile < job->ntiles)
                render_tile(job, tile, &scr);
            leave_work(job);
            if (tile >= job->ntiles)
                break;
        }
    atomic_fetch_add(&job->gaussians_short, scr.gaussian.short_samples);
    scratch_free(&scr);
    pthread_mutex_lock(&job->lock);
    atomic_fetch_sub(&job->workers_left, 1);
    pthread_cond_broadcast(&job->cond); /* wakes the coordinator at once */
    pthread_mutex_unlock(&job->lock);
    return NULL;
}

/* The state written carries the work its batches took so far (the rays of
 * the finished tiles and the seconds), so that a resumed render reports
 * the rays and time of the whole render, as an uninterrupted one. */
static int checkpoint_paused(render_job *job, const render_hooks *hooks, double start, rr_error *err)
{
    pthread_mutex_lock(&job->lock);
    job->paused = 1;
    while (job->active > 0)
        pthread_cond_wait(&job->cond, &job->lock);
    pthread_mutex_unlock(&job->lock);
    image *img = job->img;
    uint64_t rays = img->rays;
    double seconds = img->seconds;
    img->rays += atomic_load(&job->rays), img->seconds += rr_seconds() - start;
    int rc = hooks->checkpoint(hooks->user, img, err);
    img->rays = rays, img->seconds = seconds;
    pthread_mutex_lock(&job->lock);
    job->paused = 0;
    pthread_cond_broadcast(&job->cond);
    pthread_mutex_unlock(&job->lock);
    return rc;
}

/* Sleeps up to 0.1 s, less if a worker finishes. */
static void wait_for_workers(render_job *job)
{
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    until.tv_nsec += 100000000L;
    if (until.tv_nsec >= 1000000000L)
        until.tv_sec++, until.tv_nsec -= 1000000000L;
    pthread_mutex_lock(&job->lock);
    if (atomic_load(&job->workers_left) > 0)
        pthread_cond_timedwait(&job->cond, &job->lock, &until);
    pthread_mutex_unlock(&job->lock);
}

static void report_progress(render_job *job, const render_hooks *hooks, double start)
{
    if (!hooks || !hooks->progress)
        return;
    double planned = (double)job->img->width * job->img->height * job->rs->batches;
    double fraction = fmin(0.999, atomic_load(&job->pixel_batches) / fmax(planned, 1.0));
    hooks->progress(hooks->user, fraction, atomic_load(&job->rays), rr_seconds() - start);
}

/* A failed exact sample stops the render: a pixel cannot be left with a
 * partial average, and a sample past the candidate or evaluation bounds
 * says the scene is beyond exact time integration. */
static int exact_failure(const render_job *job, rr_error *err)
{
    char why[128];
    exact_status_text(job->exact_status, why, sizeof why);
    if (job->exact_status == EXACT_NO_MEMORY || job->exact_status == EXACT_EMBREE_ERROR)
        return rr_fail(err, "exact time integration at pixel (%d, %d): %s", job->exact_px, job->exact_py, why);
    return rr_fail(err,
                   "exact time integration at pixel (%d, %d): one spatial sample needs %s; exact time cannot "
                   "finish this scene in reasonable time: render it with sampled time (the default)",
                   job->exact_px, job->exact_py, why);
}

/* Runs one round over all tiles with the worker threads, writing periodic
 * checkpoints while they are paused. */
static int run_round(render_job *job, const render_hooks *hooks, double start, double *last_checkpoint,
                     rr_error *err)
{
    int threads = job->rs->threads, started = 0, rc = 0;
    pthread_t *tids = calloc((size_t)threads, sizeof *tids);
    atomic_store(&job->next_tile, 0);
    atomic_store(&job->workers_left, threads);
    for (int i = 0; tids && i < threads; i++, started++)
        if (pthread_create(&tids[i], NULL, worker, job))
            break;
    atomic_fetch_sub(&job->workers_left, threads - started);
    if (!started)
        rc = rr_fail(err, "could not start render threads");
    double last_report = 0;
    while (atomic_load(&job->workers_left) > 0) {
        wait_for_workers(job);
        if (rr_seconds() - last_report >= 0.2) {
            report_progress(job, hooks, start);
            last_report = rr_seconds();
        }
        int due = hooks && hooks->checkpoint && hooks->checkpoint_every > 0 &&
                  rr_seconds() - *last_checkpoint >= hooks->checkpoint_every;
        if (due && !*job->cancel && !rc) {
            rr_error ck_err;
            if (checkpoint_paused(job, hooks, start, &ck_err) && hooks->checkpoint_failed)
                hooks->checkpoint_failed(hooks->user, &ck_err);
            *last_checkpoint = rr_seconds();
        }
    }
    for (int i = 0; i < started; i++)
        pthread_join(tids[i], NULL);
    free(tids);
    if (!rc && atomic_load(&job->scratch_failed))
        rc = rr_fail(err, "out of memory for a render thread's samples (%lld per batch)",
                    (long long)sampler_count(&job->rs->smp));
    if (!rc && job->exact_status)
        rc = exact_failure(job, err);
    return rc;
}

/* Will any pixel take a batch in this round or a later one? A resumed
 * checkpoint was written between tiles, in the middle of a round, so some
 * pixels can be a round ahead of all the others that still want batches. */
static int any_pixel_wants_more(const render_job *job)
{
    size_t n = (size_t)job->img->width * job->img->height;
    for (size_t i = 0; i < n; i++) {
        const pixel_state *p = &job->img->px[i];
        int x = (int)(i % (size_t)job->img->width), y = (int)(i / (size_t)job->img->width);
        if (pixel_in_crop(job->rs, x, y) && p->batches >= job->round && pixel_wants_another(job->rs, p))
            return 1;
    }
    return 0;
}

static int check_settings(const render_settings *rs, rr_error *err)
{
    if (rs->threads < 1 || rs->batches < 1)
        return rr_fail(err, "batch and thread counts must be positive");
    if (rs->target_error > 0 && rs->max_batches < rs->batches)
        return rr_fail(err, "the batch cap must be at least the batch count");
    if (render_check_exact_blur(rs->exact_time, rs->blur, err))
        return -1;
    return sampler_check(&rs->smp, err);
}

/* What render_image refuses before any work: settings, a shutter other
 * than the one accel's swept bounds were built for, and what exact time
 * cannot integrate. */
static int check_render_inputs(const accel *a, const render_settings *rs, const image *img, rr_error *err)
{
    if (check_settings(rs, err))
        return -1;
    double open, close, t0, t1;
    accel_shutter(a, &open, &close);
    shutter_span(&rs->shut, img->width, img->height, &t0, &t1);
    if (open != t0 || close != t1) /* swept bounds of another shutter miss hits */
        return rr_fail(err, "internal: accel was built for the times [%g, %g], the render is for [%g, %g]", open,
                       close, t0, t1);
    if (rs->exact_time && rs->shut.rolling.kind != ROLLING_OFF)
        return rr_fail(err, "exact time integration does not integrate a rolling shutter (each line its own "
                            "window): use sampled time");
    if (rs->exact_time && accel_has_gaussians(a))
        return rr_fail(err, "exact time integration does not integrate Gaussian-splat objects: use sampled time");
    return 0;
}

static int job_init(render_job *job, const scene *s, const accel *a, const render_settings *rs, image *img,
                    volatile sig_atomic_t *cancel, rr_error *err)
{
    memset(job, 0, sizeof *job);
    job->sc = s, job->acc = a, job->rs = rs, job->img = img, job->cancel = cancel;
    job->camera_moves = scene_camera_moves(s);
    job->gaussians = accel_has_gaussians(a);
    camera_view_rest(&s->cam, &job->rest_view);
    job->tiles_x = (img->width + TILE - 1) / TILE;
    job->tiles_y = (img->height + TILE - 1) / TILE;
    job->ntiles = job->tiles_x * job->tiles_y;
    shutter_cdf_init(&job->time_cdf, &rs->shut);
    if (rs->exact_time && exact_plan_new(s, a, &rs->shut, 1.0, &job->exact, err))
        return -1;
    if (job->exact)
        exact_plan_watch(job->exact, cancel);
    pthread_mutex_init(&job->lock, NULL);
    pthread_cond_init(&job->cond, NULL);
    return 0;
}

/* The job's statistics into the image, and its resources released. */
static void job_finish(render_job *job, image *img, double start)
{
    pthread_mutex_destroy(&job->lock);
    pthread_cond_destroy(&job->cond);
    exact_plan_free(job->exact);
    img->seconds += rr_seconds() - start;
    img->rays += atomic_load(&job->rays);
    img->kbuffer_overflows += atomic_load(&job->overflows);
    img->gaussians_short += atomic_load(&job->gaussians_short);
    img->static_traversals += atomic_load(&job->static_traversals);
    img->clamped += atomic_load(&job->clamped);
    img->exact_unresolved += job->exact_unresolved;
}

int render_image(const scene *s, const accel *a, const render_settings *rs, image *img,
                 const render_hooks *hooks, volatile sig_atomic_t *cancel, rr_error *err)
{
    render_job job;
    if (check_render_inputs(a, rs, img, err) || job_init(&job, s, a, rs, img, cancel, err))
        return -1;
    double start = rr_seconds(), last_checkpoint = start;
    uint32_t rounds = rs->target_error > 0 ? rs->max_batches : rs->batches;
    int rc = 0;
    for (job.round = 0; job.round < rounds && !rc && !*cancel; job.round++) {
        if (job.round >= rs->batches && !any_pixel_wants_more(&job))
            break;
        rc = run_round(&job, hooks, start, &last_checkpoint, err);
    }
    job_finish(&job, img, start);
    if (rc)
        return -1;
    if (*cancel) {
        if (hooks && hooks->checkpoint && hooks->checkpoint(hooks->user, img, err))
            return -1;
        return rr_fail(err, "render interrupted");
    }
    if (hooks && hooks->progress)
        hooks->progress(hooks->user, 1.0, img->rays, img->seconds);
    return 0;
}
