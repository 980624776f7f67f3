#include "splatting/frame.h"

#include <math.h>
#include <stdlib.h>

#include "surfels/hitrules.h"

int splat_frame_init(splat_frame *f, const scene *s, splat_filter filter)
{
    size_t n = (size_t)s->cam.width * s->cam.height;
    *f = (splat_frame){.sc = s, .filter = filter, .width = s->cam.width, .height = s->cam.height,
                       .camera_moves = scene_camera_moves(s), .ray_time = NAN};
    f->org = malloc(n * sizeof *f->org), f->dir = malloc(n * sizeof *f->dir);
    f->depth = malloc(n * sizeof *f->depth), f->depth_time = malloc(n * sizeof *f->depth_time);
    f->attr_depth = malloc(n * sizeof *f->attr_depth), f->attr_time = malloc(n * sizeof *f->attr_time);
    f->sums = malloc(n * sizeof *f->sums);
    if (!f->org || !f->dir || !f->depth || !f->depth_time || !f->attr_depth || !f->attr_time || !f->sums) {
        splat_frame_free(f);
        return -1;
    }
    splat_frame_clear(f);
    return 0;
}

void splat_frame_free(splat_frame *f)
{
    free(f->org), free(f->dir), free(f->depth), free(f->depth_time), free(f->attr_depth), free(f->attr_time);
    free(f->sums);
    f->org = f->dir = NULL, f->depth = f->attr_depth = NULL, f->depth_time = f->attr_time = NULL, f->sums = NULL;
}

void splat_frame_clear(splat_frame *f)
{
    size_t n = (size_t)f->width * f->height;
    for (size_t i = 0; i < n; i++) {
        f->depth[i] = f->attr_depth[i] = INFINITY;
        f->depth_time[i] = f->attr_time[i] = 0;
        shade_sums_init(&f->sums[i]);
    }
}

/* The ray through pixel centre (x + 1/2, y + 1/2) at time t, as the
 * sampled integrators make it for --pixel-filter point (scene_camera_ray:
 * a still camera's from its rest pose). */
static void pixel_ray(const splat_frame *f, int x, int y, double t, vec3 *org, vec3 *dir)
{
    scene_camera_ray(f->sc, x + 0.5, y + 0.5, t, org, dir);
}

void splat_frame_set_rays(splat_frame *f, double t)
{
    if (f->ray_time == t || (!f->camera_moves && !isnan(f->ray_time)))
        return;
    for (int y = 0; y < f->height; y++)
        for (int x = 0; x < f->width; x++)
            pixel_ray(f, x, y, t, &f->org[(size_t)y * f->width + x], &f->dir[(size_t)y * f->width + x]);
    f->ray_time = t;
}

/* A splat of one object at one instant, placed and projected. */
typedef struct {
    const scene_object *o;
    xform xf;
    size_t i;
    int x0, x1, y0, y1;  /* footprint: pixels x0 <= x <= x1, y0 <= y <= y1 */
    double cx, cy;       /* projected centre (raster), for the screen-space filter */
    int centre_valid;
    /* --filter ewa: the inverse of V = sigma^2 I + J^-1 J^-T (xx, xy, yy) and 1 / (2 pi sqrt |V|) */
    double vi[3], gauss_norm;
    int ewa_ok;
} placed_splat;

int splat_project(const camera_view *v, vec3 p, double *x, double *y)
{
    vec3 d = v3_sub(p, v->position);
    double z = v3_dot(d, v->axis[2]);
    if (!(z > 1e-12 * (1 + v3_len(d))))
        return 0;
    *x = v->fx * v3_dot(d, v->axis[0]) / z + v->cx;
    *y = v->fy * v3_dot(d, v->axis[1]) / z + v->cy;
    return 1;
}

static int clampi(double v, int lo, int hi)
{
    return v < lo ? lo : v > hi ? hi : (int)v;
}

/* The pixels whose centres x + 1/2, y + 1/2 lie in the raster box
 * lo..hi, padded by a pixel against rounding. */
static void pixels_of(const splat_frame *f, const double lo[2], const double hi[2], int box[4])
{
    box[0] = clampi(floor(lo[0] - 0.5) - 1, 0, f->width), box[1] = clampi(ceil(hi[0] - 0.5) + 1, -1, f->width - 1);
    box[2] = clampi(floor(lo[1] - 0.5) - 1, 0, f->height), box[3] = clampi(ceil(hi[1] - 0.5) + 1, -1, f->height - 1);
}

