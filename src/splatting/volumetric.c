#include "splatting/volumetric.h"

#include <math.h>
#include <stdlib.h>

#include "surfels/hitrules.h"

/* ---- the kernel of one splat at one instant (Appendix C) ----------------- */

typedef struct {
    vec3 c, n, vel;         /* centre, unit plane normal, velocity relative to the camera (world axes) */
    vec3 shading_n, color;  /* object-space shading normal (world after xform_normal), colour */
    double S0[3][3];        /* the still splat's covariance a0 a0^T + a1 a1^T + (1e-3 r)^2 n n^T */
    double S[3][3], Si[3][3]; /* S = S0 + w w^T and its inverse */
    vec3 w;                 /* the 1D Gaussian's axis along the velocity */
    vec3 u, v;              /* the splat's axes (world), the source's plane */
    const material *mat;
    const xform *xf;
} kernel;

static void outer_add(double m[3][3], vec3 a, double s)
{
    double v[3] = {a.x, a.y, a.z};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            m[i][j] += s * v[i] * v[j];
}

/* Inverse of a symmetric 3x3 matrix (adjugate over determinant); 0 if singular. */
static int inverse3(const double m[3][3], double out[3][3])
{
    double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1], c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2],
           c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    if (!(fabs(det) > 0) || !isfinite(det))
        return 0;
    double inv = 1.0 / det;
    out[0][0] = c00 * inv, out[1][0] = c01 * inv, out[2][0] = c02 * inv;
    out[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv;
    out[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv;
    out[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv;
    out[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv;
    out[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv;
    out[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv;
    return 1;
}

static vec3 mat_vec(const double m[3][3], vec3 v)
{
    return v3(m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
              m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z);
}

/* One object at instant t: its transform there and at t -+ h, and the
 * camera at the three times (cam NULL for a still camera). */
typedef struct {
    xform xf, before, after;
    double h;
    const camera_view *cam; /* [0] at t, [1] at t - h, [2] at t + h */
} instant_motion;

/* The centre's velocity relative to the camera, in world coordinates at t:
 * v_rel = R_c2w(t) d/dt[W2C(t) p(t)], the motion that moves the splat's
 * image (sec. 3.6.3 stretches the kernel along "the motion"; thesis eq.
 * 3.6 lets the camera's parameters vary in time, and the image of a still
 * splat under a moving camera is the image of the splat moving the other
 * way under a still one). Both derivatives are central differences of the
 * paths over t -+ h, as the splat's own velocity always was: the error is
 * O(h^2) of the paths' third derivative, and the rounding of 1e-16 |p| in
 * v's numerator puts 1e-16 |p| dt / h = 1e-12 |p| into the kernel's axis
 * w = v dt sigma_t / sigma for h = 1e-4 dt, far below any extent. A still
 * camera takes the world velocity as before (bit for bit). */
static vec3 relative_velocity(const instant_motion *m, vec3 c)
{
    vec3 pb = xform_point(&m->before, c), pa = xform_point(&m->after, c);
    if (!m->cam)
        return v3_scale(v3_sub(pa, pb), 0.5 / m->h);
    vec3 vel = v3(0, 0, 0);
    for (int j = 0; j < 3; j++) {
        double before = v3_dot(m->cam[1].axis[j], v3_sub(pb, m->cam[1].position));
        double after = v3_dot(m->cam[2].axis[j], v3_sub(pa, m->cam[2].position));
        vel = v3_add(vel, v3_scale(m->cam[0].axis[j], (after - before) * 0.5 / m->h));
    }
    return vel;
}

/* Sec. 3.6.3 and App. C: the splat's 2D Gaussian convolved with a 1D
 * Gaussian along its instantaneous velocity (relative to the camera, as
 * relative_velocity says) is the Gaussian of the summed
 * covariances (exact on the CPU; the GPU eigen-solver of C.2 failed):
 * S = a0 a0^T + a1 a1^T + w w^T, w = v dt sigma_t / sigma (dt the slice the
 * kernel stands for, sigma_t in units of |v| dt, sigma the kernel sigma in
 * radii, so that the 1D Gaussian's standard deviation is sigma_t |v| dt).
 * (1e-3 r)^2 n n^T keeps S invertible when v is 0 or in the plane: C.3.1
 * and C.3.2's epsilon n. Returns 0 for a kernel that cannot be inverted. */
static int make_kernel(const scene_object *o, size_t i, const instant_motion *m, double dt, double sigma_t,
                       double sigma, kernel *k)
{
    const xform *xf = &m->xf;
    const splat_geom *g = &o->model.geom[i];
    vec3 u, v, c = v3(g->center[0], g->center[1], g->center[2]);
    splat_geom_axes(g, &u, &v);
    u = xform_vector(xf, u), v = xform_vector(xf, v);
    k->c = xform_point(xf, c);
    k->n = v3_normalize(v3_cross(u, v));
    k->u = u, k->v = v;
    k->vel = relative_velocity(m, c);
    k->w = v3_scale(k->vel, dt * sigma_t / sigma);
    double r = fmax(v3_len(u), v3_len(v));
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            k->S0[a][b] = 0;
    outer_add(k->S0, u, 1), outer_add(k->S0, v, 1), outer_add(k->S0, k->n, 1e-6 * r * r);
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            k->S[a][b] = k->S0[a][b];
    outer_add(k->S, k->w, 1);
    const float *sn = pointmodel_normal(&o->model, i), *col = pointmodel_color(&o->model, i);
    k->shading_n = v3(sn[0], sn[1], sn[2]), k->color = v3(col[0], col[1], col[2]);
    k->mat = &o->mat, k->xf = xf;
    return inverse3(k->S, k->Si);
}

/* The ellipsoid's axis-aligned box: half extents sqrt(S_jj). */
static void kernel_corners(const kernel *k, vec3 corners[8])
{
    vec3 e = v3(sqrt(k->S[0][0]), sqrt(k->S[1][1]), sqrt(k->S[2][2]));
    for (int j = 0; j < 8; j++)
        corners[j] = v3(k->c.x + (j & 1 ? e.x : -e.x), k->c.y + (j & 2 ? e.y : -e.y), k->c.z + (j & 4 ? e.z : -e.z));
}

/* ---- one fragment (sec. 4.2.2) ------------------------------------------ */

typedef struct {
    double h, rho; /* weight and temporal density */
    vec3 src;      /* source point on the 2D splat */
} vfragment;

static double quad(const double m[3][3], vec3 a, vec3 b) { return v3_dot(a, mat_vec(m, b)); }

/* rho: how much of the still splat's footprint the kernel's holds, seen
 * along d: sqrt(det(P S0 P^T) / det(P S P^T)) with P onto the plane normal
 * to d, which the matrix determinant lemma makes 1 / sqrt(1 + u^T A^-1 u),
 * A = P S0 P^T, u = P w: the kernel's footprint then holds the still
 * splat's weight once, however long the slice (sec. 4.2.2: "the intensity
 * integral of a kernel is constant independent of the length in time"). */
static double temporal_density(const kernel *k, vec3 d)
{
    vec3 e1 = v3_normalize(v3_cross(d, fabs(d.x) < 0.9 ? v3(1, 0, 0) : v3(0, 1, 0))), e2 = v3_cross(d, e1);
    double a = quad(k->S0, e1, e1), b = quad(k->S0, e1, e2), c = quad(k->S0, e2, e2);
    double det = a * c - b * b, u1 = v3_dot(e1, k->w), u2 = v3_dot(e2, k->w);
    if (!(det > 0))
        return 1.0;
    return 1.0 / sqrt(1.0 + (c * u1 * u1 - 2 * b * u1 * u2 + a * u2 * u2) / det);
}

/* The source point of a kernel point x (App. C.6): "each point in the
 * interior of the volumetric kernel lies on the motion trail of its 2D
 * splat source point" (sec. 4.2.2). The kernel is the unit ball under the
 * axes (u, v, w, thickness n): x - c = alpha u + beta v + tau w + delta
 * thickness n, and the source is c + alpha u + beta v. The coefficients
 * that give x - c with the least norm are x's parameter-space position
 * (its norm is the |m| of the weight): (alpha, beta) = (u, v)^T S^-1 (x - c),
 * so the source is c + (u u^T + v v^T) S^-1 (x - c), inside the splat for
 * every x inside the kernel. Where w crosses the plane this is eqs.
 * C.42-C.44's trace-back along v (x - v (q.n / v.n)) but for delta
 * thickness |v| / |v.n|; where v lies in or near the plane, C.44 divides
 * by a v.n of rounding noise (the central difference leaves 1e-12 |v|
 * there) and C.3.1's orthogonal projection lands up to |w| off the splat:
 * both put the source where something else occludes it, or off the image
 * where the depth test is skipped (issue 56: a hidden splat showed
 * through, green 0.534 for 0.100). */
static vec3 source_point(const kernel *k, vec3 x)
{
    vec3 p = mat_vec(k->Si, v3_sub(x, k->c));
    return v3_add(k->c, v3_add(v3_scale(k->u, v3_dot(k->u, p)), v3_scale(k->v, v3_dot(k->v, p))));
}

/* The ray org + s dir against the kernel's ellipsoid (x - c)^T Si (x - c)
 * = 1 (sec. 4.2.2 after Sigg et al.): the chord's midpoint in parameter
 * space m has |m|^2 = 1 - (L / 2)^2 for a chord of length L there, and the
 * weight h(|m|) = exp(-|m|^2 / (2 sigma^2)) is the 3D Gaussian at the
 * midpoint (sec. 4.1.2's words): it grows with the chord, as sec. 4.2.2's
 * text asks and eq. 4.12's h(L / 2) does not. */
static int kernel_fragment(const kernel *k, vec3 org, vec3 dir, double sigma, vfragment *fr)
{
    vec3 oc = v3_sub(org, k->c);
    double A = quad(k->Si, dir, dir), B = quad(k->Si, dir, oc), C = quad(k->Si, oc, oc) - 1.0;
    double disc = B * B - A * C;
    if (!(disc >= 0) || !(A > 0))
        return 0;
    double s1 = (-B - sqrt(disc)) / A, s2 = (-B + sqrt(disc)) / A;
    if (s2 < 0)
        return 0;
    vec3 xm = v3_add(org, v3_scale(dir, 0.5 * (s1 + s2))), q = v3_sub(xm, k->c);
    fr->h = exp(-quad(k->Si, q, q) / (2.0 * sigma * sigma));
    fr->src = source_point(k, xm);
    fr->rho = temporal_density(k, dir);
    return 1;
}

/* ---- the passes --------------------------------------------------------- */

typedef struct {
    double *color;      /* 3 per pixel: sum a_k h C */
    double *weight;     /* sum a_k h */
    double *alpha;      /* sum over instants of a_k / sum a times the instant's alpha */
    double *num, *den;  /* this instant's sum h rho and sum h */
} vbuffers;

/* Eq. 4.1: the fragment passes if its source point is not occluded at
 * that instant: its distance from the eye within epsilon of the depth the
 * visibility pass left at the source's pixel (none there, or outside the
 * image: nothing occludes it). */
static int source_visible(const splat_frame *f, const camera_view *v, vec3 src)
{
    double x, y;
    if (!splat_project(v, src, &x, &y) || !(x >= 0 && x < f->width && y >= 0 && y < f->height))
        return 1;
    float depth = f->depth[(size_t)floor(y) * f->width + (size_t)floor(x)];
    return !isfinite(depth) || kbuffer_within((float)v3_len(v3_sub(src, v->position)), depth, (float)f->sc->epsilon);
}

/* Shading per kernel (sec. 4.1.2: deferred shading breaks moving
 * highlights, Fig. 4.4): the splat's own attributes, Phong at its source. */
static vec3 kernel_color(const splat_frame *f, const kernel *k, vec3 src, vec3 dir)
{
    vec3 odir = xform_inverse_vector(k->xf, dir);
    vec3 wn = xform_normal(k->xf, normal_facing_eye(k->shading_n, odir));
    const float n[3] = {(float)wn.x, (float)wn.y, (float)wn.z};
    const float c[3] = {(float)k->color.x, (float)k->color.y, (float)k->color.z};
    shade_sums one;
    shade_sums_init(&one);
    shade_sums_add(&one, k->mat, c, n, 1.0);
    return shade_sums_color(f->sc, &one, src, dir, 0.0);
}

static void kernel_pass(splat_frame *f, const camera_view *v, const kernel *k, double ak, vbuffers *b)
{
    vec3 corners[8];
    int box[4];
    kernel_corners(k, corners);
    splat_footprint_of(f, v, corners, box);
    for (int y = box[2]; y <= box[3]; y++)
        for (int x = box[0]; x <= box[1]; x++) {
            size_t px = (size_t)y * f->width + x;
            vfragment fr;
            f->fragments++;
            if (!kernel_fragment(k, f->org[px], f->dir[px], f->sc->kernel_sigma, &fr) || !source_visible(f, v, fr.src))
                continue;
            vec3 col = kernel_color(f, k, fr.src, f->dir[px]);
            double w = ak * fr.h;
            b->color[3 * px] += w * col.x, b->color[3 * px + 1] += w * col.y, b->color[3 * px + 2] += w * col.z;
            b->weight[px] += w;
            b->num[px] += fr.h * fr.rho, b->den[px] += fr.h;
        }
}

/* Every kernel at instant t (slice dt, weight a_k of the instants' sum). */
static void instant_pass(splat_frame *f, const splat_settings *set, double t, double dt, double ak, vbuffers *b)
{
    splat_frame_clear(f);
    splat_visibility_pass(f, t); /* per instant, of the 2D splats (sec. 4.1.2) */
    camera_view cam[3]; /* at t, t - h, t + h */
    instant_motion m = {.h = 1e-4 * dt, .cam = scene_camera_moves(f->sc) ? cam : NULL};
    scene_camera_view(f->sc, t, &cam[0]);
    scene_camera_view(f->sc, t - m.h, &cam[1]), scene_camera_view(f->sc, t + m.h, &cam[2]);
    size_t n = (size_t)f->width * f->height;
    for (size_t i = 0; i < n; i++)
        b->num[i] = b->den[i] = 0;
    for (int j = 0; j < f->sc->nobjects; j++) {
        const scene_object *o = &f->sc->objects[j];
        m.xf = animation_at(&o->anim, t), m.before = animation_at(&o->anim, t - m.h);
        m.after = animation_at(&o->anim, t + m.h);
        for (size_t i = 0; i < o->model.count; i++) {
            kernel k;
            if (make_kernel(o, i, &m, dt, set->sigma_t, f->sc->kernel_sigma, &k))
                kernel_pass(f, &cam[0], &k, ak, b);
        }
    }
    for (size_t i = 0; i < n; i++)
        b->alpha[i] += ak * (set->alpha == SPLAT_ALPHA_THESIS ? b->num[i] : b->den[i] > 0 ? b->num[i] / b->den[i] : 0);
}

int splat_volumetric(splat_frame *f, const splat_settings *set, float *rgba, rr_error *err)
{
    size_t n = (size_t)f->width * f->height;
    double *times = malloc((size_t)set->samples * sizeof *times), *mem = calloc(7 * n, sizeof *mem);
    if (!times || !mem) {
        free(times), free(mem);
        return rr_fail(err, "out of memory for the volumetric buffers");
    }
    vbuffers b = {mem, mem + 3 * n, mem + 4 * n, mem + 5 * n, mem + 6 * n};
    const shutter *shut = &f->sc->shut;
    splat_instants(set, shut, times);
    double asum = 0, dt = (shut->close - shut->open) / set->samples;
    for (int k = 0; k < set->samples; k++)
        asum += shutter_weight(shut, times[k]);
    for (int k = 0; asum > 0 && k < set->samples; k++)
        instant_pass(f, set, times[k], dt, shutter_weight(shut, times[k]) / asum, &b);
    vec3 bg = f->sc->background;
    for (size_t i = 0; i < n; i++) {
        double a = fmin(1.0, fmax(0.0, b.alpha[i])), inv = b.weight[i] > 0 ? 1.0 / b.weight[i] : 0.0;
        double c[3] = {b.color[3 * i] * inv, b.color[3 * i + 1] * inv, b.color[3 * i + 2] * inv}, bgc[3] = {bg.x, bg.y, bg.z};
        for (int ch = 0; ch < 3; ch++)
            rgba[4 * i + ch] = (float)(a * c[ch] + (1 - a) * bgc[ch]);
        rgba[4 * i + 3] = (float)a;
    }
    free(times), free(mem);
    return asum > 0 ? 0 : rr_fail(err, "every instant has weight a(t) = 0: nothing to splat");
}
