/* What one ray receives from a Gaussian-splat model (gaussian.h), and how
 * the hits are composited: the image formation each model defines,
 * evaluated per ray at the ray's own time (a moving camera or object is
 * where it is at the ray's instant, not at a frame's). Pure math: no
 * Embree, no scene; the Gaussian integrator (gaussian_integrator.c) asks
 * accel for candidates, evaluates them here and composites the hits.
 *
 * 2D Gaussians (2DGS, Huang et al. 2024, Eqs. 8-10; the official
 * rasterizer hbb1/diff-surfel-rasterization, forward.cu renderCUDA): the
 * splat's homogeneous map T = K [t_u t_v p] from its (u, v, 1) to pixel
 * coordinates; the ray through raster (x, y) meets the splat where the two
 * planes x T_3 - T_1 and y T_3 - T_2 cross, rho3d = u^2 + v^2; the
 * screen-space low-pass rho2d = 2 |pixel - centre of the projected
 * ellipse|^2; G = exp(-min(rho3d, rho2d) / 2); the depth is the hit's view
 * depth, or the centre's when the filter wins; a plane hit nearer than 0.2
 * is skipped (and so is a splat whose centre is; before e0ed020 the
 * filter's hits were tested at the centre's depth: 2dgs-center-near);
 * alpha = min(0.99, opacity G), skipped below 1/255; colour from SH in
 * the direction camera -> mean.
 * Order: the centre's view depth (the rasterizer's sort) or the hit's.
 *
 * 3D Gaussians as their rasterizers draw them (the default; graphdeco-inria
 * diff-gaussian-rasterization, its antialiased variant, nerfstudio gsplat):
 * the EWA footprint cov2D = J W Sigma W^T J^T of the camera of the ray's
 * instant, J at the mean's x/z, y/z clamped to 1.3 tan(fov/2) about the
 * optical axis (gsplat: to 0.3 tan(fov/2) past each image edge), + 0.3 on
 * the diagonal, evaluated at the ray's pixel; ordered by the centre's view
 * depth; colour from SH in the direction camera -> mean.
 *
 * 3D Gaussians as 3DGRT traces them (Moenne-Loccoz et al. 2024,
 * nv-tlabs/3dgrut, kernel degree 2): the ray in the Gaussian's canonical
 * frame S^-1 R^T (x - mu); response exp(-d^2 / 2) of its squared distance
 * of closest approach; ordered by the distance to that closest point;
 * colour from SH in the ray's direction (formation "3dgrt").
 *
 * Compositing, all: front to back, C += T alpha c, T *= 1 - alpha. The
 * rasterizers stop before the hit that would bring T below 1e-4 (forward.cu); 3DGRT
 * composites each hit while T is above 1e-3, so the hit that crosses it
 * is composited (3dgrtTracer.cuh traceVolumetricGS, render/3dgrt.yaml
 * min_transmittance). What is behind gets the final T. */
#ifndef RR_GAUSSIAN_HIT_H
#define RR_GAUSSIAN_HIT_H

#include <stdint.h>

#include "motion/animation.h"
#include "core/arena.h"
#include "core/camera.h"
#include "gaussians/gaussian.h"

#define GAUSSIAN_ALPHA_MIN (1.0 / 255.0)
/* The squared kernel radius (in scales) beyond which alpha = o G falls
 * below GAUSSIAN_ALPHA_MIN: G = exp(-r^2 / 2) >= 1 / (255 o) needs r^2 <=
 * 2 ln(255 o). Every 1/255 reach is this one (gaussian_cull.c's culls and
 * gaussian_reach.c's boxes, the benchmark's), or its value at opacity 1 rounded up. */