/* Projects the world points; 0 when one is not in front of the camera. */
static int raster_extent(const camera_view *v, const vec3 *pts, int n, double lo[2], double hi[2])
{
    lo[0] = lo[1] = INFINITY, hi[0] = hi[1] = -INFINITY;
    for (int k = 0; k < n; k++) {
        double x, y;
        if (!splat_project(v, pts[k], &x, &y))
            return 0;
        lo[0] = fmin(lo[0], x), hi[0] = fmax(hi[0], x), lo[1] = fmin(lo[1], y), hi[1] = fmax(hi[1], y);
    }
    return 1;
}

void splat_footprint_of(const splat_frame *f, const camera_view *v, const vec3 corners[8], int box[4])
{
    double lo[2], hi[2];
    if (!raster_extent(v, corners, 8, lo, hi)) { /* reaches behind the camera: every pixel */
        box[0] = box[2] = 0, box[1] = f->width - 1, box[3] = f->height - 1;
        return;
    }
    pixels_of(f, lo, hi, box);
}

/* Ren, Pfister, Zwicker 2002, sec. 5.2: the Jacobian J of the projection
 * from the splat's parameters (a, b) (the point c + a u + b v) to raster
 * coordinates at its centre, then their eq. 7's object-space resampling
 * filter G_V, V = V^r + J^-1 J^-T with V^r = sigma^2 I (our kernel
 * exp(-r^2 / (2 sigma^2)) is G_{sigma^2 I} up to a factor every splat
 * shares, which the per-pixel normalisation removes). Returns the raster
 * half-extents of the screen-space filter J V^r J^T + I (eq. 5) at the
 * kernel's cutoff r = 1, i.e. 1 / sigma standard deviations. */
static void ewa_setup(const splat_frame *f, const camera_view *v, placed_splat *p, double half[2])
{
    vec3 u, w, c = xform_point(&p->xf, v3(p->o->model.geom[p->i].center[0], p->o->model.geom[p->i].center[1],
                                             p->o->model.geom[p->i].center[2]));
    splat_geom_axes(&p->o->model.geom[p->i], &u, &w);
    vec3 ax[2] = {xform_vector(&p->xf, u), xform_vector(&p->xf, w)}, d = v3_sub(c, v->position);
    double z = v3_dot(d, v->axis[2]), J[2][2], s2 = f->sc->kernel_sigma * f->sc->kernel_sigma;
    for (int j = 0; j < 2; j++) {
        double az = v3_dot(ax[j], v->axis[2]);
        J[0][j] = v->fx * (v3_dot(ax[j], v->axis[0]) * z - v3_dot(d, v->axis[0]) * az) / (z * z);
        J[1][j] = v->fy * (v3_dot(ax[j], v->axis[1]) * z - v3_dot(d, v->axis[1]) * az) / (z * z);
    }
    /* J^-1 J^-T = (J^T J)^-1 */
    double m00 = J[0][0] * J[0][0] + J[1][0] * J[1][0], m01 = J[0][0] * J[0][1] + J[1][0] * J[1][1];
    double m11 = J[0][1] * J[0][1] + J[1][1] * J[1][1], det = m00 * m11 - m01 * m01;
    p->ewa_ok = z > 0 && det > 1e-12 * (m00 * m11) && det > 0;
    half[0] = sqrt(s2 * (J[0][0] * J[0][0] + J[0][1] * J[0][1]) + 1) / f->sc->kernel_sigma;
    half[1] = sqrt(s2 * (J[1][0] * J[1][0] + J[1][1] * J[1][1]) + 1) / f->sc->kernel_sigma;
    if (!p->ewa_ok)
        return;
    double v00 = s2 + m11 / det, v01 = -m01 / det, v11 = s2 + m00 / det, dv = v00 * v11 - v01 * v01;
    p->vi[0] = v11 / dv, p->vi[1] = -v01 / dv, p->vi[2] = v00 / dv;
    p->gauss_norm = 1.0 / (2.0 * M_PI * sqrt(dv));
}

/* Thesis sec. 4.2.1: the footprint is the projection of the splat's
 * bounds (its object-space box, placed at t); with the EWA approximation
 * (sec. 4.2.3) it also holds the disc of radius sqrt 2 about the projected
 * centre; with the EWA filter the screen-space filter's box (ewa_setup). */
