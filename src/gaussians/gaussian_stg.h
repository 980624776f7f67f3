/* SpacetimeGaussians "lite" models (Li et al. 2024,
 * oppo-us-research/SpacetimeGaussians at 427abfc5): a dynamic kind
 * (gaussian_dynamic.h), each Gaussian a function of time t (the scene's
 * time: one model per 50-frame segment, its timestamps (frame - start) /
 * 50). With D = t - trbf_center (renderer/__init__.py:318; forward_lite
 * forward.cu:186):
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
 * The PLY reader is formats/gaussian_stg_ply.c. The model's static arrays
 * hold x (mean), exp(scale) (scale), sigmoid(opacity) (opacity),
 * normalize(rot) or 0 (rotation, the state at D = 0) and f_dc as
 * sh[0..2] (sh_degree 0; the row's colour reads them as RGB). */
#ifndef RR_GAUSSIAN_STG_H
#define RR_GAUSSIAN_STG_H

#include "gaussians/gaussian_dynamic.h"

/* torch.nn.functional.normalize's eps (the default, ourslite.py:40). */
#define GAUSSIAN_STG_NORMALIZE_EPS 1e-12

typedef struct {
    gaussian_dynamic base; /* first: m->dynamic points at it */
    float *trbf_center;    /* 1 per Gaussian: the time of its mean and its peak opacity */
    float *trbf_scale;     /* 1 per Gaussian, as stored: the temporal scale is exp(trbf_scale) */
    float *motion;         /* 9 per Gaussian: velocity, then the D^2 and D^3 coefficients (x y z each) */
    float *omega;          /* 4 per Gaussian: the quaternion's rate, (w x y z) as rot */
    float *rot;            /* 4 per Gaussian: rot_0..3 as stored (any length, zero allowed) */
} gaussian_stg;

extern const gaussian_dynamic_ops gaussian_stg_ops;

/* Storage for n Gaussians' motion (NULL when out of memory). */
gaussian_dynamic *gaussian_stg_alloc(size_t n);

/* m's motion (m->dynamic of this kind). */
static inline gaussian_stg *gaussian_stg_of(const gaussian_model *m)
{
    RR_DCHECK(m->dynamic && m->dynamic->ops == &gaussian_stg_ops);
    return (gaussian_stg *)m->dynamic;
}

#endif
