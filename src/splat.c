#include "splat.h"

static void store3(float out[3], vec3 a)
{
    out[0] = (float)a.x;
    out[1] = (float)a.y;
    out[2] = (float)a.z;
}

int splat_geom_init(splat_geom *s, vec3 c, vec3 u, vec3 v)
{
    vec3 n = v3_cross(u, v);
    double area = v3_len(n);
    double lu = v3_len(u), lv = v3_len(v);
    /* |u x v| = |u||v| sin(angle): reject zero axes and parallel axes. */
    if (!(lu > 0 && lv > 0 && area > 1e-9 * lu * lv))
        return -1;
    n = v3_scale(n, 1.0 / area);
    /* Dual basis of (u, v) within the plane: du = (v x n) / (u . (v x n)). */
    vec3 vn = v3_cross(v, n), nu = v3_cross(n, u);
    vec3 du = v3_scale(vn, 1.0 / v3_dot(u, vn));
    vec3 dv = v3_scale(nu, 1.0 / v3_dot(v, nu));
    store3(s->center, c);
    store3(s->plane_normal, n);
    store3(s->dual_u, du);
    store3(s->dual_v, dv);
    return 0;
}

static inline float dot3f(const float a[3], const float b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

int splat_intersect(const splat_geom *s, const float o[3], const float d[3],
                    float tnear, float tfar, float *t_out, float *r2_out)
{
    float denom = dot3f(d, s->plane_normal);
    if (denom == 0.0f)
        return 0; /* ray parallel to the splat plane: it has no area there */
    float co[3] = {s->center[0] - o[0], s->center[1] - o[1], s->center[2] - o[2]};
    float t = dot3f(co, s->plane_normal) / denom;
    if (!(t >= tnear && t <= tfar))
        return 0;
    float q[3] = {t * d[0] - co[0], t * d[1] - co[1], t * d[2] - co[2]};
    float a = dot3f(s->dual_u, q), b = dot3f(s->dual_v, q);
    float r2 = a * a + b * b;
    if (!(r2 <= 1.0f))
        return 0;
    *t_out = t;
    *r2_out = r2;
    return 1;
}

double splat_kernel_weight(double r2, double sigma)
{
    if (!(r2 <= 1.0))
        return 0.0;
    return exp(-r2 / (2.0 * sigma * sigma));
}

aabb splat_bounds(vec3 c, vec3 u, vec3 v)
{
    vec3 e = v3(sqrt(u.x * u.x + v.x * v.x), sqrt(u.y * u.y + v.y * v.y),
                sqrt(u.z * u.z + v.z * v.z));
    aabb b = {v3_sub(c, e), v3_add(c, e)};
    return b;
}

void splat_axes_from_normal(vec3 n, double radius, vec3 *u, vec3 *v)
{
    n = v3_normalize(n);
    /* Pick the world axis least aligned with n to build a stable tangent. */
    vec3 helper = fabs(n.x) < 0.6 ? v3(1, 0, 0) : (fabs(n.y) < 0.6 ? v3(0, 1, 0) : v3(0, 0, 1));
    vec3 a = v3_normalize(v3_cross(helper, n));
    vec3 b = v3_cross(n, a);
    *u = v3_scale(a, radius);
    *v = v3_scale(b, radius);
}