static void footprint(const splat_frame *f, const camera_view *v, placed_splat *p)
{
    const float *c = p->o->model.geom[p->i].center, *e = &p->o->model.extent[3 * p->i];
    vec3 corners[8];
    for (int k = 0; k < 8; k++)
        corners[k] = xform_point(&p->xf, v3(c[0] + (k & 1 ? e[0] : -e[0]), c[1] + (k & 2 ? e[1] : -e[1]),
                                            c[2] + (k & 4 ? e[2] : -e[2])));
    p->centre_valid = splat_project(v, xform_point(&p->xf, v3(c[0], c[1], c[2])), &p->cx, &p->cy);
    double lo[2], hi[2];
    int box[4];
    if (!raster_extent(v, corners, 8, lo, hi)) {
        p->x0 = p->y0 = 0, p->x1 = f->width - 1, p->y1 = f->height - 1;
        return;
    }
    double half[2] = {M_SQRT2, M_SQRT2};
    if (f->filter == SPLAT_FILTER_EWA)
        ewa_setup(f, v, p, half);
    if (f->filter != SPLAT_FILTER_NONE && p->centre_valid) {
        lo[0] = fmin(lo[0], p->cx - half[0]), hi[0] = fmax(hi[0], p->cx + half[0]);
        lo[1] = fmin(lo[1], p->cy - half[1]), hi[1] = fmax(hi[1], p->cy + half[1]);
    }
    pixels_of(f, lo, hi, box);
    p->x0 = box[0], p->x1 = box[1], p->y0 = box[2], p->y1 = box[3];
}

/* One fragment: the pixel's ray in the object's space (as accel.c moves
 * it: from the double world ray, then to float) against the splat's plane;
 * its depth t and squared kernel radius r2 (> 1 outside the ellipse). */
typedef struct {
    float t, r2, odir[3];
    float ab[2]; /* the crossing's splat parameters (--filter ewa) */
} fragment;

static int fragment_at(const splat_frame *f, const placed_splat *p, vec3 org, vec3 dir, fragment *fr)
{
    vec3 o = xform_inverse_point(&p->xf, org), d = xform_inverse_vector(&p->xf, dir);
    const float of[3] = {(float)o.x, (float)o.y, (float)o.z};
    fr->odir[0] = (float)d.x, fr->odir[1] = (float)d.y, fr->odir[2] = (float)d.z;
    const splat_geom *g = &p->o->model.geom[p->i];
    float co[3], denom;
    if (!splat_depth_f(g->center, g->plane_normal, of, fr->odir, co, &denom, &fr->t) || !(fr->t >= 0.0f))
        return 0; /* Embree's rays start at tnear 0 */
    fr->r2 = splat_radius2_f(g->dual_u, g->dual_v, co, fr->odir, fr->t);
    if (f->filter == SPLAT_FILTER_EWA)
        splat_coords_f(g->dual_u, g->dual_v, co, fr->odir, fr->t, fr->ab);
    return 1;
}

typedef void fragment_fn(splat_frame *f, const placed_splat *p, size_t px, const fragment *fr, double t);

/* Every splat of every object placed at t, each footprint pixel offered to fn. */
static void raster(splat_frame *f, double t, fragment_fn *fn)
{
    splat_frame_set_rays(f, t);
    camera_view v;
    scene_camera_view(f->sc, t, &v);
    for (int k = 0; k < f->sc->nobjects; k++) {
        placed_splat p = {.o = &f->sc->objects[k]};
        p.xf = animation_at(&p.o->anim, t);
        for (p.i = 0; p.i < p.o->model.count; p.i++) {
            footprint(f, &v, &p);
            for (int y = p.y0; y <= p.y1; y++)
                for (int x = p.x0; x <= p.x1; x++) {
                    size_t px = (size_t)y * f->width + x;
                    fragment fr;
                    f->fragments++;
                    if (fragment_at(f, &p, f->org[px], f->dir[px], &fr))
                        fn(f, &p, px, &fr, t);
                }
        }
    }
}

/* Visibility pass (sec. 4.1.1): the depth buffer keeps the closest
 * crossing inside the ellipse (eq. 4.2); the screen-space filter's extra
 * pixels do not write depth (sec. 4.2.3, last paragraph). */
