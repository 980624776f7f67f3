/* Exact time integration's object kinds as rows (exact_internal.h's
 * exact_kind_ops, indexed by object_kind as accel_build.c's Embree rows
 * are): what a candidate of each kind keeps, how its state over a piece is
 * certified, and how it is shaded at one time. */
#include "render/exact_internal.h"

static vec3 f3(const float *a) { return v3(a[0], a[1], a[2]); }

/* The largest factor by which the ellipse coordinates (du.q, dv.q) stretch
 * an in-plane displacement q: the spectral norm of the 2x3 map, from the
 * larger eigenvalue of its 2x2 Gram matrix (1 / the smaller radius). */
static double dual_norm(const splat_geom *g)
{
    vec3 du = f3(g->dual_u), dv = f3(g->dual_v);
    double a = v3_dot(du, du), b = v3_dot(du, dv), c = v3_dot(dv, dv);
    double lambda = 0.5 * (a + c) + sqrt(0.25 * (a - c) * (a - c) + b * b);
    return sqrt(lambda) * (1 + 1e-12);
}

/* Where a ray crosses a candidate splat's plane (splat_depth_d and
 * splat_radius2_d, the sampled path's rule in double): depth s and squared
 * ellipse radius r2, both INFINITY when the ray is parallel to the plane
 * (denom = D.n = 0: no hit, as in splat_intersect). */
typedef struct {
    double denom, s, r2;
} plane_crossing;

static plane_crossing plane_crossing_of(const cand_info *g, const object_ray *r)
{
    plane_crossing pc = {0, INFINITY, INFINITY};
    double o[3] = {r->org.x, r->org.y, r->org.z}, d[3] = {r->dir.x, r->dir.y, r->dir.z}, co[3];
    if (splat_depth_d(g->center, g->normal, o, d, co, &pc.denom, &pc.s))
        pc.r2 = splat_radius2_d(g->dual_u, g->dual_v, co, d, pc.s);
    else
        pc.s = INFINITY;
    return pc;
}

/* A ray against an analytic sphere (hitrules.h) and the depth s of its
 * visible crossing from the origin on (the far root when neither is ahead:
 * then s < 0, no hit). */
static sphere_crossing sphere_crossing_of(const scene_object *o, const object_ray *r, double *s)
{
    sphere_crossing sc = sphere_cross(r->org, r->dir, o->sphere_center, o->sphere_radius);
    int k = sphere_visible_root(sc.root, 0.0, INFINITY);
    *s = sc.root[k < 0 ? 1 : k];
    return sc;
}

/* A splat: the farthest of its points from the model-space point c is
 * within twice its radius of its centre (a plane crossing within the slack
 * of the ellipse, splat_eval's slack < 1, is inside it); its plane, ellipse
 * and shading normal for the certificates. */
static void splat_describe(const scene_object *o, unsigned prim, vec3 c, cand_info *info)
{
    const float *e = &o->model.extent[3 * (size_t)prim];
    const splat_geom *g = &o->model.geom[prim];
    info->reach = v3_len(v3_sub(f3(g->center), c)) + 2.0 * sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    for (int k = 0; k < 3; k++) {
        info->center[k] = g->center[k], info->normal[k] = g->plane_normal[k];
        info->dual_u[k] = g->dual_u[k], info->dual_v[k] = g->dual_v[k];
    }
    info->dual_norm = dual_norm(g);
    info->shading_normal = f3(pointmodel_normal(&o->model, prim));
}

/* A sphere: its farthest point from c; the certificates need nothing else. */
static void sphere_describe(const scene_object *o, unsigned prim, vec3 c, cand_info *info)
{
    (void)prim;
    info->reach = v3_len(v3_sub(o->sphere_center, c)) + o->sphere_radius;
}

/* A splat at the piece's middle, and whether its state holds over the piece.
 * Hit plane crossing P (depth s), ellipse radius r. Over the piece:
 * - the crossing moves by at most sigma = delta / (|D.n| - eps_d) in depth
 *   (the ray point at depth s moves by delta, then slides along the ray to
 *   the plane) and in the plane by the ray point's motion projected along
 *   the ray onto the plane, a projection of norm 1 / cos(ray, normal):
 *   move = delta (|D| + eps_d) / (|D.n| - eps_d) = sigma (|D| + eps_d);
 * - the ellipse coordinates (a, b) = (du.q, dv.q) move by at most
 *   kappa * move, kappa the spectral norm of [du; dv] (dual_norm);
 * so r > 1 + kappa move: never covered; r < 1 - kappa move and s > sigma:
 * always covered. D moves by at most eps_d (its turn rate). The same argument run backwards from a hit at another
 * time gives the first (a hit then puts P within move of the ellipse). */
