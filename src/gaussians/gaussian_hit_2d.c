/* A 2DGS splat's hit (gaussian_hit.h): its geometry at the ray's pixel, one
 * Gaussian or four in lanes, the low-pass filter, the near and tile rules
 * of hbb1/diff-surfel-rasterization's forward.cu. */
#include "gaussians/gaussian_hit_internal.h"

/* Gaussian i's first two axes times their scales (object space). */
static void splat_axes(const gaussian_model *m, size_t i, double u[3], double v[3])
{
    const float *s = &m->scale[3 * i];
    double R[3][3];
    quaternion_matrix(&m->rotation[4 * i], R);
    for (int a = 0; a < 3; a++)
        u[a] = R[a][0] * s[0], v[a] = R[a][1] * s[1];
}

/* Gaussian i's rows of T (splat_rows), its mean at camera-space p. */
void gaussian_splat_rows(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p, double row[3][3])
{
    double u[3], v[3], pc[3] = {p.x, p.y, p.z};
    splat_axes(m, i, u, v);
    splat_rows_double(r, u, v, pc, row);
}

/* 2DGS's tile radius: at e0ed020 (preprocessCUDA) the 3-sigma circle's
 * image's half extent, at least 3 x FilterSize (0.707106), rounded up;
 * up to 3a9357f, 3 times the unit circle's image's half extent. */
static int in_2dgs_tiles(const gaussian_ray *r, const double row[3][3], double c, double centre_x, double centre_y)
{
    double d22 = DUAL_CONIC(row[2], row[2], c * c);
    double hx = centre_x * centre_x - DUAL_CONIC(row[0], row[0], c * c) / d22;
    double hy = centre_y * centre_y - DUAL_CONIC(row[1], row[1], c * c) / d22;
    /* the extent does not depend on where the pixel grid's origin is; the
     * centre in pixel-index coordinates (ndc2pix's (W-1)/2) is 0.5 less */
    double extent = sqrt(rr_fmax(1e-4, rr_fmax(hx, hy)));
    double radius = c == 1.0 ? ceil(3.0 * extent) : ceil(rr_fmax(extent, c * 0.707106f));
    return in_rasterizer_tiles(r, centre_x - 0.5, centre_y - 0.5, radius);
}

#if RR_LANES
/* splat_2d_geometry_of_double of four culled Gaussians (prim; p: their
 * camera-space means), computed in lanes. Their axes come from the scalar
 * splat_axes (one rotation rule), gathered in registers: doubles stored
 * one by one and loaded as a vector stalled on store forwarding (perf
 * annotate). */
RR_LANES_TARGET void splat_2d_geometry_in_lanes(const gaussian_model *m, const unsigned prim[4], const gaussian_ray *r,
                                                const vec3 p[4], splat_2d_geometry_double g[4])
{
    double u[4][3], v[4][3];
    for (int j = 0; j < 4; j++)
        splat_axes(m, prim[j], u[j], v[j]);
    v4d U[3], V[3], P[3] = {{p[0].x, p[1].x, p[2].x, p[3].x}, {p[0].y, p[1].y, p[2].y, p[3].y},
                            {p[0].z, p[1].z, p[2].z, p[3].z}};
    for (int a = 0; a < 3; a++)
        U[a] = (v4d){u[0][a], u[1][a], u[2][a], u[3][a]}, V[a] = (v4d){v[0][a], v[1][a], v[2][a], v[3][a]};
    splat_2d_geometry_v4d four;
    splat_rows_v4d(r, U, V, P, four.row);
    splat_2d_geometry_of_v4d(r, filter_circle(m), &four);
    for (int j = 0; j < 4; j++) {
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                g[j].row[a][b] = four.row[a][b][j];
        g[j].cz = four.cz[j], g[j].u = four.u[j], g[j].v = four.v[j], g[j].rho3d = four.rho3d[j];
        g[j].rho2d = four.rho2d[j], g[j].centre_x = four.centre_x[j], g[j].centre_y = four.centre_y[j];
        g[j].plane_depth = four.plane_depth[j], g[j].filtered = four.filtered[j] != 0;
    }
}
#endif

/* Whether the near skip takes the centre's view depth where the filter
 * wins: forward.cu renderCUDA's `depth = (rho3d <= rho2d) ? hit : Tw.z;
 * if (depth < near_n) continue;` from 661d224 (2024-05-06, the first
 * commit 2DGS pinned; fw:384-385) to 7bdbd51 (2024-08-28, fw:365-366);
 * e0ed020 ("fix near cull", fw:369-372) takes the plane hit's depth at
 * every pixel. */
static int near_by_centre_where_filtered(const gaussian_model *m)
{
    gaussian_formation f = gaussian_formation_of(m);
    return f == GAUSSIAN_FORMATION_2DGS_CENTER_NEAR || f == GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE;
}

/* Whether Gaussian i's plane holds the camera centre exactly (p: its
 * camera-space mean): forward.cu's DUAL_VISIABLE cull, -p_view . n == 0
 * (fw:209-214 at e0ed020 and 7bdbd51; since 3a9357f), with the normal as
 * t_u x t_v in camera space (so under an object's uneven scale too). */
static int splat_edge_on(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    double R[3][3];
    quaternion_matrix(&m->rotation[4 * i], R);
    vec3 tu = cam_vector(r->m, v3(R[0][0], R[1][0], R[2][0])), tv = cam_vector(r->m, v3(R[0][1], R[1][1], R[2][1]));
    return v3_dot(p, v3_cross(tu, tv)) == 0;
}

