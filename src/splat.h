/* Elliptical surface splats: ray intersection and kernel weight.
 * Pure math, no Embree and no scene knowledge.
 *
 * A splat is the ellipse {c + a*u + b*v : a^2 + b^2 <= 1} (thesis eq. 4.2),
 * where u and v are its tangent axes scaled to the principal radii. For fast
 * intersection we store the unit plane normal and the dual axes du, dv with
 * du.u = dv.v = 1 and du.v = dv.u = du.n = dv.n = 0, so that the splat
 * coordinates of a point q in the plane are a = du.(q-c), b = dv.(q-c). */
#ifndef RR_SPLAT_H
#define RR_SPLAT_H

#include "common.h"

typedef struct {
    float center[3];
    float plane_normal[3];
    float dual_u[3];
    float dual_v[3];
} splat_geom;

/* Precomputes the intersection form of the splat (c, u, v). Returns -1 when
 * u and v are (nearly) parallel or zero, i.e. the ellipse is degenerate. */
int splat_geom_init(splat_geom *s, vec3 c, vec3 u, vec3 v);

/* Intersects the ray o + t*d with the splat. On a hit with tnear <= t <= tfar
 * returns 1 and sets *t and *r2 = a^2 + b^2 (squared kernel radius). */
int splat_intersect(const splat_geom *s, const float o[3], const float d[3],
                    float tnear, float tfar, float *t, float *r2);

/* Truncated Gaussian kernel weight exp(-r^2 / (2 sigma^2)) for r <= 1, 0
 * beyond (the splat's elliptical support, thesis sec. 2.1). */
double splat_kernel_weight(double r2, double sigma);

/* Tight axis-aligned bounds of the ellipse c +- a*u + b*v: along axis k the
 * extent is sqrt(u_k^2 + v_k^2). */
aabb splat_bounds(vec3 c, vec3 u, vec3 v);

/* Builds two orthogonal tangent axes of length radius perpendicular to n
 * (a circular splat). n need not be normalised but must be non-zero. */
void splat_axes_from_normal(vec3 n, double radius, vec3 *u, vec3 *v);

#endif
