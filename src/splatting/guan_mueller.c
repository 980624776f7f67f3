#include "splatting/guan_mueller.h"

#include <math.h>
#include <stdlib.h>

#include "surfels/hitrules.h"

/* ---- the points, in the order the paper draws them ----------------------- */

/* One point of one object, with the key it is bucket-sorted by (sec. 3.2:
 * "we first bucket-sort the points with respect to the viewpoint and then
 * render them in front-to-back order"; here an exact sort). */
typedef struct {
    const scene_object *o;
    size_t i;
    double depth;
} gm_point;

static int by_depth(const void *a, const void *b)
{
    double x = ((const gm_point *)a)->depth, y = ((const gm_point *)b)->depth;
    return (x > y) - (x < y);
}

/* A point placed at one instant: world centre, axes and normal. */
typedef struct {
    vec3 c, u, v, n;
    xform xf;
} gm_placed;

static gm_placed place(const scene_object *o, size_t i, double t)
{
    gm_placed p;
    const splat_geom *g = &o->model.geom[i];
    p.xf = animation_at(&o->anim, t);
    splat_geom_axes(g, &p.u, &p.v);
    p.c = xform_point(&p.xf, v3(g->center[0], g->center[1], g->center[2]));
    p.u = xform_vector(&p.xf, p.u), p.v = xform_vector(&p.xf, p.v);
    const float *sn = pointmodel_normal(&o->model, i);
    p.n = v3_normalize(xform_normal(&p.xf, v3(sn[0], sn[1], sn[2])));
    return p;
}

static size_t count_points(const scene *s)
{
    size_t n = 0;
    for (int j = 0; j < s->nobjects; j++)
        n += s->objects[j].model.count;
    return n;
}

/* Every point, sorted by the depth along the view axis of the camera v of
 * its centre at t0 and t1 averaged (the object at the flash: t0 = t1; a
 * trail: the middle of its motion vector). */
static void sort_points(const scene *s, const camera_view *v, double t0, double t1, gm_point *pts)
{
    size_t k = 0;
    for (int j = 0; j < s->nobjects; j++)
        for (size_t i = 0; i < s->objects[j].model.count; i++, k++) {
            vec3 mid = v3_scale(v3_add(place(&s->objects[j], i, t0).c, place(&s->objects[j], i, t1).c), 0.5);
            pts[k] = (gm_point){&s->objects[j], i, v3_dot(v3_sub(mid, v->position), v->axis[2])};
        }
    qsort(pts, k, sizeof *pts, by_depth);
}

/* The point's colour as the flash shows it: its attributes shaded at its
 * centre (sec. 4: a motion splat's intensity follows "the result of the
 * complete shading equation"; unlit: its colour). */
static vec3 point_color(const scene *s, const gm_placed *p, const scene_object *o, size_t i, vec3 eye)
{
    vec3 dir = v3_normalize(v3_sub(p->c, eye));
    const float *sn = pointmodel_normal(&o->model, i), *col = pointmodel_color(&o->model, i);
    vec3 wn = xform_normal(&p->xf, normal_facing_eye(v3(sn[0], sn[1], sn[2]), xform_inverse_vector(&p->xf, dir)));
    const float n[3] = {(float)wn.x, (float)wn.y, (float)wn.z}, c[3] = {col[0], col[1], col[2]};
    shade_sums one;
    shade_sums_init(&one);
    shade_sums_add(&one, &o->mat, c, n, 1.0);
    return shade_sums_color(s, &one, p->c, dir, 0.0);
}

/* ---- a layer composited front to back ----------------------------------- */

typedef struct {
    double *rgb;   /* 3 per pixel, premultiplied */
    double *trans; /* what still shows through: 1 - alpha (blend), or the summed alpha (add) */
} gm_layer;

static void layer_blend(gm_layer *l, size_t px, vec3 col, double a)
{
    double w = l->trans[px] * a;
    l->rgb[3 * px] += w * col.x, l->rgb[3 * px + 1] += w * col.y, l->rgb[3 * px + 2] += w * col.z;
    l->trans[px] *= 1.0 - a;
}

/* ---- the sharp object (sec. 3.2) ---------------------------------------- */

/* The Gaussian disk read where the ray meets its plane (a texture-mapped
 * square; splat_kernel_weight's truncated Gaussian in radii): 0 outside. */