/* The tile rule's filter where the filter's circle reaches behind the
 * camera's plane (its image a hyperbola, not an ellipse): forward.cu at
 * e0ed020 goes on with the same formulas whatever the sign of the dual
 * conic's d = T_w . T_w (c^2, c^2, -1) (compute_aabb, fw:119-145, stops
 * only at d == 0; preprocessCUDA fw:226-236 takes the tiles of its
 * point_image and extent), and renderCUDA (fw:362-366) filters about that
 * point_image: the hyperbola's centre. So with tileRule the splat is drawn
 * in the hyperbola's tiles, filtered about its centre (GAUSSIANS.md says
 * which of those pixels the bounds can miss). 0 where d == 0: culled. */
static int hyperbola_filter(const gaussian_model *m, const gaussian_ray *r, const splat_2d_geometry_double *g,
                            splat_2d_geometry_double *out)
{
    double c = filter_circle(m), d22 = DUAL_CONIC(g->row[2], g->row[2], c * c);
    if (d22 == 0)
        return 0;
    *out = *g;
    out->centre_x = DUAL_CONIC(g->row[0], g->row[2], c * c) / d22;
    out->centre_y = DUAL_CONIC(g->row[1], g->row[2], c * c) / d22;
    double dx = out->centre_x - r->x, dy = out->centre_y - r->y;
    out->rho2d = GAUSSIAN_FILTER_INV_SQUARE * (dx * dx + dy * dy);
    out->filtered = 1;
    return 1;
}

/* Gaussian i's 2DGS hit from its geometry at the pixel (p: its
 * camera-space mean). */
int hit_2d_from_geometry(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                         const splat_2d_geometry_double *g, gaussian_hit *h)
{
    splat_2d_geometry_double hyperbola;
    if (g->cz == 0)
        return 0;
    if (m->tile_rule && !g->filtered) {
        if (!hyperbola_filter(m, r, g, &hyperbola))
            return 0;
        g = &hyperbola;
    }
    /* where the filter wins the hit is placed at the centre's depth, the
     * point its bounds and windows hold. The near skip takes the plane
     * hit's depth even there (forward.cu since e0ed020, the commit 2DGS
     * pins), or that centre's depth (the older rule): then filter pixels
     * whose ray meets the plane nearer than 0.2, or behind the camera, are
     * drawn (the centre is beyond 0.2: cull_2d). A splat seen exactly
     * edge-on (its plane holds the camera centre), which forward.cu culls
     * (DUAL_VISIABLE), shows nothing: under e0ed020's rule every ray meets
     * its plane at the camera centre, at view depth 0; under the older
     * one its filter pixels are culled by name */
    double depth = g->rho3d <= g->rho2d ? g->plane_depth : g->row[2][2];
    if (g->plane_depth < GAUSSIAN_NEAR) {
        if (!near_by_centre_where_filtered(m) || depth < GAUSSIAN_NEAR || splat_edge_on(m, i, r, p))
            return 0;
    }
    double rho = rr_fmin(g->rho3d, g->rho2d), t = depth / r->depth_per_t;
    /* alpha below 1/255 for certain (opacity <= 1): exp is the costly
     * part, and the exact test follows (a test with the opacity's own log
     * cost a log per candidate) */
    if (!(rho <= gaussian_alpha_reach2(1.0) + 1e-9) || !(t >= r->tmin && t < r->tmax))
        return 0;
    double alpha = clamp_alpha(GAUSSIAN_ALPHA_MAX, m->opacity[i], exp(-0.5 * rho));
    if (alpha < GAUSSIAN_ALPHA_MIN)
        return 0;
    if (m->tile_rule && (!g->filtered || !in_2dgs_tiles(r, g->row, filter_circle(m), g->centre_x, g->centre_y)))
        return 0;
    const float *mu = &m->mean[3 * i];
    vec3 dir = v3_sub(v3(mu[0], mu[1], mu[2]), r->eye);
    double key = order == GAUSSIAN_ORDER_CENTER_DEPTH ? p.z / r->depth_per_t : t;
    *h = (gaussian_hit){(float)key, (float)t, (float)alpha,
                        {(float)dir.x, (float)dir.y, (float)dir.z}, 0, (unsigned)i};
    return 1;
}

/* Gaussian i's 2DGS hit once cull_2d passed it (p: its camera-space mean). */
int hit_2d_after_cull(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                      gaussian_hit *h)
{
    splat_2d_geometry_double g;
    gaussian_splat_rows(m, i, r, p, g.row);
    splat_2d_geometry_of_double(r, filter_circle(m), &g);
    return hit_2d_from_geometry(m, i, order, r, p, &g, h);
}

int gaussian_hit_2d(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r,
                    gaussian_hit *h)
{
    vec3 p = camera_mean(m, i, r);
    return cull_2d(m, i, r, p) && hit_2d_after_cull(m, i, order, r, p, h);
}

int gaussian_filter_centre_2d(const gaussian_model *m, size_t i, const gaussian_ray *r, double *x, double *y)
{
    splat_2d_geometry_double g;
    gaussian_splat_rows(m, i, r, camera_mean(m, i, r), g.row);
    splat_2d_geometry_of_double(r, filter_circle(m), &g);
    if (g.filtered)
        *x = g.centre_x, *y = g.centre_y;
    return g.filtered;
}
