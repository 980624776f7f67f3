/* What one ray receives from a Gaussian-splat model (gaussian.h), and how
 * the hits are composited: the image formation each model defines,
 * evaluated per ray at the ray's own time (issue 24). Pure math: no
 * Embree, no scene; accel.c gathers the hits, render.c composites them.
 *
 * 2D Gaussians (2DGS, Huang et al. 2024, Eqs. 8-10; the official
 * rasterizer hbb1/diff-surfel-rasterization, forward.cu renderCUDA): the
 * splat's homogeneous map T = K [t_u t_v p] from its (u, v, 1) to pixel
 * coordinates; the ray through raster (x, y) meets the splat where the two
 * planes x T_3 - T_1 and y T_3 - T_2 cross, rho3d = u^2 + v^2; the
 * screen-space low-pass rho2d = 2 |pixel - centre of the projected
 * ellipse|^2; G = exp(-min(rho3d, rho2d) / 2); the depth is the hit's view
 * depth, or the centre's when the filter wins; nearer than 0.2 is skipped
 * (and so is a splat whose centre is); alpha = min(0.99, opacity G),
 * skipped below 1/255; colour from SH in the direction camera -> mean.
 * Order: the centre's view depth (the rasterizer's sort) or the hit's.
 *
 * 3D Gaussians as 3DGRT traces them (Moenne-Loccoz et al. 2024,
 * nv-tlabs/3dgrut, kernel degree 2): the ray in the Gaussian's canonical
 * frame S^-1 R^T (x - mu); response exp(-d^2 / 2) of its squared distance
 * of closest approach; ordered by the distance to that closest point;
 * colour from SH in the ray's direction. Not the 3DGS rasterizer's image
 * (no EWA projection, no +0.3 dilation).
 *
 * Compositing, both: front to back, C += T alpha c, T *= 1 - alpha, and
 * the pass stops before the hit that would bring T below
 * GAUSSIAN_MIN_TRANSMITTANCE; what is behind gets T. */
#ifndef RR_GAUSSIAN_HIT_H
#define RR_GAUSSIAN_HIT_H

#include "animation.h"
#include "camera.h"
#include "gaussian.h"

#define GAUSSIAN_ALPHA_MIN (1.0 / 255.0)
#define GAUSSIAN_ALPHA_MAX 0.99
#define GAUSSIAN_NEAR 0.2              /* 2DGS: view depth below which hits are skipped */
#define GAUSSIAN_MIN_TRANSMITTANCE 1e-4 /* 2DGS's stopping rule */
#define GAUSSIAN_FILTER_INV_SQUARE 2.0  /* 2DGS: rho2d = 2 |d|^2 (a filter of 0.707 pixels) */
#define GAUSSIAN_GRT_MIN_RESPONSE 0.0113 /* 3DGRT: responses at or below are no hit */

/* One Gaussian's contribution to a ray. */
typedef struct {
    float key;    /* compositing order (view depth or ray distance) */
    float t;      /* ray distance of the hit (world units) */
    float alpha;
    float dir[3]; /* the SH direction, object space */
    unsigned obj, prim;
} gaussian_hit;

/* A ray's hits (grown as needed; a thread's scratch). */
typedef struct {
    gaussian_hit *hits;
    size_t count, cap;
    size_t dropped; /* hits that found no memory */
} gaussian_hits;

void gaussian_hits_add(gaussian_hits *h, const gaussian_hit *hit);
void gaussian_hits_free(gaussian_hits *h);

/* One world ray at one time, seen in one object's space. */
typedef struct {
    double m[3][4];    /* object space -> camera space (camera_view's axes) */
    double fx, fy, cx, cy;
    double x, y;       /* the ray's raster position */
    vec3 eye;          /* the camera centre, object space */
    vec3 org, dir;     /* the ray, object space (dir: the world unit direction, so t is world distance) */
    double depth_per_t; /* view depth gained per unit of t (world dir . camera z) */
    double tmax;       /* hits beyond are hidden (an opaque surface) */
} gaussian_ray;

/* Fills r for the world ray org + t dir through raster (x, y) of view,
 * in the space of an object placed by xf. */
void gaussian_ray_init(gaussian_ray *r, const camera_view *view, const xform *xf, double x, double y, vec3 org,
                       vec3 dir, double tmax);

/* Gaussian i's hit on the ray: 1 and *h filled (not obj), or 0. */
int gaussian_hit_2d(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r,
                    gaussian_hit *h);
int gaussian_hit_3d(const gaussian_model *m, size_t i, const gaussian_ray *r, gaussian_hit *h);

/* Object-space bounds of every point of Gaussian i that can give a ray
 * alpha >= 1/255: the splat's plane or the ellipsoid out to the kernel
 * radius where opacity G reaches 1/255, and for a 2D Gaussian also a ball
 * that holds the low-pass filter's footprint (gaussian_filter_reach). */
aabb gaussian_bounds(const gaussian_model *m, size_t i, double filter_reach);

/* 2DGS's filter footprint: how far from the mean (object space) a ray can
 * pass and still get alpha >= 1/255 from the filter, for a Gaussian whose
 * camera distance is at most `distance` (object-space units) under focal
 * length `focal` (pixels, the smaller of fx and fy). */
double gaussian_filter_reach(const gaussian_model *m, size_t i, double distance, double focal);

/* Front-to-back compositing of the hits (sorted here by key, then object,
 * then Gaussian: the same order whatever order they were found in) over
 * `behind` (the surface or background colour). models[obj] is the hit's
 * model. Returns the final transmittance. */
double gaussian_composite(gaussian_hits *h, const gaussian_model *const *models, vec3 behind, vec3 *rgb);

#endif
