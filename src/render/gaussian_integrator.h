/* The Gaussian integrator: one sample's Gaussian-splat objects along its
 * world ray, composited front to back (gaussian_hit.h's image formation).
 * It asks accel only which Gaussians a ray may meet in a stretch
 * (accel_gaussian_candidates); the per-object rays, the windows of
 * distance, the chunks evaluated in order of their key floors and the
 * compositing calls are its own, and so is their scratch. Behind the
 * integrator seam (integrator.h) it is gaussian_integrator_row: each
 * sample's Gaussians composited over the colour the surfel integrator
 * gives it (surfel_integrator.h, static reuse included). */
#ifndef RR_GAUSSIAN_INTEGRATOR_H
#define RR_GAUSSIAN_INTEGRATOR_H

#include <stdint.h>

#include "accel/accel.h"
#include "core/arena.h"
#include "gaussians/gaussian_hit.h"

/* A dynamic model's Gaussians at one ray's time, as static ones: slot j
 * of `model` (the object's model's kind and formation over scratch arrays)
 * holds Gaussian prim[j] of the object's model at that time
 * (gaussian_dynamic_instant_cull and _rest), for a window's candidates. */
typedef struct {
    gaussian_model model;
    unsigned *prim;
    size_t cap;
} gaussian_instant;

/* One world ray at one time seen in a Gaussian object's space, and the
 * stretch of the ray where that object can be. */
typedef struct {
    gaussian_ray ray;
    double time;        /* the ray's scene time */
    const gaussian_model *model; /* what its candidates are evaluated with: the object's, or instant's */
    gaussian_instant *instant;   /* a dynamic model's Gaussians at the ray's time; NULL for a static one */
    unsigned obj;
    double enter, exit; /* the stretch of the world ray inside the object's swept sphere, padded */
    double lead;        /* gaussian_key_lead: how far below its hit's t a key can lie */
    double pad;         /* gaussian_traversal_pad: how far a hit's t can lie outside its box's stretch */
} gaussian_object_ray;

/* A thread's scratch: _init it over an arena, clear the hits of a sample
 * with _reset, release it with _free. Its arrays, the hits' heap among
 * them, grow in the arena (rr_arena_grow: a window's candidates one at a
 * time) and are reused sample after sample until the arena's reset (the
 * render loop's after each batch, or _begin_batch's of an own arena). */
typedef struct {
    rr_arena *arena;                   /* the worker's, or own */
    rr_arena own;
    gaussian_hits hits;                /* the hits waiting to be composited (gaussian_blend.c's heap, in arena) */
    gaussian_object_ray *rays;         /* the sample's ray in each Gaussian object it may meet */
    gaussian_instant *instants;        /* and its dynamic model's Gaussians at the ray's time (rays[k]'s is
                                        * instants[k]) */
    size_t rays_cap;
    gaussian_candidate *candidates;    /* a window's Gaussians, evaluated after its traversals */
    size_t candidates_count, candidates_cap;
    uint64_t *candidate_order;         /* their evaluation order, with sorting space */
    size_t candidate_order_cap;
    size_t instant_cap_reached;        /* the largest capacity of an instant before the last batch */
    size_t instant_cap_batch;          /* and in the batch under way */
    uint64_t short_samples;            /* samples that dropped Gaussians for lack of memory (hits.dropped > 0),
                                        * counted on across samples: a batch that adds one fails (gaussian_batch) */
} gaussian_integrator;

/* arena: the arrays' (NULL: an arena of its own), outliving g. */
void gaussian_integrator_init(gaussian_integrator *g, rr_arena *arena);
/* A new sample: no hits waiting, none dropped (hits.added and hits.moved
 * keep counting: statistics). */
void gaussian_integrator_reset(gaussian_integrator *g);
/* A new batch, after the arena's reset (the render loop resets a
 * worker's; this one resets an arena of its own): the arrays are gone (the
 * next samples reuse their memory), each taken anew at the capacity it
 * reached (rr_arena_renew). */
void gaussian_integrator_begin_batch(gaussian_integrator *g);
void gaussian_integrator_free(gaussian_integrator *g);

/* One sample: the world ray org + t dir (dir unit) at scene time `time`
 * through raster (x, y) of the camera `view` (the camera at that time). */
typedef struct {
    const camera_view *view;
    double x, y;
    vec3 org, dir;
    double time;
} gaussian_sample;

/* Composites into *blend, front to back, every Gaussian hit of the
 * sample's ray nearer than tmax (the opaque surface behind, or infinity),
 * with the scene s that accel a was built for. The ray is gathered in
 * windows of distance, so that once the transmittance is spent nothing
 * behind is evaluated. */
void gaussian_integrate(const scene *s, const accel *a, const gaussian_sample *smp, double tmax, gaussian_integrator *g,
                        gaussian_blend *blend);

#endif
