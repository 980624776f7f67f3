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

#include "core/common.h"

typedef struct {
    float center[3];
    float plane_normal[3];
    float dual_u[3];
    float dual_v[3];
} splat_geom;

/* Precomputes the intersection form of the splat (c, u, v). Returns -1 when
 * u and v are (nearly) parallel or zero, i.e. the ellipse is degenerate. */
int splat_geom_init(splat_geom *s, vec3 c, vec3 u, vec3 v);

/* The one ray/splat-plane rule, at two precisions from one body (splat.c):
 * the sampled path traces in float (splat_intersect), exact time in double
 * (exact.c), and a rule restated by hand would drift apart.
 * splat_depth_*: 0 when the ray is parallel to the plane (denom = d.n = 0:
 * no area there); else the crossing's depth t and co = c - o.
 * splat_radius2_*: a^2 + b^2 of the crossing at depth t (thesis eq. 4.2);
 * splat_coords_*: its a and b (the EWA filter of src/splatting/ needs them). */
int splat_depth_f(const float c[3], const float n[3], const float o[3], const float d[3], float co[3],
                  float *denom, float *t);
float splat_radius2_f(const float du[3], const float dv[3], const float co[3], const float d[3], float t);
int splat_depth_d(const double c[3], const double n[3], const double o[3], const double d[3], double co[3],
                  double *denom, double *t);
double splat_radius2_d(const double du[3], const double dv[3], const double co[3], const double d[3], double t);
void splat_coords_f(const float du[3], const float dv[3], const float co[3], const float d[3], float t, float ab[2]);
void splat_coords_d(const double du[3], const double dv[3], const double co[3], const double d[3], double t,
                    double ab[2]);

/* The tangent axes u, v back from the intersection form (the dual basis
 * inverted; float rounding aside, the axes splat_geom_init was given). */
void splat_geom_axes(const splat_geom *s, vec3 *u, vec3 *v);

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