static inline double gaussian_alpha_reach2(double opacity) { return 2.0 * log(opacity / GAUSSIAN_ALPHA_MIN); }
#define GAUSSIAN_ALPHA_MAX 0.99
#define GAUSSIAN_NEAR 0.2              /* 2DGS: view depth below which hits are skipped */
#define GAUSSIAN_MIN_TRANSMITTANCE 1e-4 /* 2DGS's stopping rule */
#define GAUSSIAN_FILTER_INV_SQUARE 2.0  /* 2DGS: rho2d = 2 |d|^2 (a filter of 0.707 pixels) */
#define GAUSSIAN_GRT_MIN_RESPONSE 0.0113 /* 3DGRT: responses at or below are no hit */
#define GAUSSIAN_GRT_MIN_TRANSMITTANCE 1e-3 /* 3DGRT: hits are composited while T is above it */

/* One Gaussian's contribution to a ray. */
typedef struct {
    float key;    /* compositing order, as a ray distance (a view depth / the ray's depth per unit t) */
    float t;      /* ray distance of the hit (world units) */
    float alpha;
    float dir[3]; /* the SH direction, object space */
    unsigned obj, prim;
} gaussian_hit;

/* A Gaussian a traversal listed, and its mean in camera space once the
 * cull has computed it. */
typedef struct {
    vec3 p;
    float key_floor; /* gaussian_key_floor, once the cull has kept it */
    unsigned prim;
    unsigned ray;    /* which ray it was listed for: the caller's index (gaussian_cull_candidates) */
} gaussian_candidate;

/* A ray's hits, a thread's scratch: the heap grows in the thread's arena
 * (rr_arena_grow), so it is gone with the arena's reset and its owner
 * begins it anew then (gaussian_hits_begin: empty, at the capacity it
 * reached); out of arena memory a hit is dropped and counted. */
typedef struct {
    rr_arena *arena;    /* where hits grows; outlives it */
    gaussian_hit *hits; /* waiting to be composited: a heap in compositing order (gaussian_blend.c) */
    size_t count, cap;
    size_t dropped;   /* hits that found no memory */
    size_t added;     /* hits ever added (a statistic, and how windows grow: gaussian_integrator.c) */
    size_t moved;     /* hits moved within the heap (a statistic: at most 3 log2 n a hit, n its size) */
    int in_order;     /* hits[0..count) ascend in compositing order (the heap's moves can be skipped) */
} gaussian_hits;

/* An empty heap growing in arena (the statistics zero). */
void gaussian_hits_init(gaussian_hits *h, rr_arena *arena);
/* After arena's reset: no hits and no array (the statistics kept). */
void gaussian_hits_begin(gaussian_hits *h);
void gaussian_hits_add(gaussian_hits *h, const gaussian_hit *hit);

/* One world ray at one time, seen in one object's space. */
typedef struct {
    double m[3][4];    /* object space -> camera space (camera_view's axes) */
    double fx, fy, cx, cy;
    int width, height; /* the image's (the rasterizers' tiles) */
    double stretch;    /* gaussian_view_stretch of the camera */
    double stretch_fov_minus_one; /* the same for 3dgs-fov-minus-one (gaussian_view_stretch_of) */
    double x, y;       /* the ray's raster position */
    vec3 eye;          /* the camera centre, object space */
    vec3 org, dir;     /* the ray, object space (dir: the world unit direction, so t is world distance) */
    double depth_per_t; /* view depth gained per unit of t (world dir . camera z) */
    double tmin, tmax; /* the stretch of the ray whose hits are wanted: tmin <= t < tmax */
    double scale;      /* the object's largest scale (object lengths -> camera lengths) */
} gaussian_ray;

/* Fills r for the world ray org + t dir through raster (x, y) of view,
 * in the space of an object placed by xf (the stretch: all of it). */
void gaussian_ray_init(gaussian_ray *r, const camera_view *view, const xform *xf, double x, double y, vec3 org,
                       vec3 dir);

/* How far below its hit's distance t a hit's key can lie: a 2D Gaussian's
 * key in centre-depth order is its centre's, at most its kernel reach
 * (3.33 scales) from the hit; other keys are the hit's own distance. For
 * the largest scale s of a model (world units) seen along a ray with
 * depth_per_t. */
