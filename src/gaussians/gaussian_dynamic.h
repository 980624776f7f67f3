/* Gaussians that move: SpacetimeGaussians "lite" models (Li et al. 2024,
 * oppo-us-research/SpacetimeGaussians at 427abfc5), each Gaussian a
 * function of time t (the scene's time: one model per 50-frame segment,
 * its timestamps (frame - start) / 50). With D = t - trbf_center
 * (renderer/__init__.py:318; forward_lite forward.cu:186):
 *   mean     x + motion[0:3] D + motion[3:6] D^2 + motion[6:9] D^3  (forward.cu:196-198)
 *   rotation normalize(rot + omega D), torch's F.normalize (divided by
 *            max(|q|, 1e-12): q = 0 stays 0) and nothing more: the CUDA
 *            builds its matrix from that q without normalising again
 *            (ourslite.py:40, 123-126; forward.cu:127-138)
 *   scale    exp(scale), constant (ourslite.py:120-121, 837)
 *   opacity  sigmoid(opacity) exp(-(D / exp(trbf_scale))^2): no 1/2, no
 *            temporal cut-off (forward.cu:202-204, ourslite.py:835-836;
 *            helper_train.py:390-391 is the same in training)
 *   colour   f_dc_0..2 as plain RGB, fed as precomputed colours: no SH, no
 *            +0.5, no clamp per Gaussian (ourslite.py:139-140,
 *            renderer/__init__.py:320 and 339; forward.cu:430)
 * Pure data and math (the gaussians layer): the PLY reader is
 * gaussian_stg_ply.c. A model carries this through gaussian_model.dynamic
 * (NULL for static models); its static arrays hold x (mean), exp(scale)
 * (scale), sigmoid(opacity) (opacity), normalize(rot) or 0 (rotation, the
 * state at D = 0) and f_dc as sh[0..2] (sh_degree 0, rgb_precomputed).
 *
 * A second kind: real-time 4DGS (Yang et al., ICLR 2024;
 * fudan-zvg/4d-gaussian-splatting at 63725f21), each 4D Gaussian
 * conditioned on t as its rasterizer does it (forward.cu:279-352),
 * converted by scripts/convert_4dgs.py (its PLY: gaussian_dynamic_ply.h).
 * With D = t - t_center:
 *   mean     x + vel D, vel = Sigma_xt / Sigma_tt (forward.cu:347-350)
 *   rotation, scale  the conditional covariance, the same at every t
 *            (forward.cu:337-339): rot normalised on load as 3DGS's are
 *   opacity  sigmoid(opacity) marginal, marginal = exp(-0.5 D^2 / t_var),
 *            and 0 (not drawn) unless marginal > 0.05 (forward.cu:333-336)
 *   colour   4D SH (gaussian_sh4d_color) seen from the camera toward the
 *            CANONICAL mean x, not the moved one (forward.cu:79-81,
 *            480-482: orig_points), at dir_t = t_center - t (:83)
 * Its static arrays hold x, exp(scale), normalize(rot), sigmoid(opacity)
 * and sh4d as sh (sh_degree the spatial degree, sh_coeffs
 * (sh_degree + 1)^2 (sh_degree_t + 1)). */
#ifndef RR_GAUSSIAN_DYNAMIC_H
#define RR_GAUSSIAN_DYNAMIC_H

#include "core/common.h"
#include "gaussians/gaussian.h"
#include "gaussians/gaussian_hit.h"

/* torch.nn.functional.normalize's eps (the default, ourslite.py:40). */
#define GAUSSIAN_DYNAMIC_NORMALIZE_EPS 1e-12

/* Which rules a dynamic model follows. */
typedef enum { GAUSSIAN_DYNAMIC_STG, GAUSSIAN_DYNAMIC_FDGS } gaussian_dynamic_kind;

typedef struct gaussian_dynamic {
    gaussian_dynamic_kind kind;
    /* SpacetimeGaussians-lite (kind STG) */
    float *trbf_center;   /* 1 per Gaussian: the time of its mean and its peak opacity (owns the block
                           * all five arrays share: gaussian_dynamic_alloc) */
    float *trbf_scale;    /* 1 per Gaussian, as stored: the temporal scale is exp(trbf_scale) */
    float *motion;        /* 9 per Gaussian: velocity, then the D^2 and D^3 coefficients (x y z each) */
    float *omega;         /* 4 per Gaussian: the quaternion's rate, (w x y z) as rot */
    float *rot;           /* 4 per Gaussian: rot_0..3 as stored (any length, zero allowed) */
    /* 4DGS (kind FDGS) */
    float *t_center;      /* 1 per Gaussian: the time of its canonical mean and its peak opacity (owns the
                           * block the three arrays share: gaussian_dynamic_alloc_fdgs) */
    float *velocity;      /* 3 per Gaussian: vel_0..2, the mean's (constant) rate */
    float *t_var;         /* 1 per Gaussian: the temporal marginal's variance (> 0) */
    double time_duration; /* T of the time harmonics (> 0) */
    int sh_degree_t;      /* time harmonics k = 1..sh_degree_t (0 to 2; 0 unless sh_degree is 3) */
} gaussian_dynamic;

