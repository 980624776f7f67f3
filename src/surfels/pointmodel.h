/* A point model: an array of elliptical surfel splats with per-splat
 * shading normal and color, in the object's own coordinate system. */
#ifndef RR_POINTMODEL_H
#define RR_POINTMODEL_H

#include "core/common.h"
#include "surfels/splat.h"

typedef struct {
    size_t count, capacity;
    splat_geom *geom; /* intersection form, one per splat */
    /* 6 per splat: unit shading normal, then linear RGB color. Interleaved
     * because a hit reads both: one cache miss instead of two. */
    float *shading;
    float *extent;    /* 3 per splat: half size of the tight box about the center */
    aabb bounds;      /* union of the tight splat bounds */
} pointmodel;

static inline const float *pointmodel_normal(const pointmodel *m, size_t i) { return &m->shading[6 * i]; }
static inline const float *pointmodel_color(const pointmodel *m, size_t i) { return &m->shading[6 * i + 3]; }

void pointmodel_init(pointmodel *m);
void pointmodel_free(pointmodel *m);

/* Appends the splat c + a*u + b*v (a^2+b^2 <= 1) with shading normal n (made
 * unit; if zero, u x v is used) and color. Returns -1 with a reason for a
 * degenerate ellipse, non-finite input or out-of-memory. */
int pointmodel_add(pointmodel *m, vec3 c, vec3 u, vec3 v, vec3 n, vec3 color, rr_error *err);

/* Appends a circular splat of the given radius perpendicular to n. */
int pointmodel_add_circle(pointmodel *m, vec3 c, vec3 n, double radius, vec3 color, rr_error *err);

/* Reorders the splats along a Morton (Z-order) curve of their centers, so
 * that splats near in space are near in memory: the BVH's neighbouring
 * leaves then share cache lines (measured with make bench: see
 * src/bench/BENCH.md). The image depends on the order only through the summation order
 * of hits at exactly equal depth (coplanar splats), i.e. in the last bits.
 * If order_out is given it receives a malloc'ed array (NULL for an empty
 * model): new splat i was old splat (*order_out)[i]. */
int pointmodel_sort_spatially(pointmodel *m, size_t **order_out, rr_error *err);

#endif