double gaussian_key_lead(const gaussian_model *m, gaussian_order order, double s, double depth_per_t);
/* How far a hit's distance can lie from the stretch of the ray inside its
 * Gaussian's bounds (a window's traversal is wider by this): a 2D hit where
 * the filter wins is placed at the centre's depth, the bounds hold the ray
 * near a point of the filter's circle. */
double gaussian_traversal_pad(const gaussian_model *m, double s, double depth_per_t);

/* Start loading what Gaussian i's cull reads (its mean and scale), what
 * the rest of its evaluation reads (rotation and opacity) and what
 * compositing it reads (its SH coefficients). A model of millions is far
 * larger than the caches: a hit's evaluation waited on those loads one
 * after another (a profile of a benchmark-scale render: most of gaussian_hit_2d's time), and
 * evaluating a traversal's candidates a few behind their prefetches
 * overlaps the waits; most candidates fail the cull, so only the ones
 * that pass it load the rest. No value changes. */
void gaussian_prefetch_cull(const gaussian_model *m, size_t i);
void gaussian_prefetch_hit(const gaussian_model *m, size_t i);
void gaussian_prefetch_sh(const gaussian_model *m, size_t i);

/* Gaussian i's hit on the ray under m's formation: 1 and *h filled (not
 * obj), or 0. The three rules it dispatches to are below. It is the cull
 * (0: no hit for certain; else *p = the camera-space mean), from the mean
 * and scale alone, and then the rest of the evaluation. */
int gaussian_hit_any(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, gaussian_hit *h);
int gaussian_cull(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 *p);
int gaussian_hit_after_cull(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                            gaussian_hit *h);
/* gaussian_hit_after_cull for four Gaussians of one ray (the same hits, bit
 * for bit; 2D geometry in AVX2 lanes where rr_lanes_available, lanes.h):
 * bit j of the result is set when prim[j] hits, h[j] its hit. */
int gaussian_hits_after_cull4(const gaussian_model *m, const unsigned prim[4], gaussian_order order,
                              const gaussian_ray *r, const vec3 p[4], gaussian_hit h[4]);
#ifdef RR_DCHECKS
/* Test hook: bit j set when the lanes' 2D geometry of prim[j] differs in
 * any bit from the scalar's (0 without AVX2 lanes). */
int gaussian_2d_geometry_lanes_differ(const gaussian_model *m, const unsigned prim[4], const gaussian_ray *r,
                                      const vec3 p[4]);
#endif
int gaussian_hit_2d(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r,
                    gaussian_hit *h);
/* Culls the n candidates listed in cand (their prims), keeping those the
 * cull passes at the front of cand with their means in camera space, key
 * floors and `ray`; returns how many. Their rotation and opacity are
 * prefetched; the means and scales a few ahead. */
size_t gaussian_cull_candidates(const gaussian_model *m, const gaussian_ray *r, gaussian_candidate *cand, size_t n,
                                unsigned ray);
/* A float at or below the key of any hit of Gaussian i on r, in either
 * order, from its camera-space mean p (the cull's): its hits can then
 * wait while those of smaller keys are composited (gaussian_integrator.c); -INFINITY
 * where no bound is known. */
float gaussian_key_floor(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p);
/* The 2DGS low-pass filter's centre (raster position) of Gaussian i seen
 * by r's camera; 0 where its circle's image is no ellipse (for tests). */
int gaussian_filter_centre_2d(const gaussian_model *m, size_t i, const gaussian_ray *r, double *x, double *y);
int gaussian_hit_3dgrt(const gaussian_model *m, size_t i, const gaussian_ray *r, gaussian_hit *h);

