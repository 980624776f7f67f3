/* Gaussians that move: the seam every dynamic kind plugs into. A dynamic
 * model is a static gaussian_model (gaussian.h) whose arrays hold the
 * state at the kind's reference time, plus m->dynamic: the kind's own
 * struct, whose first member is a gaussian_dynamic pointing at the kind's
 * row of operations (gaussian_dynamic_ops). Nothing outside a kind's file
 * tells the kinds apart: the renderer, the BVH, the blend and
 * `refrender export` call through the row (the wrappers below).
 *
 * The kinds (one file each, with their rules and sources):
 *   gaussian_stg.h   SpacetimeGaussians "lite" (Li et al. 2024): cubic
 *                    mean, turning quaternion, temporal RBF opacity, RGB
 *   gaussian_fdgs.h  real-time 4DGS (Yang et al., ICLR 2024): 4D Gaussians
 *                    conditioned on t, linear mean, marginal opacity, 4D SH
 * Their PLY readers: formats/gaussian_dynamic_ply.h. A new kind is its
 * own file here defining a row, and a reader there with one line in the
 * reader table (tests/test_gaussian_dynamic_kinds.c builds a third kind
 * in the test alone and renders it through these calls).
 *
 * Shared below: the one-block allocation every kind uses, the D-interval of
 * a shutter, the proved bounds of a cubic and of a linear path over it,
 * and the reach box of a moving Gaussian (gaussian_dynamic_reach_bounds). */
#ifndef RR_GAUSSIAN_DYNAMIC_H
#define RR_GAUSSIAN_DYNAMIC_H

#include <stddef.h>

#include "core/common.h"
#include "core/interval.h"
#include "gaussians/gaussian.h"
#include "gaussians/gaussian_hit.h"

/* gaussian_dynamic_state, the row (gaussian_dynamic_ops) and the head of
 * every kind's struct (gaussian_dynamic) are the model's own (gaussian.h):
 * it frees its moving part through the row. */

/* One float array of a kind's struct: where its pointer is (offsetof), and
 * how many floats it holds per Gaussian. */
typedef struct {
    size_t member;
    size_t width;
} gaussian_dynamic_array;

/* A zeroed kind struct of `size` bytes (a gaussian_dynamic first) for n
 * Gaussians, of row ops, whose `count` arrays share one block laid out in
 * the order given, so the block's size is the widths' sum and cannot
 * disagree with the layout; NULL, with nothing left allocated, when an
 * allocation fails or the size overflows. */
gaussian_dynamic *gaussian_dynamic_alloc(size_t n, size_t size, const gaussian_dynamic_ops *ops,
                                         const gaussian_dynamic_array *arrays, int count);
void gaussian_dynamic_free(gaussian_dynamic *d);

/* ---- calls through the model's row -------------------------------------- */

static inline void gaussian_dynamic_at(const gaussian_model *m, size_t i, double t, gaussian_dynamic_state *out)
{
    m->dynamic->ops->at(m, i, t, out);
}

static inline vec3 gaussian_dynamic_color(const gaussian_model *m, size_t i, double t, vec3 dir)
{
    return m->dynamic->ops->color(m, i, t, dir);
}

/* Sets dir to the row's view direction; keeps it (the instant's) when the
 * row has none. */
static inline void gaussian_dynamic_view_dir(const gaussian_model *m, size_t i, vec3 eye, float dir[3])
{
    if (m->dynamic->ops->view_dir)
        m->dynamic->ops->view_dir(m, i, eye, dir);
}

static inline int gaussian_dynamic_bounds(const gaussian_model *m, size_t i, double t0, double t1, double lo[3],
                                          double hi[3], double *opacity_max)
{
    RR_DCHECK(m->dynamic && i < m->count && t0 <= t1);
    return m->dynamic->ops->bounds(m, i, t0, t1, lo, hi, opacity_max);
}

/* The name `refrender export` writes as the model's motion ("none" for a
 * static model). */
static inline const char *gaussian_dynamic_name(const gaussian_model *m)
{
    return m->dynamic ? m->dynamic->ops->name : "none";
}