static double disk_alpha(const gm_placed *p, vec3 org, vec3 dir, double sigma)
{
    double den = v3_dot(dir, p->n);
    if (!(fabs(den) > 0))
        return 0.0;
    double s = v3_dot(v3_sub(p->c, org), p->n) / den;
    if (!(s >= 0))
        return 0.0;
    vec3 q = v3_sub(v3_add(org, v3_scale(dir, s)), p->c);
    /* q = a u + b v: the 2x2 Gram system (u, v need not be orthogonal) */
    double uu = v3_dot(p->u, p->u), uv = v3_dot(p->u, p->v), vv = v3_dot(p->v, p->v), det = uu * vv - uv * uv;
    if (!(det > 0))
        return 0.0;
    double qu = v3_dot(q, p->u), qv = v3_dot(q, p->v), a = (vv * qu - uv * qv) / det, b = (uu * qv - uv * qu) / det;
    return splat_kernel_weight(a * a + b * b, sigma);
}

static void object_pass(splat_frame *f, const gm_point *pts, size_t n, double t, gm_layer *obj)
{
    camera_view v;
    scene_camera_view(f->sc, t, &v);
    splat_frame_set_rays(f, t);
    for (size_t k = 0; k < n; k++) {
        gm_placed p = place(pts[k].o, pts[k].i, t);
        vec3 col = point_color(f->sc, &p, pts[k].o, pts[k].i, v.position), corners[8];
        aabb b = splat_bounds(p.c, p.u, p.v);
        for (int j = 0; j < 8; j++)
            corners[j] = v3(j & 1 ? b.hi.x : b.lo.x, j & 2 ? b.hi.y : b.lo.y, j & 4 ? b.hi.z : b.lo.z);
        int box[4];
        splat_footprint_of(f, &v, corners, box);
        for (int y = box[2]; y <= box[3]; y++)
            for (int x = box[0]; x <= box[1]; x++) {
                size_t px = (size_t)y * f->width + x;
                f->fragments++;
                double a = disk_alpha(&p, f->org[px], f->dir[px], f->sc->kernel_sigma);
                if (a > 0)
                    layer_blend(obj, px, col, a);
            }
    }
}

/* ---- the trails (sec. 3.3, 4) ------------------------------------------- */

/* d(raster x, y) / d(world point) at p: the projection's Jacobian. */
static void raster_jacobian(const camera_view *v, vec3 p, vec3 jac[2])
{
    vec3 d = v3_sub(p, v->position);
    double z = v3_dot(d, v->axis[2]), f[2] = {v->fx, v->fy};
    for (int r = 0; r < 2; r++)
        jac[r] = v3_scale(v3_sub(v3_scale(v->axis[r], 1.0 / z), v3_scale(v->axis[2], v3_dot(d, v->axis[r]) / (z * z))),
                          f[r]);
}

/* One trail: centre (raster), the inverse of its 2D covariance, its peak. */
typedef struct {
    double mx, my, i00, i01, i11, peak, reach_x, reach_y;
} gm_trail;

/* Sec. 3.3's "more efficient method": the disk's 3D covariance (u u^T +
 * v v^T, zero along the normal) through the Jacobian, plus the rank-1
 * covariance of the projected motion vector m (an ellipse of zero width
 * spanning it: (m/2)(m/2)^T), centred at m's middle (Fig. 3-4), read as
 * the disk's Gaussian over the summed ellipse. A low-pass keeps a point's
 * integral, so the peak is sqrt(det V_disk / det V). 0 for a point behind
 * the camera at either end or seen edge-on (no footprint to blur). */
static int make_trail(const camera_view *v0, const camera_view *v1, const gm_placed *p0, const gm_placed *p1,
                      gm_trail *tr)
{
    double x0, y0, x1, y1;
    if (!splat_project(v0, p0->c, &x0, &y0) || !splat_project(v1, p1->c, &x1, &y1))
        return 0;
    vec3 jac[2];
    raster_jacobian(v1, p1->c, jac);
    double ju[2] = {v3_dot(jac[0], p1->u), v3_dot(jac[1], p1->u)}, jv[2] = {v3_dot(jac[0], p1->v), v3_dot(jac[1], p1->v)};
    double d00 = ju[0] * ju[0] + jv[0] * jv[0], d01 = ju[0] * ju[1] + jv[0] * jv[1], d11 = ju[1] * ju[1] + jv[1] * jv[1];
    double hx = 0.5 * (x1 - x0), hy = 0.5 * (y1 - y0);
    double v00 = d00 + hx * hx, v01 = d01 + hx * hy, v11 = d11 + hy * hy;
    double det_disk = d00 * d11 - d01 * d01, det = v00 * v11 - v01 * v01;
    if (!(det_disk > 1e-12 * (d00 + d11) * (d00 + d11)) || !isfinite(det))
        return 0;
    *tr = (gm_trail){0.5 * (x0 + x1), 0.5 * (y0 + y1), v11 / det, -v01 / det, v00 / det, sqrt(det_disk / det),
                     sqrt(v00), sqrt(v11)};
    return 1;
}

