/* Real-time 4DGS models (Yang et al., ICLR 2024; fudan-zvg/4d-gaussian-splatting
 * at 63725f21): a dynamic kind (gaussian_dynamic.h), each 4D Gaussian
 * conditioned on t as its rasterizer does it (forward.cu:279-352),
 * converted by scripts/convert_4dgs.py (its PLY reader:
 * formats/gaussian_fdgs_ply.c). With D = t - t_center:
 *   mean     x + vel D, vel = Sigma_xt / Sigma_tt (forward.cu:347-350)
 *   rotation, scale  the conditional covariance, the same at every t
 *            (forward.cu:337-339): rot normalised on load as 3DGS's are
 *   opacity  sigmoid(opacity) marginal, marginal = exp(-0.5 D^2 / t_var),
 *            and 0 (not drawn) unless marginal > 0.05 (forward.cu:333-336)
 *   colour   4D SH (gaussian_sh4d_color) seen from the camera toward the
 *            CANONICAL mean x, not the moved one (forward.cu:79-81,
 *            480-482: orig_points), at dir_t = t_center - t (:83)
 * The model's static arrays hold x, exp(scale), normalize(rot),
 * sigmoid(opacity) and sh4d as sh (sh_degree the spatial degree, sh_coeffs
 * (sh_degree + 1)^2 (sh_degree_t + 1)). */
#ifndef RR_GAUSSIAN_FDGS_H
#define RR_GAUSSIAN_FDGS_H

#include "gaussians/gaussian_dynamic.h"

/* 4DGS draws a Gaussian only where its marginal is above this
 * (forward.cu:334: mask = marginal_t > 0.05). */
#define GAUSSIAN_FDGS_MARGINAL_CUT 0.05

typedef struct {
    gaussian_dynamic base; /* first: m->dynamic points at it */
    float *t_center;       /* 1 per Gaussian: the time of its canonical mean and its peak opacity */
    float *velocity;       /* 3 per Gaussian: vel_0..2, the mean's (constant) rate */
    float *t_var;          /* 1 per Gaussian: the temporal marginal's variance (> 0) */
    double time_duration;  /* T of the time harmonics (> 0) */
    int sh_degree_t;       /* time harmonics k = 1..sh_degree_t (0 to 2; 0 unless sh_degree is 3) */
} gaussian_fdgs;

extern const gaussian_dynamic_ops gaussian_fdgs_ops;

/* Storage for n Gaussians' motion (NULL when out of memory); time_duration
 * and sh_degree_t are left for the reader. */
gaussian_dynamic *gaussian_fdgs_alloc(size_t n);

/* m's motion (m->dynamic of this kind). */
static inline gaussian_fdgs *gaussian_fdgs_of(const gaussian_model *m)
{
    RR_DCHECK(m->dynamic && m->dynamic->ops == &gaussian_fdgs_ops);
    return (gaussian_fdgs *)m->dynamic;
}

#endif
