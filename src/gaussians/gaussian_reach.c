/* How far from its mean a Gaussian can give a ray alpha >= 1/255, and the
 * object-space boxes the BVH is built from (gaussian_hit.h): the kernel's
 * reach, the screen footprint's, the traversal pad and key lead. */
#include "gaussians/gaussian_hit_internal.h"

#include "core/interval.h"

/* The kernel radius (in scales) beyond which alpha < 1/255 (gaussian_alpha_reach2);
 * 3DGRT also drops responses at or below GAUSSIAN_GRT_MIN_RESPONSE. 0:
 * never seen. */
static double kernel_reach(const gaussian_model *m, size_t i)
{
    double r2 = gaussian_alpha_reach2(m->opacity[i]);
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        r2 = rr_fmin(r2, -2.0 * log(GAUSSIAN_GRT_MIN_RESPONSE));
    return r2 > 0 ? sqrt(r2) : 0.0;
}

/* Only 2D models' hits can lie off the centre's depth (gaussian_hit.h). */
double gaussian_traversal_pad(const gaussian_model *m, double s, double depth_per_t)
{
    if (m->kind != GAUSSIAN_2D)
        return 0.0;
    /* the hit lies in the splat's plane within 3.33 scales of the centre
     * (rho3d <= 2 ln 255), or has the centre's depth while the filter's
     * circle point lies within 3 scales (the filter won) */
    return traversal_pad_double(s, depth_per_t);
}

double gaussian_key_lead(const gaussian_model *m, gaussian_order order, double s, double depth_per_t)
{
    /* the same bound: a centre-depth key is the centre's, within 3.33
     * scales of its 2D hit (gaussian_traversal_pad) */
    return order == GAUSSIAN_ORDER_CENTER_DEPTH ? gaussian_traversal_pad(m, s, depth_per_t) : 0.0;
}

static aabb bounds_with_reach(const gaussian_model *m, size_t i, const double view_reach[3]);

double gaussian_filter_near(double min_scale, double max_scale)
{
    return GAUSSIAN_NEAR * min_scale / (max_scale * max_scale);
}

/* 2DGS: rho2d = 2 |d|^2 <= 2 ln(255 o): the ray's pixel lies within
 * sqrt(ln(255 o)) pixels of the centre of the image of the filter's circle
 * (c scales), which is the image of a point P of its disc (filter_pole,
 * *along_plane: in the splat's plane); at P's view depth (at most distance
 * + |P - mean|) a pixel spans depth / focal (*across_view: at P's view
 * depth, so across the view axis). */
static void filter_2d_reach(const gaussian_model *m, size_t i, const gaussian_view_bound *v, double *along_plane,
                            double *across_view)
{
    double px2 = 0.5 * gaussian_alpha_reach2(m->opacity[i]); /* exact: halving a double */
    *along_plane = *across_view = 0.0;
    if (!(px2 > 0))
        return;
    const float *s = &m->scale[3 * i];
    double radius = filter_circle(m) * rr_fmax(s[0], s[1]);
    double pole = v->near > 0 ? rr_fmin(radius, filter_pole_double(radius, v->near)) : radius;
    *along_plane = pole, *across_view = sqrt(px2) * (v->distance + pole) / v->focal;
}

/* The 3D rasterizers: the ray through a pixel d pixels from the mean's
 * image passes the mean's depth z within |d| z / f_min of it, and alpha >=
 * 1/255 needs |d|^2 <= 2 ln(255 o) lambda_max(cov2D), lambda_max <=
 * (f_max / z)^2 (1 + lim^2) s^2 + dilation: within k sqrt(stretch^2 s^2 +
 * dilation (z / f_min)^2), z at most the distance, across the view axis
 * (the hit is at the mean's view depth). */
static double footprint_3d_reach(const gaussian_model *m, size_t i, const gaussian_view_bound *v)
{
    double k2 = gaussian_alpha_reach2(m->opacity[i]);
    if (!(k2 > 0))
        return 0.0;
    const float *s = &m->scale[3 * i];
    double sigma = rr_fmax(s[0], rr_fmax(s[1], s[2])) * v->stretch, z = v->distance / v->focal;
    return sqrt(k2 * (sigma * sigma + raster_rules_of(gaussian_formation_of(m))->dilation * z * z));
}

/* The screen footprint's reach about the mean: a part that can point any
 * way, and a part across the view axis. */
static void view_reach_parts(const gaussian_model *m, size_t i, const gaussian_view_bound *v, double *any,
                             double *across)
{
    switch (gaussian_formation_of(m)) {
    case GAUSSIAN_FORMATION_2DGS:
    case GAUSSIAN_FORMATION_2DGS_CENTER_NEAR:
    case GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE: filter_2d_reach(m, i, v, any, across); return;
    case GAUSSIAN_FORMATION_3DGRT: *any = *across = 0.0; return;
    default: *any = 0.0, *across = footprint_3d_reach(m, i, v); return;
    }
}

double gaussian_view_reach(const gaussian_model *m, size_t i, const gaussian_view_bound *v)
{
    double any, across;
    view_reach_parts(m, i, v, &any, &across);
    return any + across;
}

/* How far along unit axis e (component n_e of the view axis n) a vector of
 * length 1 across a view axis within `cone` radians of n reaches: across
 * the axis a it reaches sqrt(1 - (a.e)^2), and the least |a.e| in the cone
 * is sin(max(0, asin|n_e| - cone)). 1 without a view axis. */
static double across_view_extent(const gaussian_view_bound *v, double n_e)
{
    if (!(v->cone < M_PI / 2) || v3_dot(v->axis, v->axis) == 0 || !(fabs(n_e) <= 1.0))
        return 1.0;
    /* 1e-6 more cone: asin near 1 magnifies n_e's rounding (1e-16 -> 1.5e-8 rad) */
    double tilt = asin(fabs(n_e)) - v->cone - 1e-6;
    return tilt > 0 ? cos(tilt) * (1 + 1e-9) + 1e-12 : 1.0;
}

aabb gaussian_view_bounds(const gaussian_model *m, size_t i, const gaussian_view_bound *v)
{
    double any, across, n[3] = {v->axis.x, v->axis.y, v->axis.z}, reach[3];
    view_reach_parts(m, i, v, &any, &across);
    for (int a = 0; a < 3; a++)
        reach[a] = any + across * across_view_extent(v, n[a]);
    return bounds_with_reach(m, i, reach);
}

aabb gaussian_bounds(const gaussian_model *m, size_t i, double view_reach)
{
    double reach[3] = {view_reach, view_reach, view_reach};
    return bounds_with_reach(m, i, reach);
}

static aabb bounds_with_reach(const gaussian_model *m, size_t i, const double view_reach[3])
{
    const float *mu = &m->mean[3 * i], *s = &m->scale[3 * i];
    double R[3][3], k = kernel_reach(m, i);
    quaternion_matrix(&m->rotation[4 * i], R);
    aabb b;
    double c[3] = {mu[0], mu[1], mu[2]}, lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        double e2 = 0;
        for (int j = 0; j < 3; j++) /* a 2D Gaussian's third scale is 0 */
            e2 += (R[a][j] * s[j]) * (R[a][j] * s[j]);
        double e = rr_fmax(k * sqrt(e2), view_reach[a]);
        /* float rounding never clips a Gaussian (core/interval.h) */
        interval box = interval_widen(interval_around(c[a], e), interval_float_room(e, c[a]));
        lo[a] = box.lo, hi[a] = box.hi;
    }
    b.lo = v3(lo[0], lo[1], lo[2]), b.hi = v3(hi[0], hi[1], hi[2]);
    return b;
}
