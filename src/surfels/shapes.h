/* Procedural surfel models on analytic shapes, so scenes and tests do not
 * depend on downloaded data. Output is deterministic (no randomness). */
#ifndef RR_SHAPES_H
#define RR_SHAPES_H

#include "surfels/surfel.h"

typedef struct {
    char kind[16];      /* "sphere", "torus" or "plane" */
    size_t count;       /* approximate number of splats */
    double radius;      /* sphere radius; torus major radius; plane half side */
    double minor_radius;/* torus tube radius */
    vec3 color, color2; /* checker colors (color2 used when checker > 0) */
    int checker;        /* checker cells: per side (plane), per pi (sphere, torus) */
    double overlap;     /* splat radius factor over the hole-free minimum */
} shape_params;

void shape_params_default(shape_params *p);

/* Generates surfels in object space (centered at the origin; plane in z=0
 * with normal +z). *out is malloc'ed; the caller frees it. */
int shape_generate(const shape_params *p, surfel **out, size_t *n, rr_error *err);

#endif
