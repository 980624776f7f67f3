/* The integrator seam: "estimate these pixel samples". render.c draws a
 * pixel's batch of samples (positions, times, weights) and hands it to the
 * integrator the scene needs; the integrator returns the batch's estimate.
 * Three sit behind it:
 *  - sampled surfels (surfel_integrator.h): epsilon window, k-buffer,
 *    blending, deferred Phong, and static reuse for a still camera;
 *  - sampled Gaussians (gaussian_integrator.h): the surfels' colour, then
 *    each sample's Gaussian hits composited over it; the surfels keep
 *    their static reuse;
 *  - exact time (exact.h): each spatial position's exact time average.
 * Each is one row (integrator_ops) of the table integrator_named looks up
 * (after pbrt-v4's Integrator::Create(name, ...)): it checks what it can
 * render, sets up and tears down its per-render state (exact time's plan),
 * says why a batch failed, and keeps its own per-thread state (thread_new /
 * thread_free), made once per worker thread per render: render.c's pool
 * starts the workers once and they work every round (batch) of the render.
 * Its scratch arrays live in the worker's arena (core/arena.h), which the
 * loop resets after each batch (pbrt-v4's scratchBuffer.Reset() after each
 * pixel sample): nothing in the arena outlives a batch, and after the
 * first batches a worker mallocs nothing more. A row also declares its
 * own counters (counters.h: exact time's unresolved share): the loop sums
 * them into the image, and the header writes them (output.h,
 * output_counter_attrs), knowing no more than their attribute and scale.
 * The loop knows no row by name: a new integrator is a row and a line in
 * integrator.c's table. */
#ifndef RR_INTEGRATOR_H
#define RR_INTEGRATOR_H

#include <signal.h>
#include <stdint.h>

#include "accel/accel.h"
#include "core/arena.h"
#include "core/camera.h"
#include "render/counters.h"
#include "render/render_settings.h"

/* What every integrator reads, shared by the threads (read-only during
 * the render; the row's setup fills `plan`). */
typedef struct {
    const scene *sc;       /* accel_scene(acc): the scene rendered, its shutter the one owner (sc->shut) */
    const accel *acc;
    const render_settings *rs;
    void *plan;            /* the row's per-render state (setup / teardown); NULL without */
    int camera_moves;      /* every sample traces its own world ray */
    camera_view rest_view; /* the camera at rest (Gaussian hits, still camera) */
    /* render_image's cancel flag (NULL: never cancelled): a batch checks it
     * as it goes, so a stop waits for no batch, however many samples it has */
    volatile sig_atomic_t *cancel;
} integrator_context;

/* One batch of one pixel: count samples at raster (x[i], y[i]), time t[i],
 * with the sampler's weight w[i]. */
typedef struct {
    const double *x, *y, *t, *w;
    int count;
} pixel_samples;

/* What a thread's batches cost, summed into the render's statistics (the
 * fixed counts here, the row's own in `counter`). */
typedef struct {
    uint64_t rays;              /* samples estimated */
    uint64_t overflows;         /* samples with more than KBUFFER_MAX hits to blend */
    uint64_t static_traversals; /* traversals of the static objects (image.static_traversals) */
    double counter[COUNTERS_MAX]; /* the row's own counters, by index in its `counters` */
} integrator_counts;

/* A batch's status: 0, or why it has no estimate. INTEGRATOR_INTERRUPTED
 * is no failure (the cancel flag stops the render); other negative values
 * are the row's own, which its batch_failure puts into words. */
enum { INTEGRATOR_OK = 0, INTEGRATOR_NO_MEMORY = -1, INTEGRATOR_INTERRUPTED = -2 };

typedef struct integrator_ops {
    const char *id;   /* the name integrator_named finds it by ("exact": --time-integration's) */
    const char *name; /* in messages ("exact time") */
    /* What it cannot render (settings, scene): -1 with err before any work;
     * NULL: it renders anything render_image takes. */
    int (*check)(const integrator_context *ctx, rr_error *err);
    /* The per-render state into ctx->plan, once before the workers start,
     * freed by teardown after they end (NULL: none). */
    int (*setup)(integrator_context *ctx, rr_error *err);
    void (*teardown)(integrator_context *ctx);
    /* A thread's state, with its scratch in `arena` (the worker's, kept
     * until after thread_free, reset after every batch); NULL when out of
     * memory. */
    void *(*thread_new)(const integrator_context *ctx, rr_arena *arena);
    /* The batch's estimate (RGBA) into est; returns a status (above). */
    int (*pixel_batch)(void *thread, const integrator_context *ctx, const pixel_samples *ps, double est[4],
                       integrator_counts *c);
    /* Adds what the thread counted across batches to c, and frees it. */
    void (*thread_free)(void *thread, integrator_counts *c);
    /* The render's error for a batch of pixel (px, py) that failed with
     * status (never INTEGRATOR_INTERRUPTED); returns -1. */
    int (*batch_failure)(int status, int px, int py, rr_error *err);
    /* Its own counters (counters.h; at most COUNTERS_MAX): its batches add
     * to integrator_counts.counter[i], the loop sums them into the image's
     * counters and the header writes counters[i].attribute. */
    const counter_spec *counters;
    int ncounters;
} integrator_ops;

/* The integrators (defined beside their code), and the table of them. */
extern const integrator_ops surfel_integrator_row, gaussian_integrator_row, exact_integrator_row;

/* The row of `table` (n rows) whose id is `id`, or NULL. */
const integrator_ops *integrator_find(const integrator_ops *const *table, int n, const char *id);
/* The built-in row named id ("surfels", "gaussians", "exact"), or NULL. */
const integrator_ops *integrator_named(const char *id);

/* The integrator a render of ctx uses: rs->integrator when set, else
 * sampled time, Gaussians when the scene has Gaussian objects, else
 * surfels. */
const integrator_ops *integrator_for(const integrator_context *ctx);

/* A sampled integrator's estimate of one batch (thesis sec. 4.5): the
 * sampler-weighted mean of the colours, each in the render's blur space,
 * of the samples `group` estimates. group(thread, ctx, ps, first, rgba, c)
 * estimates the samples from `first` to the end of a group it chooses (at
 * most ACCEL_PACKET), into rgba[0], rgba[1], ..., and returns the index
 * after the group. Returns 0, or INTEGRATOR_INTERRUPTED when *ctx->cancel
 * became non-zero before the batch's last group (no estimate: the pixel
 * keeps the batches it had, and a resumed render draws this batch again
 * whole). */
typedef int integrator_group_fn(void *thread, const integrator_context *ctx, const pixel_samples *ps, int first,
                                double (*rgba)[4], integrator_counts *c);
int integrator_sampled_batch(void *thread, const integrator_context *ctx, const pixel_samples *ps,
                              integrator_group_fn *group, double est[4], integrator_counts *c);

#endif
