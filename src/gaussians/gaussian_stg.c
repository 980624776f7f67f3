/* SpacetimeGaussians-lite's rules (gaussian_stg.h): its row of
 * gaussian_dynamic_ops. */
#include "gaussians/gaussian_stg.h"

#include <float.h>
#include <math.h>
#include <stddef.h>

/* The motion's arrays share one block: per Gaussian 1 + 1 + 9 + 4 + 4
 * floats. */
gaussian_dynamic *gaussian_stg_alloc(size_t n)
{
    static const gaussian_dynamic_array arrays[] = {
        {offsetof(gaussian_stg, trbf_center), 1}, {offsetof(gaussian_stg, trbf_scale), 1},
        {offsetof(gaussian_stg, motion), 9}, {offsetof(gaussian_stg, omega), 4}, {offsetof(gaussian_stg, rot), 4}};
    return gaussian_dynamic_alloc(n, sizeof(gaussian_stg), &gaussian_stg_ops, arrays,
                                  (int)(sizeof arrays / sizeof *arrays));
}

/* ---- at t ------------------------------------------------------------------ */

/* One axis' cubic, (x, motion[k], motion[3 + k], motion[6 + k]), as
 * gaussian_dynamic_cubic_at evaluates it (forward.cu:196-198). */
static void axis_coefficients(const gaussian_model *m, size_t i, int k, double c[4])
{
    const float *mo = &gaussian_stg_of(m)->motion[9 * i];
    c[0] = m->mean[3 * i + k], c[1] = mo[k], c[2] = mo[3 + k], c[3] = mo[6 + k];
}

/* exp(-(D / exp(trbf_scale))^2): forward.cu:202-203 (the scale passed
 * as exp(trbf_scale), ourslite.py:835). */
static double temporal_weight(double D, float trbf_scale)
{
    double y = D / exp(trbf_scale);
    return exp(-(y * y));
}

/* D = t - trbf_center (renderer/__init__.py:318, forward.cu:186). */
static double offset_at(const gaussian_model *m, size_t i, double t)
{
    RR_DCHECK(i < m->count);
    return t - gaussian_stg_of(m)->trbf_center[i];
}

static void mean_at(const gaussian_model *m, size_t i, double D, double mean[3])
{
    double c[4];
    for (int k = 0; k < 3; k++) {
        axis_coefficients(m, i, k, c);
        mean[k] = gaussian_dynamic_cubic_at(c, D);
    }
}

/* F.normalize(rot + D omega): divided by max(|v|, eps), so 0 stays 0
 * (ourslite.py:123-126); the CUDA does not normalise again
 * (forward.cu:127). Components are floats plus a product with D, so |v|^2
 * neither overflows nor loses a nonzero v below 1e-150. */
static void rotation_at(const gaussian_model *m, size_t i, double D, double q[4])
{
    const gaussian_stg *st = gaussian_stg_of(m);
    double v[4], len2 = 0;
    for (int k = 0; k < 4; k++)
        v[k] = st->rot[4 * i + k] + D * st->omega[4 * i + k], len2 += v[k] * v[k];
    double div = fmax(sqrt(len2), GAUSSIAN_STG_NORMALIZE_EPS);
    for (int k = 0; k < 4; k++)
        q[k] = v[k] / div;
}

static double opacity_at(const gaussian_model *m, size_t i, double D)
{
    return m->opacity[i] * temporal_weight(D, gaussian_stg_of(m)->trbf_scale[i]);
}

static void stg_at(const gaussian_model *m, size_t i, double t, gaussian_dynamic_state *out)
{
    double D = offset_at(m, i, t);
    mean_at(m, i, D, out->mean);
    for (int k = 0; k < 3; k++) {
        out->scale[k] = m->scale[3 * i + k];
        out->rgb[k] = m->sh[3 * (size_t)m->sh_coeffs * i + (size_t)k];
    }
    rotation_at(m, i, D, out->q);
    out->opacity = opacity_at(m, i, D);
}