/* 4DGS draws a Gaussian only where its marginal is above this
 * (forward.cu:334: mask = marginal_t > 0.05). */
#define GAUSSIAN_FDGS_MARGINAL_CUT 0.05

/* One Gaussian at one time, as the official renderer draws it. */
typedef struct {
    double mean[3];
    double q[4];       /* (w x y z): unit, or shorter than 1 when |rot + omega D| < 1e-12, or 0 */
    double scale[3];
    double opacity;
    double rgb[3];     /* STG only: a 4DGS colour depends on the view (gaussian_dynamic_color) */
} gaussian_dynamic_state;

/* Storage for n Gaussians' motion (NULL when out of memory): STG's, or
 * 4DGS's (_fdgs: time_duration and sh_degree_t left for the reader). */
gaussian_dynamic *gaussian_dynamic_alloc(size_t n);
gaussian_dynamic *gaussian_dynamic_alloc_fdgs(size_t n);
void gaussian_dynamic_free(gaussian_dynamic *d);

/* Gaussian i of m (m->dynamic not NULL) at time t. */
void gaussian_dynamic_at(const gaussian_model *m, size_t i, double t, gaussian_dynamic_state *out);

/* The colour of Gaussian i of a 4DGS model m at time t seen along dir
 * (gaussian_dynamic_view_dir's): its 4D SH, time argument t_center - t
 * (forward.cu:83). */
vec3 gaussian_dynamic_color(const gaussian_model *m, size_t i, double t, vec3 dir);
/* The view direction of that colour, from the camera centre eye (object
 * space) to the CANONICAL mean x, not the moved one (forward.cu:79-81,
 * 480-482 pass orig_points), as a hit holds it (gaussian_hit.dir). */
void gaussian_dynamic_view_dir(const gaussian_model *m, size_t i, vec3 eye, float dir[3]);

/* Over the times [t0, t1] (t0 <= t1) Gaussian i's mean stays in
 * [lo, hi] (per axis; both the exact cubic path and what
 * gaussian_dynamic_at computes), and its opacity is at most
 * *opacity_max. Returns -1 (nothing written) if the box is not finite. */
int gaussian_dynamic_bounds(const gaussian_model *m, size_t i, double t0, double t1, double lo[3], double hi[3],
                            double *opacity_max);

/* ---- rendering: a moving Gaussian as the static one of its instant ----
 *
 * The kernels (gaussian_hit.h) draw static Gaussians. A ray at time t
 * draws Gaussian i of a dynamic model as the static Gaussian of its state
 * at t, written into slot j of a scratch model `out` of m's kind and
 * formation (its mean, scale, rotation and opacity arrays have room for
 * slot j; its sh is not read): the mean, the scale, q as the CUDA takes it
 * and the opacity, in floats as the CUDA holds them. The renderer maps
 * the scratch's hits back to i, so the compositing order and the colour
 * are those of Gaussian i itself. In two parts, as the kernels read them:
 * _cull the mean and scale (all a cull reads, gaussian_hit.h), _rest the
 * rotation and opacity (for the candidates the cull keeps). */
void gaussian_dynamic_instant_cull(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j);
void gaussian_dynamic_instant_rest(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j);
/* Start loading what each part reads of Gaussian i (no value changes). */
void gaussian_dynamic_prefetch_cull(const gaussian_model *m, size_t i);
void gaussian_dynamic_prefetch_rest(const gaussian_model *m, size_t i);

/* Object-space bounds of every point through which Gaussian i can give a
 * ray alpha >= 1/255 at any time whose state gaussian_dynamic_instant_cull/_rest
 * draws with its mean in [lo, hi] and its opacity at most opacity_max
 * (gaussian_dynamic_bounds' box and bound over the times): the box of
 * gaussian_view_bounds for every such instant, under the view bound v
 * (whose distance must hold the camera's from every point of [lo, hi]). */
aabb gaussian_dynamic_reach_bounds(const gaussian_model *m, size_t i, const double lo[3], const double hi[3],
                                   double opacity_max, const gaussian_view_bound *v);

#endif
