#include "surfels/splat.h"

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

/* One body for both precisions (splat.h); the order of every operation is
 * fixed here, so each precision gives the same numbers wherever it is used. */
#define DOT3(a, b) ((a)[0] * (b)[0] + (a)[1] * (b)[1] + (a)[2] * (b)[2])
#define DEFINE_SPLAT_RULES(T, suffix)                                                                  \
    int splat_depth_##suffix(const T c[3], const T n[3], const T o[3], const T d[3], T co[3], T *denom, \
                             T *t)                                                                     \
    {                                                                                                  \
        *denom = DOT3(d, n);                                                                           \
        if (*denom == 0)                                                                               \
            return 0;                                                                                  \
        co[0] = c[0] - o[0], co[1] = c[1] - o[1], co[2] = c[2] - o[2];                                 \
        *t = DOT3(co, n) / *denom;                                                                     \
        return 1;                                                                                      \
    }                                                                                                  \
    void splat_coords_##suffix(const T du[3], const T dv[3], const T co[3], const T d[3], T t, T ab[2])  \
    {                                                                                                  \
        T q[3] = {t * d[0] - co[0], t * d[1] - co[1], t * d[2] - co[2]};                               \
        ab[0] = DOT3(du, q), ab[1] = DOT3(dv, q);                                                      \
    }                                                                                                  \
    T splat_radius2_##suffix(const T du[3], const T dv[3], const T co[3], const T d[3], T t)           \
    {                                                                                                  \
        T ab[2];                                                                                       \
        splat_coords_##suffix(du, dv, co, d, t, ab);                                                   \
        return ab[0] * ab[0] + ab[1] * ab[1];                                                          \
    }
DEFINE_SPLAT_RULES(float, f)
DEFINE_SPLAT_RULES(double, d)

int splat_intersect(const splat_geom *s, const float o[3], const float d[3],
                    float tnear, float tfar, float *t_out, float *r2_out)
{
    float co[3], denom, t;
    if (!splat_depth_f(s->center, s->plane_normal, o, d, co, &denom, &t))
        return 0;
    if (!(t >= tnear && t <= tfar))
        return 0;
    float r2 = splat_radius2_f(s->dual_u, s->dual_v, co, d, t);
    if (!(r2 <= 1.0f))
        return 0;
    *t_out = t;
    *r2_out = r2;
    return 1;
}

void splat_geom_axes(const splat_geom *s, vec3 *u, vec3 *v)
{
    /* the inverse of the matrix with rows du, dv, n has the columns
     * (dv x n, n x du, du x dv) / det, the first two the axes */
    vec3 du = v3(s->dual_u[0], s->dual_u[1], s->dual_u[2]), dv = v3(s->dual_v[0], s->dual_v[1], s->dual_v[2]);
    vec3 n = v3(s->plane_normal[0], s->plane_normal[1], s->plane_normal[2]);
    vec3 c0 = v3_cross(dv, n), c1 = v3_cross(n, du);
    double det = v3_dot(du, c0);
    *u = v3_scale(c0, 1.0 / det), *v = v3_scale(c1, 1.0 / det);
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