static void trail_raster(splat_frame *f, const gm_trail *tr, vec3 col, splat_trails mode, gm_layer *m)
{
    int x0 = (int)fmax(0, floor(tr->mx - tr->reach_x - 1)), x1 = (int)fmin(f->width - 1, ceil(tr->mx + tr->reach_x));
    int y0 = (int)fmax(0, floor(tr->my - tr->reach_y - 1)), y1 = (int)fmin(f->height - 1, ceil(tr->my + tr->reach_y));
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++) {
            double dx = x + 0.5 - tr->mx, dy = y + 0.5 - tr->my;
            double rho2 = tr->i00 * dx * dx + 2 * tr->i01 * dx * dy + tr->i11 * dy * dy;
            double g = tr->peak * splat_kernel_weight(rho2, f->sc->kernel_sigma);
            size_t px = (size_t)y * f->width + x;
            f->fragments++;
            if (!(g > 0))
                continue;
            if (mode == SPLAT_TRAILS_BLEND)
                layer_blend(m, px, col, g);
            else {
                m->rgb[3 * px] += g * col.x, m->rgb[3 * px + 1] += g * col.y, m->rgb[3 * px + 2] += g * col.z;
                m->trans[px] += g;
            }
        }
}

/* One trail per point whose normal faces the viewer at the flash (sec. 4:
 * "we do not generate motion splats for points with back-facing normals"),
 * from its place at the shutter's open to its place at the close, as the
 * camera saw each (a moving camera's trails are the motion on the image). */
static void trail_pass(splat_frame *f, const splat_settings *set, const gm_point *pts, size_t n, gm_layer *m)
{
    double t0 = f->sc->shut.open, t1 = f->sc->shut.close;
    camera_view v0, v1;
    scene_camera_view(f->sc, t0, &v0), scene_camera_view(f->sc, t1, &v1);
    for (size_t k = 0; k < n; k++) {
        gm_placed p0 = place(pts[k].o, pts[k].i, t0), p1 = place(pts[k].o, pts[k].i, t1);
        gm_trail tr;
        if (!(v3_dot(p1.n, v3_sub(v1.position, p1.c)) > 0) || !make_trail(&v0, &v1, &p0, &p1, &tr))
            continue;
        trail_raster(f, &tr, point_color(f->sc, &p1, pts[k].o, pts[k].i, v1.position), set->trails, m);
    }
}

/* ---- the two images (sec. 4) --------------------------------------------- */

/* The object image over the motion image over the background (sec. 4:
 * "alpha-blending the object and the motion image in that order"). */
static void composite(const splat_frame *f, const gm_layer *obj, const gm_layer *mot, splat_trails mode, float *rgba)
{
    vec3 bg = f->sc->background;
    double bgc[3] = {bg.x, bg.y, bg.z};
    for (size_t i = 0; i < (size_t)f->width * f->height; i++) {
        double oa = 1.0 - obj->trans[i], ma = mode == SPLAT_TRAILS_ADD ? fmin(1.0, mot->trans[i]) : 1.0 - mot->trans[i];
        for (int ch = 0; ch < 3; ch++)
            rgba[4 * i + ch] = (float)(obj->rgb[3 * i + ch] + (1 - oa) * (mot->rgb[3 * i + ch] + (1 - ma) * bgc[ch]));
        rgba[4 * i + 3] = (float)(oa + (1 - oa) * ma);
    }
}

int splat_guan_mueller(splat_frame *f, const splat_settings *set, float *rgba, rr_error *err)
{
    size_t npx = (size_t)f->width * f->height, n = count_points(f->sc);
    gm_point *pts = malloc((n ? n : 1) * sizeof *pts);
    double *mem = calloc(8 * npx, sizeof *mem);
    if (!pts || !mem) {
        free(pts), free(mem);
        return rr_fail(err, "out of memory for the motion-hint buffers");
    }
    gm_layer obj = {mem, mem + 3 * npx}, mot = {mem + 4 * npx, mem + 7 * npx};
    for (size_t i = 0; i < npx; i++)
        obj.trans[i] = 1.0, mot.trans[i] = set->trails == SPLAT_TRAILS_ADD ? 0.0 : 1.0;
    camera_view v;
    double flash = f->sc->shut.close; /* the current frame (sec. 4's M_curr) */
    scene_camera_view(f->sc, flash, &v);
    sort_points(f->sc, &v, flash, flash, pts);
    object_pass(f, pts, n, flash, &obj);
    sort_points(f->sc, &v, f->sc->shut.open, flash, pts);
    trail_pass(f, set, pts, n, &mot);
    composite(f, &obj, &mot, set->trails, rgba);
    free(pts), free(mem);
    return 0;
}