/* What a Gaussian's bounds must hold of the camera over the shutter. */
typedef struct {
    double distance; /* the farthest the camera gets from the Gaussian (object units) */
    double focal;    /* the smaller focal length, pixels (shrunk by the object's scale spread) */
    double stretch;  /* gaussian_view_stretch of the camera */
    double near;     /* 2DGS: a view depth a hit's centre always exceeds, as an object length
                      * (gaussian_filter_near); 0: none known */
    vec3 axis;       /* the camera's view axis (unit, object space) at some time, and how far */
    double cone;     /* (radians) it turns from it over the shutter; a zero axis: not known */
} gaussian_view_bound;

/* The least view depth a 2DGS hit's centre has (GAUSSIAN_NEAR, world) as
 * an object length, for an object scaled by factors in [min_scale,
 * max_scale]: the world's pole offset (max_scale r)^2 / depth, over
 * min_scale, is at most r^2 / this (filter_2d_reach). */
double gaussian_filter_near(double min_scale, double max_scale);

/* How much farther than f / depth a length can project in a rasterizer's
 * footprint: sqrt(1 + lim_x^2 + lim_y^2) f_max / f_min, lim the Jacobian's
 * widest clamp (gsplat's: 0.3 tan(fov / 2) past the farther image edge
 * from the principal point). */
double gaussian_view_stretch(const camera_view *v);
/* The stretch under formation f: gaussian_view_stretch, or for
 * 3dgs-fov-minus-one its pinned Jacobian's, whose focal lengths are the
 * image's size / (2 tan(-0.5)) whatever the camera's. */
double gaussian_view_stretch_of(gaussian_formation f, const camera_view *v);

/* How far from the mean (object space) a ray can pass and still get alpha
 * >= 1/255 through a footprint drawn on the screen: 2DGS's low-pass
 * filter, or a 3D rasterizer's EWA footprint (its dilation included); 0
 * for 3DGRT (its ellipsoid is its reach). */
double gaussian_view_reach(const gaussian_model *m, size_t i, const gaussian_view_bound *v);

/* Object-space bounds of every point of Gaussian i that can give a ray
 * alpha >= 1/255: the splat's plane or the ellipsoid out to the kernel
 * radius where opacity G reaches 1/255, and a ball of radius view_reach
 * (gaussian_view_reach) about the mean. */
aabb gaussian_bounds(const gaussian_model *m, size_t i, double view_reach);
/* The same with the footprint's reach as it points: the screen footprint
 * lies across the view axis (a rasterizer's hit at the mean's view depth,
 * the 2DGS filter's at its point P's), so where the view axis is known to
 * within a cone the box is flatter along it (on the benchmark-scale view a
 * ball's box, pierced obliquely, listed 2.5 candidates a kept one). */
aabb gaussian_view_bounds(const gaussian_model *m, size_t i, const gaussian_view_bound *v);

/* Front-to-back compositing, a stretch of the ray at a time (hits are
 * gathered in windows of ray distance, so that a ray whose transmittance
 * is spent early does not evaluate what lies behind). */
typedef struct {
    double T;          /* transmittance so far */
    vec3 sum;          /* colour so far */
    size_t composited; /* hits composited */
    int done;          /* the next hit would have brought T below the minimum: stop */
    double time;       /* the ray's scene time (a 4DGS colour depends on it; 0 from init) */
} gaussian_blend;

void gaussian_blend_init(gaussian_blend *b);

/* Composites, in order (key, then object, then Gaussian: the same
 * whatever order they were found in), the hits of h whose key is below
 * `final_below` (no hit still to be found has a smaller key), and removes
 * them from h (all of h once the transmittance is spent); O(log n) moves
 * a hit added or composited, n the hits waiting. models[obj] is a hit's
 * model. */
void gaussian_blend_hits(gaussian_blend *b, gaussian_hits *h, const gaussian_model *const *models,
                         double final_below);

/* The colour over `behind` (the surface or the background). */
vec3 gaussian_blend_over(const gaussian_blend *b, vec3 behind);

#endif
