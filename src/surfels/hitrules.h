/* The rules a hit obeys, one function each, shared by the sampled path
 * (accel.c: Embree callbacks, float rays) and exact time integration
 * (exact.c, exact_integrate.c: double): what the two integrators see at
 * one instant must be the same surface, or exact time stops being a check
 * of the sampled path (pbrt-v4 likewise has one intersection routine per
 * shape for every integrator). The splat's own rule is splat.h's
 * splat_depth_* / splat_radius2_* pair. */
#ifndef RR_HITRULES_H
#define RR_HITRULES_H

#include "surfels/splat.h"

/* A ray org + s dir against the sphere (center, radius): A = |dir|^2,
 * B = oc.dir, oc2 = |oc|^2 (oc = org - center), the discriminant, and the
 * two roots (from the discriminant clamped at 0; there is no crossing
 * when disc < 0). */
typedef struct {
    double A, B, oc2, disc, root[2];
} sphere_crossing;

static inline sphere_crossing sphere_cross(vec3 org, vec3 dir, vec3 center, double radius)
{
    sphere_crossing c;
    vec3 oc = v3_sub(org, center);
    c.A = v3_dot(dir, dir), c.B = v3_dot(oc, dir), c.oc2 = v3_dot(oc, oc);
    c.disc = c.B * c.B - c.A * (c.oc2 - radius * radius);
    double sq = sqrt(fmax(0.0, c.disc));
    c.root[0] = (-c.B - sq) / c.A, c.root[1] = (-c.B + sq) / c.A;
    return c;
}

/* An opaque sphere shows its nearer crossing in [tnear, tfar] (the far one
 * from inside): the index of that root, -1 when neither is in range. */
static inline int sphere_visible_root(const double root[2], double tnear, double tfar)
{
    for (int i = 0; i < 2; i++)
        if (root[i] >= tnear && root[i] <= tfar)
            return i;
    return -1;
}

/* Surfaces are two-sided: the side facing the eye is shaded (scenes/README.md,
 * back faces), so a normal pointing along the ray is turned round. */
static inline vec3 normal_facing_eye(vec3 normal, vec3 dir)
{
    return v3_dot(normal, dir) > 0 ? v3_scale(normal, -1.0) : normal;
}

/* A hit's blending weight: the splat's truncated Gaussian kernel at r^2
 * (thesis sec. 2.1); an analytic sphere is opaque, weight 1. */
static inline double hit_weight(int is_sphere, double r2, double sigma)
{
    return is_sphere ? 1.0 : splat_kernel_weight(r2, sigma);
}

#endif