/* f_dc as stored, whatever the view and time: lite hands it to the
 * rasterizer as colors_precomp (renderer/__init__.py:339), and the blend
 * reads it without the SH step's +0.5 and clamp (forward.cu:316, 430). */
static vec3 stg_color(const gaussian_model *m, size_t i, double t, vec3 dir)
{
    (void)t, (void)dir;
    const float *sh = &m->sh[(size_t)3 * m->sh_coeffs * i];
    return v3(sh[0], sh[1], sh[2]);
}

/* ---- over [t0, t1] ---------------------------------------------------------- */

/* The largest opacity over [t0, t1]: the RBF peaks at D = 0, so over the
 * interval at trbf_center clamped into it. As computed: fl(t - c) is
 * monotone in t, so |D| is least there, and the rest is monotone but for
 * exp, within 1 ulp of exact in glibc: 4 eps covers it. */
static double opacity_max(const gaussian_model *m, size_t i, double t0, double t1)
{
    const gaussian_stg *st = gaussian_stg_of(m);
    double c = st->trbf_center[i], tc = fmin(fmax(c, t0), t1);
    return m->opacity[i] * temporal_weight(tc - c, st->trbf_scale[i]) * (1 + 4 * DBL_EPSILON);
}

/* Each axis' cubic path (gaussian_dynamic_cubic_bounds' proof). */
static int stg_bounds(const gaussian_model *m, size_t i, double t0, double t1, double lo[3], double hi[3],
                      double *opacity_bound)
{
    interval D = gaussian_dynamic_offset_interval(t0, t1, gaussian_stg_of(m)->trbf_center[i]), box[3];
    double c[4];
    for (int k = 0; k < 3; k++) {
        axis_coefficients(m, i, k, c);
        if (gaussian_dynamic_cubic_bounds(c, D, &box[k]))
            return -1;
    }
    gaussian_dynamic_store_box(box, lo, hi);
    *opacity_bound = opacity_max(m, i, t0, t1);
    return 0;
}

/* ---- rendering ---------------------------------------------------------------- */

static void stg_instant_cull(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j)
{
    double mean[3];
    mean_at(m, i, offset_at(m, i, t), mean);
    gaussian_dynamic_store_cull(m, i, mean, out, j);
}

static void stg_instant_rest(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j)
{
    double D = offset_at(m, i, t), q[4];
    rotation_at(m, i, D, q);
    for (int k = 0; k < 4; k++)
        out->rotation[4 * j + k] = (float)q[k];
    out->opacity[j] = (float)opacity_at(m, i, D);
}

static void stg_prefetch_cull(const gaussian_model *m, size_t i)
{
    const gaussian_stg *st = gaussian_stg_of(m);
    __builtin_prefetch(&st->trbf_center[i]);
    __builtin_prefetch(&st->motion[9 * i]);
    __builtin_prefetch(&st->motion[9 * i + 8]);
    __builtin_prefetch(&m->mean[3 * i]);
    __builtin_prefetch(&m->scale[3 * i]);
}

static void stg_prefetch_rest(const gaussian_model *m, size_t i)
{
    const gaussian_stg *st = gaussian_stg_of(m);
    __builtin_prefetch(&st->rot[4 * i]);
    __builtin_prefetch(&st->omega[4 * i]);
    __builtin_prefetch(&st->trbf_scale[i]);
    __builtin_prefetch(&m->opacity[i]);
}

/* The colour is the same from every direction: the instant's direction
 * is kept (no view_dir). */
const gaussian_dynamic_ops gaussian_stg_ops = {
    .name = "stg-lite",
    .free = gaussian_dynamic_free,
    .at = stg_at,
    .color = stg_color,
    .view_dir = NULL,
    .bounds = stg_bounds,
    .instant_cull = stg_instant_cull,
    .instant_rest = stg_instant_rest,
    .prefetch_cull = stg_prefetch_cull,
    .prefetch_rest = stg_prefetch_rest,
};