static cand_eval splat_eval(const scene_object *o, const cand_info *g, const object_ray *r, double delta, double eps_d)
{
    (void)o;
    plane_crossing pc = plane_crossing_of(g, r);
    double denom = pc.denom, radius = sqrt(pc.r2);
    cand_eval e = {0, 1, pc.s, 0.0};
    e.hit = denom != 0 && e.s >= 0 && radius <= 1;
    if (delta == 0) /* nothing moves relative to the ray */
        return e;
    double cabs = fabs(denom);
    e.sure = 0;
    e.sigma = INFINITY; /* depth range unknown */
    if (!(cabs > eps_d))
        return e;
    e.sigma = delta / (cabs - eps_d);
    double move = e.sigma * (v3_len(r->dir) + eps_d);
    double slack = g->dual_norm * move;
    /* which side of the shading normal faces the eye must not change either */
    double side = fabs(v3_dot(g->shading_normal, r->dir));
    e.sure = radius > 1 + slack || (e.s < -e.sigma && slack < 1) || (radius < 1 - slack && e.s > e.sigma && side > eps_d);
    return e;
}

/* An analytic sphere: the line's distance rho from the center moves by at
 * most delta, and the visible crossing stays within the shell of
 * half-width delta about the surface on the same side (front from outside,
 * back from inside): its depth stays between the shell's crossings. */
static cand_eval sphere_eval(const scene_object *o, const cand_info *g, const object_ray *r, double delta, double eps_d)
{
    (void)g, (void)eps_d;
    double s;
    sphere_crossing sc = sphere_crossing_of(o, r, &s);
    double R = o->sphere_radius, A = sc.A, B = sc.B, oc2 = sc.oc2;
    cand_eval e = {0, 1, INFINITY, 0.0};
    if (sc.disc >= 0) {
        e.s = s;
        e.hit = e.s >= 0;
    }
    if (delta == 0)
        return e;
    double rho = sqrt(fmax(0.0, oc2 - B * B / A)), lam = sqrt(A), centre = -B / A, dist = sqrt(oc2);
    e.sure = rho > R + delta;
    e.sigma = INFINITY; /* depth range unknown until certified */
    if (e.sure || !(rho < R - delta) || fabs(dist - R) <= delta)
        return e;
    double outer = sqrt((R + delta) * (R + delta) - rho * rho) / lam;
    double inner = sqrt(fmax(0.0, (R - delta) * (R - delta) - rho * rho)) / lam;
    double lo = dist > R ? centre - outer : centre + inner, hi = dist > R ? centre - inner : centre + outer;
    e.sigma = fmax(e.s - lo, hi - e.s);
    e.sure = lo > 0 || hi < 0;
    return e;
}

/* The splat hit at one time: no hit when the ray is parallel to its
 * plane (as in splat_intersect). */
static int splat_cross(const scene_object *o, const cand_info *g, const object_ray *r, exact_crossing *x)
{
    plane_crossing pc = plane_crossing_of(g, r);
    if (pc.denom == 0)
        return 0;
    const float *sc = pointmodel_color(&o->model, g->prim);
    x->s = pc.s, x->r2 = pc.r2;
    x->normal = g->shading_normal;
    x->color = v3(sc[0], sc[1], sc[2]);
    return 1;
}

/* The sphere's visible crossing, its outward normal there. */
static int sphere_cross_at(const scene_object *o, const cand_info *g, const object_ray *r, exact_crossing *x)
{
    (void)g;
    sphere_crossing_of(o, r, &x->s);
    x->r2 = 0.0;
    x->normal = v3_scale(v3_sub(v3_add(r->org, v3_scale(r->dir, x->s)), o->sphere_center), 1.0 / o->sphere_radius);
    x->color = o->sphere_color;
    return 1;
}

/* A Gaussian model's row is empty: the exact integrator's check refuses
 * exact time for it (exact_integrate.c, exact_check). Every kind has its
 * row, empty or not (asserted): a kind added last without one does not
 * build (scene.h, object_kind). */
static const exact_kind_ops exact_rows[] = {
    [OBJECT_POINTS] = {splat_describe, splat_eval, splat_cross, 0},
    [OBJECT_SPHERE] = {sphere_describe, sphere_eval, sphere_cross_at, 1},
    [OBJECT_GAUSSIANS] = {NULL, NULL, NULL, 0},
};
_Static_assert(sizeof exact_rows / sizeof *exact_rows == OBJECT_KIND_COUNT, "an object kind without its exact row");

/* The bound is checked before the row is read or its address taken. */
const exact_kind_ops *exact_kind_row(const scene_object *o)
{
    RR_DCHECK((unsigned)o->kind < OBJECT_KIND_COUNT);
    const exact_kind_ops *row = &exact_rows[o->kind];
    RR_DCHECK(row->eval);
    return row;
}
