/* Real-time 4DGS's rules (gaussian_fdgs.h): its row of
 * gaussian_dynamic_ops. */
#include "gaussians/gaussian_fdgs.h"

#include <float.h>
#include <math.h>
#include <stddef.h>

/* The arrays share one block: per Gaussian 1 + 3 + 1 floats. */
gaussian_dynamic *gaussian_fdgs_alloc(size_t n)
{
    static const gaussian_dynamic_array arrays[] = {
        {offsetof(gaussian_fdgs, t_center), 1}, {offsetof(gaussian_fdgs, velocity), 3},
        {offsetof(gaussian_fdgs, t_var), 1}};
    return gaussian_dynamic_alloc(n, sizeof(gaussian_fdgs), &gaussian_fdgs_ops, arrays,
                                  (int)(sizeof arrays / sizeof *arrays));
}

/* ---- at t ------------------------------------------------------------------ */

/* The temporal marginal exp(-0.5 D^2 / t_var) (forward.cu:333, t_var
 * holding cov_t plus any prefilter_var: the converter's). */
static double marginal(double D, float t_var) { return exp(-0.5 * D * D / t_var); }

/* sigmoid(opacity) marginal where the marginal is above the cut, else 0:
 * the CUDA drops the Gaussian (forward.cu:334-336). */
static double opacity_at(const gaussian_model *m, size_t i, double D)
{
    double g = marginal(D, gaussian_fdgs_of(m)->t_var[i]);
    return g > GAUSSIAN_FDGS_MARGINAL_CUT ? m->opacity[i] * g : 0.0;
}

/* The mean x + vel D (forward.cu:347-350; dt = timestamp - t, :283), as
 * gaussian_dynamic_linear_bounds bounds it. */
static void mean_at(const gaussian_model *m, size_t i, double D, double mean[3])
{
    const float *vel = &gaussian_fdgs_of(m)->velocity[3 * i];
    for (int k = 0; k < 3; k++)
        mean[k] = m->mean[3 * i + k] + vel[k] * D;
}

static double offset_at(const gaussian_model *m, size_t i, double t) { return t - gaussian_fdgs_of(m)->t_center[i]; }

/* The mean, and the constant conditional covariance's scale and unit
 * quaternion. */
static void fdgs_at(const gaussian_model *m, size_t i, double t, gaussian_dynamic_state *out)
{
    double D = offset_at(m, i, t);
    mean_at(m, i, D, out->mean);
    for (int k = 0; k < 3; k++)
        out->scale[k] = m->scale[3 * i + k], out->rgb[k] = 0.0;
    for (int k = 0; k < 4; k++)
        out->q[k] = m->rotation[4 * i + k];
    out->opacity = opacity_at(m, i, D);
}

/* Its 4D SH, time argument t_center - t (forward.cu:83), seen along dir
 * (fdgs_view_dir's). */
static vec3 fdgs_color(const gaussian_model *m, size_t i, double t, vec3 dir)
{
    const gaussian_fdgs *f = gaussian_fdgs_of(m);
    RR_DCHECK(i < m->count);
    return gaussian_sh4d_color(&m->sh[(size_t)3 * m->sh_coeffs * i], m->sh_degree, f->sh_degree_t,
                               f->t_center[i] - t, f->time_duration, dir);
}

/* From the camera centre eye to the CANONICAL mean x, not the moved one
 * (forward.cu:79-81, 480-482 pass orig_points). */
static void fdgs_view_dir(const gaussian_model *m, size_t i, vec3 eye, float dir[3])
{
    const float *mu = &m->mean[3 * i];
    dir[0] = (float)(mu[0] - eye.x), dir[1] = (float)(mu[1] - eye.y), dir[2] = (float)(mu[2] - eye.z);
}

/* ---- over [t0, t1] ---------------------------------------------------------- */

/* The largest opacity over [t0, t1]: the marginal peaks at D = 0, so at
 * t_center clamped into the interval (fl(t - c) monotone in t, the rest
 * monotone but for exp, within 1 ulp in glibc: 4 eps covers it). 0 when
 * even that is at or below the cut: no instant of the interval draws the
 * Gaussian (opacity_at). */
static double opacity_max(const gaussian_model *m, size_t i, double t0, double t1)
{
    const gaussian_fdgs *f = gaussian_fdgs_of(m);
    double c = f->t_center[i], tc = fmin(fmax(c, t0), t1);
    double g = marginal(tc - c, f->t_var[i]) * (1 + 4 * DBL_EPSILON);
    return g > GAUSSIAN_FDGS_MARGINAL_CUT ? m->opacity[i] * g : 0.0;
}

static int fdgs_bounds(const gaussian_model *m, size_t i, double t0, double t1, double lo[3], double hi[3],
                       double *opacity_bound)
{
    const gaussian_fdgs *f = gaussian_fdgs_of(m);
    interval D = gaussian_dynamic_offset_interval(t0, t1, f->t_center[i]), box[3];
    for (int k = 0; k < 3; k++)
        if (gaussian_dynamic_linear_bounds(m->mean[3 * i + k], f->velocity[3 * i + k], D, &box[k]))
            return -1;
    gaussian_dynamic_store_box(box, lo, hi);
    *opacity_bound = opacity_max(m, i, t0, t1);
    return 0;
}

/* ---- rendering ---------------------------------------------------------------- */

static void fdgs_instant_cull(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j)
{
    double mean[3];
    mean_at(m, i, offset_at(m, i, t), mean);
    gaussian_dynamic_store_cull(m, i, mean, out, j);
}

/* The quaternion as loaded (constant), the opacity with its cut. */
static void fdgs_instant_rest(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j)
{
    for (int k = 0; k < 4; k++)
        out->rotation[4 * j + k] = m->rotation[4 * i + k];
    out->opacity[j] = (float)opacity_at(m, i, offset_at(m, i, t));
}

static void fdgs_prefetch_cull(const gaussian_model *m, size_t i)
{
    const gaussian_fdgs *f = gaussian_fdgs_of(m);
    __builtin_prefetch(&f->t_center[i]);
    __builtin_prefetch(&f->velocity[3 * i]);
    __builtin_prefetch(&m->mean[3 * i]);
    __builtin_prefetch(&m->scale[3 * i]);
}

static void fdgs_prefetch_rest(const gaussian_model *m, size_t i)
{
    __builtin_prefetch(&m->rotation[4 * i]);
    __builtin_prefetch(&gaussian_fdgs_of(m)->t_var[i]);
    __builtin_prefetch(&m->opacity[i]);
}

const gaussian_dynamic_ops gaussian_fdgs_ops = {
    .name = "4dgs",
    .free = gaussian_dynamic_free,
    .at = fdgs_at,
    .color = fdgs_color,
    .view_dir = fdgs_view_dir,
    .bounds = fdgs_bounds,
    .instant_cull = fdgs_instant_cull,
    .instant_rest = fdgs_instant_rest,
    .prefetch_cull = fdgs_prefetch_cull,
    .prefetch_rest = fdgs_prefetch_rest,
};