static void visibility_fragment(splat_frame *f, const placed_splat *p, size_t px, const fragment *fr, double t)
{
    (void)p;
    if (fr->r2 <= 1.0f && fr->t < f->depth[px])
        f->depth[px] = fr->t, f->depth_time[px] = t;
}

void splat_visibility_pass(splat_frame *f, double t) { raster(f, t, visibility_fragment); }

/* Eq. 4.13: r~ = min(r2D, r3D), r2D = d(x, y)^2 / r^2 with r = sqrt 2
 * pixels from the projected centre; none: r3D alone. */
static double filtered_r2(const splat_frame *f, const placed_splat *p, size_t px, const fragment *fr)
{
    if (f->filter != SPLAT_FILTER_BOTSCH || !p->centre_valid)
        return fr->r2;
    double dx = (double)(px % (size_t)f->width) + 0.5 - p->cx, dy = (double)(px / (size_t)f->width) + 0.5 - p->cy;
    return fmin((dx * dx + dy * dy) / 2.0, fr->r2);
}

/* A fragment's weight, 0 when the filter rejects it: the kernel h(r~) (none,
 * botsch), or Ren et al.'s eq. 7 G_V(u) at the crossing's parameters u,
 * cut where u^T V^-1 u > 1 / sigma^2 (the kernel's own cutoff r = 1). */
static double fragment_weight(const splat_frame *f, const placed_splat *p, size_t px, const fragment *fr)
{
    if (f->filter != SPLAT_FILTER_EWA) {
        double r2 = filtered_r2(f, p, px, fr);
        return r2 <= 1.0 ? splat_kernel_weight(r2, f->sc->kernel_sigma) : 0.0;
    }
    if (!p->ewa_ok)
        return 0.0;
    double a = fr->ab[0], b = fr->ab[1], q = p->vi[0] * a * a + 2 * p->vi[1] * a * b + p->vi[2] * b * b;
    double sigma = f->sc->kernel_sigma;
    return q * sigma * sigma <= 1.0 ? p->gauss_norm * exp(-0.5 * q) : 0.0;
}

/* Attribute pass (sec. 4.1.1, eq. 4.3): a fragment within epsilon of the
 * depth buffer adds its kernel-weighted colour, normal and material. */
static void attribute_fragment(splat_frame *f, const placed_splat *p, size_t px, const fragment *fr, double t)
{
    double weight = fragment_weight(f, p, px, fr);
    if (!(weight > 0) || (isfinite(f->depth[px]) && !kbuffer_within(fr->t, f->depth[px], (float)f->sc->epsilon)))
        return;
    const float *n = pointmodel_normal(&p->o->model, p->i);
    /* as accel.c's accept_hit: the normal facing the eye, moved to world space */
    vec3 wn = xform_normal(&p->xf, normal_facing_eye(v3(n[0], n[1], n[2]), v3(fr->odir[0], fr->odir[1], fr->odir[2])));
    const float wnf[3] = {(float)wn.x, (float)wn.y, (float)wn.z};
    float w = (float)weight; /* as the k-buffer stores it */
    shade_sums_add(&f->sums[px], &p->o->mat, pointmodel_color(&p->o->model, p->i), wnf, w);
    if (fr->t < f->attr_depth[px])
        f->attr_depth[px] = fr->t, f->attr_time[px] = t;
}

void splat_attribute_pass(splat_frame *f, double t) { raster(f, t, attribute_fragment); }

void splat_shade_pass(splat_frame *f, float *rgba)
{
    const scene *s = f->sc;
    for (int y = 0; y < f->height; y++)
        for (int x = 0; x < f->width; x++) {
            size_t px = (size_t)y * f->width + x;
            float *out = &rgba[4 * px];
            int hit = isfinite(f->depth[px]) || f->sums[px].wsum > 0;
            vec3 c = s->background;
            if (hit && f->sums[px].wsum > 0) {
                int vis = isfinite(f->depth[px]);
                double t = vis ? f->depth_time[px] : f->attr_time[px];
                vec3 org, dir;
                pixel_ray(f, x, y, t, &org, &dir);
                c = shade_sums_color(s, &f->sums[px], org, dir, vis ? f->depth[px] : f->attr_depth[px]);
            }
            out[0] = (float)c.x, out[1] = (float)c.y, out[2] = (float)c.z, out[3] = hit ? 1.0f : 0.0f;
        }
}
