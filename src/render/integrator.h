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
 * Each keeps its own per-thread state (thread_new / thread_free), made
 * once per worker thread per render: render.c's pool starts the workers
 * once and they work every round (batch) of the render. Its scratch
 * arrays live in the worker's arena (core/arena.h), which the integrator
 * resets at the start of each batch: nothing in the arena outlives a
 * batch, and after the first batches a worker mallocs nothing more. */
#ifndef RR_INTEGRATOR_H
#define RR_INTEGRATOR_H

#include <stdint.h>

#include "core/arena.h"
#include "core/camera.h"
#include "render/exact.h"
#include "render/render.h"

/* What every integrator reads, shared by the threads (read-only). */
typedef struct {
    const scene *sc;
    const accel *acc;
    const render_settings *rs;
    exact_plan *exact;     /* with rs->exact_time */
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

/* What a thread's batches cost, summed into the render's statistics. */
typedef struct {
    uint64_t rays;              /* samples estimated */
    uint64_t overflows;         /* samples with more than KBUFFER_MAX hits to blend */
    uint64_t static_traversals; /* traversals of the static objects (image.static_traversals) */
    double unresolved;          /* exact time: exact_stats.unresolved */
} integrator_counts;

typedef struct {
    const char *name;
    /* A thread's state, with its scratch in `arena` (the worker's, kept
     * until after thread_free); NULL when out of memory. */
    void *(*thread_new)(const integrator_context *ctx, rr_arena *arena);
    /* The batch's estimate (RGBA) into est; returns 0, or an EXACT_ status
     * other than EXACT_OK when the batch has no estimate. */
    int (*pixel_batch)(void *thread, const integrator_context *ctx, const pixel_samples *ps, double est[4],
                       integrator_counts *c);
    /* Adds what the thread counted across batches to c, and frees it. */
    void (*thread_free)(void *thread, integrator_counts *c);
} integrator;

/* The integrator a render of ctx needs: exact time with rs->exact_time,
 * else sampled Gaussians when the scene has Gaussian objects, else sampled
 * surfels. */
const integrator *integrator_for(const integrator_context *ctx);

/* The integrators (defined beside their code). */
extern const integrator surfel_integrator_ops, gaussian_integrator_ops, exact_integrator_ops;

/* A sampled integrator's estimate of one batch (thesis sec. 4.5): the
 * sampler-weighted mean of the colours, each in the render's blur space,
 * of the samples `group` estimates. group(thread, ctx, ps, first, rgba, c)
 * estimates the samples from `first` to the end of a group it chooses (at
 * most ACCEL_PACKET), into rgba[0], rgba[1], ..., and returns the index
 * after the group. Returns 0, or EXACT_INTERRUPTED when *ctx->cancel became
 * non-zero before the batch's last group (no estimate: the pixel keeps the
 * batches it had, and a resumed render draws this batch again whole). */
typedef int integrator_group_fn(void *thread, const integrator_context *ctx, const pixel_samples *ps, int first,
                                double (*rgba)[4], integrator_counts *c);
int integrator_sampled_batch(void *thread, const integrator_context *ctx, const pixel_samples *ps,
                              integrator_group_fn *group, double est[4], integrator_counts *c);

#endif
