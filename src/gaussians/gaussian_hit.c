/* One ray seen in a Gaussian model's space (gaussian_ray_init), and a
 * Gaussian's hit dispatched to its formation's rule (gaussian_hit_2d.c,
 * gaussian_hit_3d.c) once gaussian_cull.c has kept it. */
#include "gaussians/gaussian_hit_internal.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

void gaussian_ray_init(gaussian_ray *r, const camera_view *view, const xform *xf, double x, double y, vec3 org,
                       vec3 dir)
{
    for (int k = 0; k < 3; k++) {
        const vec3 a = view->axis[k];
        for (int j = 0; j < 3; j++) /* axis_k . (column j of the object's linear part) */
            r->m[k][j] = a.x * xf->r[0][j] + a.y * xf->r[1][j] + a.z * xf->r[2][j];
        r->m[k][3] = v3_dot(a, v3_sub(xf->t, view->position));
    }
    r->fx = view->fx, r->fy = view->fy, r->cx = view->cx, r->cy = view->cy;
    r->width = view->width, r->height = view->height;
    r->x = x, r->y = y;
    r->eye = xform_inverse_point(xf, view->position);
    r->org = xform_inverse_point(xf, org);
    r->dir = xform_inverse_vector(xf, dir);
    r->depth_per_t = v3_dot(dir, view->axis[2]);
    r->tmin = 0.0, r->tmax = INFINITY;
    double col2[3] = {0, 0, 0};
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 3; k++)
            col2[j] += xf->r[k][j] * xf->r[k][j];
    r->scale = sqrt(rr_fmax(col2[0], rr_fmax(col2[1], col2[2]))) * (1 + 1e-9);
    r->stretch = gaussian_view_stretch(view);
    r->stretch_fov_minus_one = raster_pinned_stretch(view);
}

int gaussian_hit_after_cull(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                            gaussian_hit *h)
{
    if (m->kind == GAUSSIAN_2D)
        return hit_2d_after_cull(m, i, order, r, p, h);
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        return gaussian_hit_3dgrt(m, i, r, h);
    return hit_3d_raster_after_cull(m, i, r, p, h);
}

int gaussian_hits_after_cull4(const gaussian_model *m, const unsigned prim[4], gaussian_order order,
                              const gaussian_ray *r, const vec3 p[4], gaussian_hit h[4])
{
    int found = 0;
#if RR_LANES
    if (m->kind == GAUSSIAN_2D && rr_lanes_available()) {
        splat_2d_geometry_double g[4];
        splat_2d_geometry_in_lanes(m, prim, r, p, g);
        for (int j = 0; j < 4; j++)
            found |= hit_2d_from_geometry(m, prim[j], order, r, p[j], &g[j], &h[j]) << j;
        return found;
    }
#endif
    for (int j = 0; j < 4; j++)
        found |= gaussian_hit_after_cull(m, prim[j], order, r, p[j], &h[j]) << j;
    return found;
}

#ifdef RR_DCHECKS
/* Whether a lane's splat_2d_geometry differs in any bit from one
 * Gaussian's: the hits' floats hide a double's last bits. */
static int geometry_differs(const splat_2d_geometry_double *a, const splat_2d_geometry_double *b)
{
    if (memcmp(a->row, b->row, sizeof a->row) || memcmp(&a->cz, &b->cz, sizeof a->cz))
        return 1;
    if (a->cz == 0)
        return 0;
    double x[] = {a->u, a->v, a->rho3d, a->rho2d, a->centre_x, a->centre_y, a->plane_depth};
    double y[] = {b->u, b->v, b->rho3d, b->rho2d, b->centre_x, b->centre_y, b->plane_depth};
    return memcmp(x, y, sizeof x) || a->filtered != b->filtered;
}

int gaussian_2d_geometry_lanes_differ(const gaussian_model *m, const unsigned prim[4], const gaussian_ray *r,
                                      const vec3 p[4])
{
    int differ = 0;
#if RR_LANES
    if (m->kind != GAUSSIAN_2D || !rr_lanes_available())
        return 0;
    splat_2d_geometry_double four[4], one;
    splat_2d_geometry_in_lanes(m, prim, r, p, four);
    for (int j = 0; j < 4; j++) {
        gaussian_splat_rows(m, prim[j], r, p[j], one.row);
        splat_2d_geometry_of_double(r, filter_circle(m), &one);
        differ |= geometry_differs(&one, &four[j]) << j;
    }
#else
    (void)m, (void)prim, (void)r, (void)p;
#endif
    return differ;
}
#endif

int gaussian_hit_any(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, gaussian_hit *h)
{
    vec3 p;
    return gaussian_cull(m, i, r, &p) && gaussian_hit_after_cull(m, i, order, r, p, h);
}
