#include "render/render.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "render/integrator.h"

#define TILE 16

typedef struct {
    integrator_context ctx; /* ctx.plan: the integrator's (its setup and teardown) */
    const integrator_ops *integ; /* integrator_for(&ctx) */
    const render_settings *rs;
    shutter_cdf time_cdf;    /* times drawn from a(t) (not used for a box) */
    image *img;
    int tiles_x, tiles_y, ntiles;
    uint32_t round; /* pixels holding `round` batches render batch batch_begin + round */
    /* progress: pixel batches the pixels held when the render began, and
     * those they are expected to hold at its end (render_planned_pixel_batches) */
    uint64_t held_at_start, planned;
    atomic_int next_tile, workers_left;
    atomic_uint_fast64_t rays, overflows, clamped, pixel_batches, static_traversals;
    atomic_int scratch_failed; /* a worker could not allocate its scratch */
    atomic_int batch_failed;   /* a batch failed (see failed_status): the render stops */
    int failed_status, failed_px, failed_py; /* under lock: the first failure (the integrator's status) and its
                                                pixel */
    double counter[COUNTERS_MAX]; /* under lock: the row's own counters (integrator_counts.counter) summed over
                                     tiles */
    pthread_mutex_t lock;
    pthread_cond_t cond;  /* to the coordinator: a worker is ready or done with a round; a pause's end */
    pthread_cond_t start; /* to the workers: a round begins, or the render ends */
    atomic_int paused; /* set under lock: a checkpoint is to be written (pixel_pause_point reads it between pixels) */
    int active;        /* under lock: workers inside a tile and not stepped out for a checkpoint */
    /* the pool (under lock): workers started and ready (their scratch made),
     * rounds begun, and the end of the render */
    pthread_t *tids;
    int started, ready, quit;
    uint64_t rounds_begun;
    volatile sig_atomic_t *cancel;
} render_job;

typedef struct { /* per-thread scratch, made once per worker per render */
    sampler_scratch ss;
    double *x, *y, *t, *w;
    rr_arena arena; /* the integrator's scratch, reset after every batch (integrator.h) */
    void *integ;    /* the integrator's per-thread state */
} thread_scratch;

/* The positions and times of batch `batch` of pixel (px, py) into the
 * scratch; returns their count. The sampler's times are uniform over the
 * shutter; unless a(t) is a box they are moved to a(t)'s own distribution
 * (shutter_cdf), which keeps their stratification: the map is monotone. */
static int batch_samples(const render_job *job, int px, int py, uint32_t batch, thread_scratch *scr)
{
    const sampler *smp = &job->rs->smp;
    const shutter *sh = &job->ctx.sc->shut; /* the scene's: the one accel was built for */
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
        int lines, line = shutter_line(sh, px, py, job->ctx.sc->cam.width, job->ctx.sc->cam.height, &lines);
        for (int i = 0; i < count; i++)
            scr->t[i] = shutter_line_time(sh, line, lines, scr->t[i]);
    }
    return count;
}

/* Keeps the first failed batch (an interrupt is not a failure: the cancel
 * flag already stops the render). */
