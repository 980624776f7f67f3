#include "render.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "sampler.h"
#include "shade.h"

#define TILE 16

typedef struct {
    const scene *sc;
    const accel *acc;
    const render_settings *rs;
    sampler smp;
    image *img;
    int tiles_x, tiles_y;
    atomic_int next_tile, tiles_done, workers_left;
    atomic_uint_fast64_t rays, overflows;
    volatile sig_atomic_t *cancel;
} render_job;

typedef struct { /* per-thread scratch for one pixel */
    double *jitter, *times;
    int *perm;
} pixel_scratch;

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* One sample: trace at time t and return its color and coverage. */
static void trace_sample(const render_job *job, vec3 dir, double t, kbuffer *kb, double rgba[4])
{
    const scene *s = job->sc;
    accel_trace(job->acc, s->cam.position, dir, t, kb);
    vec3 c = kb->count ? shade_hits(s, kb, s->cam.position, dir) : s->background;
    rgba[0] = c.x, rgba[1] = c.y, rgba[2] = c.z, rgba[3] = kb->count ? 1.0 : 0.0;
}

/* Thesis sec. 4.5: s_s spatial samples, each with s_t times; colors
 * accumulate with weight a(t) and the pixel is divided by the weight sum. */
static void render_pixel(render_job *job, int px, int py, pixel_scratch *scr, uint64_t *rays,
                         uint64_t *overflows)
{
    const sampler *smp = &job->smp;
    uint64_t pixel = (uint64_t)py * (uint64_t)job->img->width + (uint64_t)px;
    double acc[4] = {0, 0, 0, 0}, wsum = 0;
    kbuffer kb;
    sampler_time_jitter(smp, pixel, scr->jitter);
    for (int i = 0; i < smp->grid * smp->grid; i++) {
        double x, y;
        sampler_position(smp, pixel, px, py, i, &x, &y);
        vec3 dir = camera_ray_direction(&job->sc->cam, x, y);
        sampler_times(smp, pixel, i, scr->jitter, scr->perm, scr->times);
        for (int j = 0; j < smp->tspp; j++) {
            double w = shutter_weight(&job->sc->shut, scr->times[j]);
            if (w == 0)
                continue; /* contributes nothing to either sum */
            double rgba[4];
            trace_sample(job, dir, scr->times[j], &kb, rgba);
            (*rays)++;
            *overflows += kb.dropped > 0;
            for (int c = 0; c < 4; c++)
                acc[c] += w * rgba[c];
            wsum += w;
        }
    }
    float *out = &job->img->rgba[4 * pixel];
    for (int c = 0; c < 4; c++)
        out[c] = wsum > 0 ? (float)(acc[c] / wsum) : 0.0f;
}

static void render_tile(render_job *job, int tile, pixel_scratch *scr)
{
    int tx = tile % job->tiles_x, ty = tile / job->tiles_x;
    int x1 = (tx + 1) * TILE, y1 = (ty + 1) * TILE;
    if (x1 > job->img->width) x1 = job->img->width;
    if (y1 > job->img->height) y1 = job->img->height;
    uint64_t rays = 0, overflows = 0;
    for (int y = ty * TILE; y < y1; y++)
        for (int x = tx * TILE; x < x1; x++)
            render_pixel(job, x, y, scr, &rays, &overflows);
    atomic_fetch_add(&job->rays, rays);
    atomic_fetch_add(&job->overflows, overflows);
}

static void *worker(void *arg)
{
    render_job *job = arg;
    int m = job->smp.tspp * job->smp.time_factor;
    pixel_scratch scr = {malloc((size_t)m * sizeof(double)), malloc((size_t)job->smp.tspp * sizeof(double)),
                         malloc((size_t)m * sizeof(int))};
    int ntiles = job->tiles_x * job->tiles_y;
    while (scr.jitter && scr.times && scr.perm && !*job->cancel) {
        int tile = atomic_fetch_add(&job->next_tile, 1);
        if (tile >= ntiles)
            break;
        render_tile(job, tile, &scr);
        atomic_fetch_add(&job->tiles_done, 1);
    }
    free(scr.jitter);
    free(scr.times);
    free(scr.perm);
    atomic_fetch_sub(&job->workers_left, 1);
    return NULL;
}

static void init_job(render_job *job, const scene *s, const accel *a, const render_settings *rs, image *img)
{
    memset(job, 0, sizeof *job);
    job->sc = s;
    job->acc = a;
    job->rs = rs;
    job->img = img;
    job->smp = (sampler){rs->seed, rs->spp_grid, rs->tspp, rs->time_factor, s->shut.open, s->shut.close};
    job->tiles_x = (img->width + TILE - 1) / TILE;
    job->tiles_y = (img->height + TILE - 1) / TILE;
}

static void wait_with_progress(render_job *job, double start, render_progress_fn progress, void *user)
{
    double ntiles = job->tiles_x * job->tiles_y;
    while (atomic_load(&job->workers_left) > 0) {
        usleep(200000);
        if (progress)
            progress(user, atomic_load(&job->tiles_done) / ntiles, atomic_load(&job->rays),
                     now_seconds() - start);
    }
}

int render_image(const scene *s, const accel *a, const render_settings *rs, image *out,
                 render_progress_fn progress, void *user, volatile sig_atomic_t *cancel,
                 rr_error *err)
{
    if (rs->spp_grid < 1 || rs->tspp < 1 || rs->time_factor < 1 || rs->threads < 1)
        return rr_fail(err, "sample counts and thread count must be positive");
    if ((int64_t)rs->tspp * rs->time_factor > SAMPLER_MAX_TIME_STRATA)
        return rr_fail(err, "tspp * time factor must be at most %d", SAMPLER_MAX_TIME_STRATA);
    out->width = s->cam.width;
    out->height = s->cam.height;
    out->rgba = calloc((size_t)out->width * (size_t)out->height * 4, sizeof(float));
    if (!out->rgba)
        return rr_fail(err, "out of memory for a %dx%d image", out->width, out->height);
    render_job job;
    init_job(&job, s, a, rs, out);
    job.cancel = cancel;
    double start = now_seconds();
    pthread_t *threads = calloc((size_t)rs->threads, sizeof *threads);
    int started = 0;
    atomic_store(&job.workers_left, rs->threads);
    for (int i = 0; threads && i < rs->threads; i++, started++)
        if (pthread_create(&threads[i], NULL, worker, &job))
            break;
    atomic_fetch_sub(&job.workers_left, rs->threads - started);
    wait_with_progress(&job, start, progress, user);
    for (int i = 0; i < started; i++)
        pthread_join(threads[i], NULL);
    free(threads);
    out->seconds = now_seconds() - start;
    out->rays = atomic_load(&job.rays);
    out->kbuffer_overflows = atomic_load(&job.overflows);
    int complete = atomic_load(&job.tiles_done) == job.tiles_x * job.tiles_y;
    if (progress && complete)
        progress(user, 1.0, out->rays, out->seconds);
    if (!complete) {
        image_free(out);
        return rr_fail(err, *cancel ? "render interrupted" : "could not start render threads");
    }
    return 0;
}

void image_free(image *img)
{
    free(img->rgba);
    img->rgba = NULL;
}