/* ---- rendering: a moving Gaussian as the static one of its instant ----
 *
 * The kernels (gaussian_hit.h) draw static Gaussians. A ray at time t
 * draws Gaussian i of a dynamic model as the static Gaussian of its state
 * at t, written into slot j of a scratch model `out` of m's kind and
 * formation (its mean, scale, rotation and opacity arrays have room for
 * slot j; its sh is not read). The renderer maps the scratch's hits back
 * to i, so the compositing order and the colour are those of Gaussian i
 * itself. In two parts, as the kernels read them: _cull the mean and scale
 * (all a cull reads, gaussian_hit.h), _rest the rotation and opacity (for
 * the candidates the cull keeps). */
static inline void gaussian_dynamic_instant_cull(const gaussian_model *m, size_t i, double t, gaussian_model *out,
                                                 size_t j)
{
    m->dynamic->ops->instant_cull(m, i, t, out, j);
}

static inline void gaussian_dynamic_instant_rest(const gaussian_model *m, size_t i, double t, gaussian_model *out,
                                                 size_t j)
{
    m->dynamic->ops->instant_rest(m, i, t, out, j);
}

static inline void gaussian_dynamic_prefetch_cull(const gaussian_model *m, size_t i)
{
    m->dynamic->ops->prefetch_cull(m, i);
}

static inline void gaussian_dynamic_prefetch_rest(const gaussian_model *m, size_t i)
{
    m->dynamic->ops->prefetch_rest(m, i);
}

/* ---- shared by the kinds' instants and bounds ------------------------------ */

/* The cull part of an instant (the row's instant_cull) of a kind whose
 * scale is constant: the mean at the instant, in floats as the kind's
 * rasterizer holds it, and the scale as loaded. */
static inline void gaussian_dynamic_store_cull(const gaussian_model *m, size_t i, const double mean[3],
                                               gaussian_model *out, size_t j)
{
    for (int k = 0; k < 3; k++)
        out->mean[3 * j + k] = (float)mean[k], out->scale[3 * j + k] = m->scale[3 * i + k];
}

/* The D-interval of [t0, t1] about the temporal centre c: [fl(t0 - c),
 * fl(t1 - c)] one step outward holds the computed and the exact t - c of
 * every t in [t0, t1] (rounding is monotone, and off by at most half a
 * step). */
static inline interval gaussian_dynamic_offset_interval(double t0, double t1, double c)
{
    return interval_step_out(interval_make(t0 - c, t1 - c));
}

/* One coordinate of a cubic path, c = (x, m1, m2, m3), in
 * SpacetimeGaussians' order (forward.cu:196-198): x + D m1 + D^2 m2 +
 * D^3 m3, D^2 = D D and D^3 = D^2 D. gaussian_dynamic_cubic_bounds proves
 * its bound for this evaluation. */
static inline double gaussian_dynamic_cubic_at(const double c[4], double D)
{
    double D2 = D * D, D3 = D2 * D;
    return c[0] + D * c[1] + D2 * c[2] + D3 * c[3];
}

/* Over the D-interval D, the exact cubic path of c and what
 * gaussian_dynamic_cubic_at computes stay in *out; -1 if it is not finite
 * (the proof: gaussian_dynamic.c). */
int gaussian_dynamic_cubic_bounds(const double c[4], interval D, interval *out);

/* The same for the linear path x + vel D, computed as x + vel * D. */
int gaussian_dynamic_linear_bounds(double x, double vel, interval D, interval *out);

/* Writes the three axes' intervals to lo, hi. */
static inline void gaussian_dynamic_store_box(const interval box[3], double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = box[k].lo, hi[k] = box[k].hi;
}

/* Object-space bounds of every point through which Gaussian i can give a
 * ray alpha >= 1/255 at any time whose state the row's instant_cull/_rest
 * draws with its mean in [lo, hi] and its opacity at most opacity_max
 * (the row's bounds over the times), its scales m->scale's and its
 * quaternion of length at most 1: the box of gaussian_view_bounds for
 * every such instant, under the view bound v (whose distance must hold the
 * camera's from every point of [lo, hi]). */
aabb gaussian_dynamic_reach_bounds(const gaussian_model *m, size_t i, const double lo[3], const double hi[3],
                                   double opacity_max, const gaussian_view_bound *v);

#endif