static void batch_failed(render_job *job, int status, int px, int py)
{
    if (status == INTEGRATOR_INTERRUPTED)
        return;
    pthread_mutex_lock(&job->lock);
    if (!job->failed_status)
        job->failed_status = status, job->failed_px = px, job->failed_py = py;
    pthread_mutex_unlock(&job->lock);
    atomic_store(&job->batch_failed, 1);
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

/* One batch of pixel (x, y) by the job's integrator into its film state;
 * returns 0, or the integrator's failure (the pixel keeps the batches it
 * had: a resumed render redoes this one). */
static int pixel_batch(render_job *job, int x, int y, pixel_state *p, thread_scratch *scr, integrator_counts *c,
                       uint64_t *clamped)
{
    uint32_t batch = job->rs->batch_begin + job->round;
    pixel_samples ps = {scr->x, scr->y, scr->t, scr->w, batch_samples(job, x, y, batch, scr)};
    double est[4];
    int rc = job->integ->pixel_batch(scr->integ, &job->ctx, &ps, est, c);
    rr_arena_reset(&scr->arena); /* nothing of a batch outlives it (integrator.h) */
    if (!rc)
        *clamped += (uint64_t)film_add_batch(p, est);
    return rc;
}

/* A tile's counts (or those of its pixels done so far) into the job's. */
static void add_counts(render_job *job, const integrator_counts *c, uint64_t clamped, uint64_t done)
{
    pthread_mutex_lock(&job->lock);
    for (int i = 0; i < job->integ->ncounters; i++)
        job->counter[i] += c->counter[i];
    pthread_mutex_unlock(&job->lock);
    atomic_fetch_add(&job->rays, c->rays);
    atomic_fetch_add(&job->overflows, c->overflows);
    atomic_fetch_add(&job->clamped, clamped);
    atomic_fetch_add(&job->pixel_batches, done);
    atomic_fetch_add(&job->static_traversals, c->static_traversals);
}

/* Between two pixels of a tile: stops when the render is cancelled or a
 * batch failed, and steps out while a checkpoint is written, so that
 * neither waits for the rest of the tile (a tile at a high sample count
 * once held a SIGTERM 12-18 s, longer than Slurm's KillWait of 30 s under
 * ASan: issue 56.7). Pixels are independent states, so a checkpoint taken
 * between two of them resumes as one taken between tiles. */
static int pixel_pause_point(render_job *job, integrator_counts *c, uint64_t *clamped, uint64_t *done)
{
    if (*job->cancel || atomic_load(&job->batch_failed))
        return 1;
    if (!atomic_load(&job->paused))
        return 0;
    /* the tile's counts so far go into the checkpoint with its pixels'
     * batches: a resumed render then counts each batch's rays once */
    add_counts(job, c, *clamped, *done);
    *c = (integrator_counts){0}, *clamped = *done = 0;
    pthread_mutex_lock(&job->lock);
    job->active--;
    pthread_cond_broadcast(&job->cond);
    while (job->paused && !*job->cancel)
        pthread_cond_wait(&job->cond, &job->lock);
    job->active++; /* (work_round's leave_work takes it back, stopped or not) */
    pthread_mutex_unlock(&job->lock);
    return *job->cancel != 0;
}

static void render_tile(render_job *job, int tile, thread_scratch *scr)
{
    image *img = job->img;
    int tx = tile % job->tiles_x, ty = tile / job->tiles_x;
    int x1 = (tx + 1) * TILE < img->width ? (tx + 1) * TILE : img->width;
    int y1 = (ty + 1) * TILE < img->height ? (ty + 1) * TILE : img->height;
    integrator_counts c = {0};
    uint64_t clamped = 0, done = 0;
    int stop = 0;
    for (int y = ty * TILE; y < y1 && !stop; y++)
        for (int x = tx * TILE; x < x1 && !stop; x++) {
            pixel_state *p = &img->px[(size_t)y * img->width + x];
            if (!pixel_in_crop(job->rs, x, y) || !pixel_wants_batch(job, p))
                continue;
            if ((stop = pixel_pause_point(job, &c, &clamped, &done)))
                break;
            int rc = pixel_batch(job, x, y, p, scr, &c, &clamped);
            if (rc) {
                batch_failed(job, rc, x, y);
                stop = 1;
            } else
                done++;
        }
    add_counts(job, &c, clamped, done);
}

/* Blocks while a checkpoint is being written; returns 1 when cancelled. */
static int enter_work(render_job *job)
{
    pthread_mutex_lock(&job->lock);
    while (job->paused && !*job->cancel)
        pthread_cond_wait(&job->cond, &job->lock);
    int stop = *job->cancel != 0 || atomic_load(&job->batch_failed);
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

static int scratch_init(thread_scratch *scr, const render_job *job)
{
    size_t n = (size_t)sampler_count(&job->rs->smp);
    scr->x = malloc(n * sizeof(double));
    scr->y = malloc(n * sizeof(double));
    scr->t = malloc(n * sizeof(double));
    scr->w = malloc(n * sizeof(double));
    rr_arena_init(&scr->arena, 0);
    scr->integ = job->integ->thread_new(&job->ctx, &scr->arena);
    return sampler_scratch_init(&scr->ss, &job->rs->smp) || !scr->x || !scr->y || !scr->t || !scr->w || !scr->integ
               ? -1
               : 0;
}

static void scratch_free(render_job *job, thread_scratch *scr)
{
    integrator_counts c = {0};
    if (scr->integ)
        job->integ->thread_free(scr->integ, &c);
    rr_arena_free(&scr->arena);
    sampler_scratch_free(&scr->ss);
    free(scr->x);
    free(scr->y);
    free(scr->t);
    free(scr->w);
}

/* A round's tiles, taken one at a time until none is left or the render
 * stops (cancelled, a batch failed). */
static void work_round(render_job *job, thread_scratch *scr)
{
    while (!enter_work(job)) {
        int tile = atomic_fetch_add(&job->next_tile, 1);
        if (tile < job->ntiles)
            render_tile(job, tile, scr);
        leave_work(job);
        if (tile >= job->ntiles)
            break;
    }
}

/* A worker of the pool: makes its scratch once, then works each round the
 * coordinator begins (run_round) until the render ends (pool_stop). A
 * worker without scratch works no round: the render fails before its
 * first (pool_start). */
static void *worker(void *arg)
{
    render_job *job = arg;
    thread_scratch scr;
    int ok = !scratch_init(&scr, job);
    pthread_mutex_lock(&job->lock);
    if (!ok)
        atomic_store(&job->scratch_failed, 1); /* the render fails: no silently black tiles */
    job->ready++;
    pthread_cond_broadcast(&job->cond);
    for (uint64_t seen = 0;;) {
        while (!job->quit && job->rounds_begun == seen)
            pthread_cond_wait(&job->start, &job->lock);
        if (job->quit)
            break;
        seen = job->rounds_begun;
        pthread_mutex_unlock(&job->lock);
        if (ok)
            work_round(job, &scr);
        pthread_mutex_lock(&job->lock);
        atomic_fetch_sub(&job->workers_left, 1);
        pthread_cond_broadcast(&job->cond); /* wakes the coordinator at once */
    }
    pthread_mutex_unlock(&job->lock);
    scratch_free(job, &scr);
    return NULL;
}

/* Ends the pool: the workers leave their wait for a round, free their
 * scratch and are joined. */
static void pool_stop(render_job *job)
{
    pthread_mutex_lock(&job->lock);
    job->quit = 1;
    pthread_cond_broadcast(&job->start);
    pthread_mutex_unlock(&job->lock);
    for (int i = 0; i < job->started; i++)
        pthread_join(job->tids[i], NULL);
    free(job->tids);
    job->tids = NULL, job->started = 0;
}

/* Starts the render's worker threads, once per render (as many as
 * pthread_create gives, at least one), and waits until each has made its
 * scratch. */
static int pool_start(render_job *job, rr_error *err)
{
    int threads = job->rs->threads;
    job->tids = calloc((size_t)threads, sizeof *job->tids);
    for (int i = 0; job->tids && i < threads; i++, job->started++)
        if (pthread_create(&job->tids[i], NULL, worker, job))
            break;
    if (!job->started) {
        free(job->tids);
        job->tids = NULL;
        return rr_fail(err, "could not start render threads");
    }
    pthread_mutex_lock(&job->lock);
    while (job->ready < job->started)
        pthread_cond_wait(&job->cond, &job->lock);
    pthread_mutex_unlock(&job->lock);
    if (!atomic_load(&job->scratch_failed))
        return 0;
    pool_stop(job);
    return rr_fail(err, "out of memory for a render thread's samples (%lld per batch)",
                   (long long)sampler_count(&job->rs->smp));
}

/* The row's counters summed by this render into the image's (which holds
 * a resumed state's: render_frames.c reads them back). */
static void add_row_counters(counter_set *into, const integrator_ops *integ, const double *sum)
{
    RR_DCHECK(integ->ncounters >= 0 && integ->ncounters <= COUNTERS_MAX);
    RR_DCHECK(!into->spec || (into->spec == integ->counters && into->n == integ->ncounters));
    into->spec = integ->counters, into->n = integ->ncounters;
    for (int i = 0; i < integ->ncounters; i++)
        into->sum[i] += sum[i];
}

/* The state written carries the work its batches took so far (the rays of
 * the finished tiles, the seconds and the row's counters), so that a
 * resumed render reports the rays, time and counters of the whole render,
 * as an uninterrupted one. */
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
    counter_set counters = img->counters;
    img->rays += atomic_load(&job->rays), img->seconds += rr_seconds() - start;
    add_row_counters(&img->counters, job->integ, job->counter); /* (the workers are paused: none adds) */
    int rc = hooks->checkpoint(hooks->user, img, err);
    img->rays = rays, img->seconds = seconds, img->counters = counters;
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

/* The batches a pixel is expected to hold at the end of the render: the
 * first B, and with a target error as many as its standard error says it
 * needs (it falls as 1/sqrt(batches): b (se / target)^2), up to the cap.
 * Only the progress line uses it; no pixel's batches depend on it. */
static uint64_t expected_batches(const render_settings *rs, const pixel_state *p)
{
    uint32_t first = p->batches > rs->batches ? p->batches : rs->batches;
    if (rs->target_error <= 0 || p->batches < 2 || !pixel_wants_another(rs, p))
        return first;
    double ratio = film_max_stderr(p) / rs->target_error;
    double needed = round(fmin(p->batches * ratio * ratio, rs->max_batches));
    uint32_t next = p->batches + 1;
    return (uint64_t)fmax(fmax(needed, first), next);
}

/* (render.h) Expected anew at each round. */
uint64_t render_planned_pixel_batches(const render_settings *rs, const image *img)
{
    uint64_t total = 0;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            if (pixel_in_crop(rs, x, y))
                total += expected_batches(rs, &img->px[(size_t)y * img->width + x]);
    return total;
}

static uint64_t held_pixel_batches(const image *img)
{
    uint64_t held = 0;
    for (size_t i = 0; i < (size_t)img->width * img->height; i++)
        held += img->px[i].batches;
    return held;
}

/* The share of this render's planned pixel batches done (a resumed render's
 * earlier ones are not its work: its ETA is for what is left). */
static void report_progress(render_job *job, const render_hooks *hooks, double start)
{
    if (!hooks || !hooks->progress)
        return;
    double planned = (double)(job->planned - job->held_at_start);
    double fraction = fmin(0.999, atomic_load(&job->pixel_batches) / fmax(planned, 1.0));
    hooks->progress(hooks->user, fraction, atomic_load(&job->rays), rr_seconds() - start);
}

/* A failed batch stops the render: a pixel cannot be left with a partial
 * average; the integrator says why (its batch_failure). */
static int batch_failure(const render_job *job, rr_error *err)
{
    if (job->integ->batch_failure)
        return job->integ->batch_failure(job->failed_status, job->failed_px, job->failed_py, err);
    return rr_fail(err, "%s at pixel (%d, %d): the batch failed (status %d)", job->integ->name, job->failed_px,
                   job->failed_py, job->failed_status);
}

/* Runs one round over all tiles with the pool's workers, writing periodic
 * checkpoints while they are paused. */
static int run_round(render_job *job, const render_hooks *hooks, double start, double *last_checkpoint,
                     rr_error *err)
{
    pthread_mutex_lock(&job->lock);
    atomic_store(&job->next_tile, 0);
    atomic_store(&job->workers_left, job->started);
    job->rounds_begun++;
    pthread_cond_broadcast(&job->start);
    pthread_mutex_unlock(&job->lock);
    double last_report = 0;
    while (atomic_load(&job->workers_left) > 0) {
        wait_for_workers(job);
        if (rr_seconds() - last_report >= 0.2) {
            report_progress(job, hooks, start);
            last_report = rr_seconds();
        }
        int due = hooks && hooks->checkpoint && hooks->checkpoint_every > 0 &&
                  rr_seconds() - *last_checkpoint >= hooks->checkpoint_every;
        if (due && !*job->cancel) {
            rr_error ck_err;
            if (checkpoint_paused(job, hooks, start, &ck_err) && hooks->checkpoint_failed)
                hooks->checkpoint_failed(hooks->user, &ck_err);
            *last_checkpoint = rr_seconds();
        }
    }
    return job->failed_status ? batch_failure(job, err) : 0;
}

/* Will any pixel take a batch in this round or a later one? A resumed
 * checkpoint was written between pixels, in the middle of a round, so some
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

/* What render_image refuses before any work (what the integrator cannot
 * render its row's check refuses: job_init). The shutter needs no check:
 * it is the scene's, read through the accel built for it (accel_scene). */
static int check_settings(const render_settings *rs, rr_error *err)
{
    if (rs->threads < 1 || rs->batches < 1)
        return rr_fail(err, "batch and thread counts must be positive");
    if (rs->target_error > 0 && rs->max_batches < rs->batches)
        return rr_fail(err, "the batch cap must be at least the batch count");
    return sampler_check(&rs->smp, err);
}

static int job_init(render_job *job, const accel *a, const render_settings *rs, image *img,
                    volatile sig_atomic_t *cancel, rr_error *err)
{
    const scene *s = accel_scene(a);
    memset(job, 0, sizeof *job);
    job->rs = rs, job->img = img, job->cancel = cancel;
    job->ctx.sc = s, job->ctx.acc = a, job->ctx.rs = rs, job->ctx.cancel = cancel;
    job->ctx.camera_moves = scene_camera_moves(s);
    camera_view_rest(&s->cam, &job->ctx.rest_view);
    job->tiles_x = (img->width + TILE - 1) / TILE;
    job->tiles_y = (img->height + TILE - 1) / TILE;
    job->ntiles = job->tiles_x * job->tiles_y;
    shutter_cdf_init(&job->time_cdf, &s->shut);
    job->integ = integrator_for(&job->ctx);
    if ((job->integ->check && job->integ->check(&job->ctx, err)) ||
        (job->integ->setup && job->integ->setup(&job->ctx, err)))
        return -1;
    pthread_mutex_init(&job->lock, NULL);
    pthread_cond_init(&job->cond, NULL);
    pthread_cond_init(&job->start, NULL);
    return 0;
}

/* The job's statistics into the image, and its resources released. */
static void job_finish(render_job *job, image *img, double start)
{
    pthread_mutex_destroy(&job->lock);
    pthread_cond_destroy(&job->cond);
    pthread_cond_destroy(&job->start);
    if (job->integ->teardown)
        job->integ->teardown(&job->ctx);
    img->seconds += rr_seconds() - start;
    img->rays += atomic_load(&job->rays);
    img->kbuffer_overflows += atomic_load(&job->overflows);
    img->static_traversals += atomic_load(&job->static_traversals);
    img->clamped += atomic_load(&job->clamped);
    add_row_counters(&img->counters, job->integ, job->counter);
}

int render_image(const accel *a, const render_settings *rs, image *img, const render_hooks *hooks,
                 volatile sig_atomic_t *cancel, rr_error *err)
{
    render_job job;
    if (check_settings(rs, err) || job_init(&job, a, rs, img, cancel, err))
        return -1;
    double start = rr_seconds(), last_checkpoint = start;
    uint32_t rounds = rs->target_error > 0 ? rs->max_batches : rs->batches;
    job.held_at_start = held_pixel_batches(img);
    int rc = pool_start(&job, err);
    for (job.round = 0; job.round < rounds && !rc && !*cancel; job.round++) {
        if (job.round >= rs->batches && !any_pixel_wants_more(&job))
            break;
        job.planned = render_planned_pixel_batches(rs, img);
        rc = run_round(&job, hooks, start, &last_checkpoint, err);
    }
    if (job.started)
        pool_stop(&job);
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
