/* Helpers shared by the Gaussian hit and cull unit tests (test_gaussian_hit.c
 * and test_gaussian_cull.c): reproducible random splats, and whether a hit
 * lies in the box a window's traversal visits. */
#ifndef RR_GAUSSIAN_HIT_UTIL_H
#define RR_GAUSSIAN_HIT_UTIL_H

#include <stddef.h>

#include "gaussians/gaussian_hit.h"

/* Why a lane test is skipped: without the vector path it would compare the
 * scalar code with itself. */
#define NO_LANES "no AVX2 lanes on this CPU (or RR_NO_LANES is set)"

/* A uniform number in [0, 1] from rand_r(state). */
double rand_uniform(unsigned *state);

/* m initialised with n Gaussians of kind and SH degree 0 (values unset). */
void hit_test_model(gaussian_model *m, size_t n, gaussian_kind kind);

/* Gaussian i of m: a random rotation, mean in [-0.5, 0.5)^3, scales of
 * size * [0.2, 1.2) (a 2D Gaussian's third 0), colour and opacity. */
void random_splat(gaussian_model *m, size_t i, unsigned *st, double size);

/* Does box b hold point p (faces included)? */
int box_holds_point(aabb b, vec3 p);

/* Does the segment of the ray from the origin along dir with distances
 * in [t - lead, t + lead] meet the box? (slabs: exact, however thin the
 * box along the ray) */
int ray_in_box_near(aabb box, vec3 dir, double t, double lead);

/* Does the 2D hit h of the ray from the origin along dir lie in its
 * Gaussian's bounds, the camera at the origin and no farther (focal 100,
 * the filter's pole bounded by GAUSSIAN_NEAR)? A point of the ray within
 * the lead of the hit's distance must be in the box. */
int hit_in_its_box(const gaussian_model *m, vec3 dir, const gaussian_hit *h, double lead);

/* The 2DGS semantics (both circle rules, both near rules) and the four
 * rasterizer semantics (3DGRT has no cull and no screen footprint). */
enum { SPLATTING_FORMATIONS = 7 };
extern const gaussian_formation splatting_formations[SPLATTING_FORMATIONS];

#endif
