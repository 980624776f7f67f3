/* SpacetimeGaussians-lite models' PLY (gaussian_dynamic_ply.h): read
 * through the PLY reader's generic layer (ply.h). */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "formats/gaussian_dynamic_ply.h"
#include "formats/gaussian_ply_common.h"
#include "gaussians/gaussian_stg.h"

/* ---- the layout (ourslite.py:335-359) ---------------------------------- */

enum {
    S_X = 0, S_NX = 3, S_CENTER = 6, S_TSCALE = 7, S_MOTION = 8, S_DC = 17, S_OPACITY = 20, S_SCALE = 21,
    S_ROT = 24, S_OMEGA = 28, S_SLOTS = 32
};
static const char *const stg_names[S_SLOTS] = {
    "x", "y", "z", "nx", "ny", "nz", "trbf_center", "trbf_scale",
    "motion_0", "motion_1", "motion_2", "motion_3", "motion_4", "motion_5", "motion_6", "motion_7", "motion_8",
    "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
    "rot_0", "rot_1", "rot_2", "rot_3", "omega_0", "omega_1", "omega_2", "omega_3"};
static const ply_schema stg_schema = {stg_names, S_SLOTS, S_SLOTS /* no integer scaling */};

static int stg_claims(const char *name)
{
    return !strcmp(name, "trbf_center") || !strcmp(name, "trbf_scale") ||
           gaussian_ply_numbered(name, "motion_") >= 0 || gaussian_ply_numbered(name, "omega_") >= 0 ||
           gaussian_ply_numbered(name, "f_t_") >= 0;
}

/* The properties lite does not have: the full variant's (oursfull.py:
 * 361-362, 375-376: six f_dc and f_t_0..2, decoded by an MLP after
 * compositing, so not per Gaussian) and SH rest coefficients. */
static int see_property(void *user, const char *path, long line, const char *name, rr_error *err)
{
    (void)user;
    if (gaussian_dynamic_ply_refuse_other(&gaussian_stg_ply, path, line, name, err))
        return -1;
    if (gaussian_ply_numbered(name, "f_t_") >= 0 || gaussian_ply_numbered(name, "f_dc_") >= 3)
        return rr_fail(err, "%s:%ld: vertex property '%s': a SpacetimeGaussians \"full\" model (f_t_*, f_dc_3 and "
                            "up) needs STG's per-pixel MLP, not supported (the \"lite\" model is)", path, line, name);
    if (gaussian_ply_numbered(name, "f_rest_") >= 0)
        return rr_fail(err, "%s:%ld: vertex property '%s': a SpacetimeGaussians model has no f_rest_* (lite's "
                            "colour is f_dc_0..2 as RGB)", path, line, name);
    return 0;
}

/* Every property but nx ny nz is needed: a partial model is refused with
 * the whole list of what it lacks. */
static int begin_model(void *user, const char *path, const int *present, size_t count, rr_error *err)
{
    gaussian_ply_sink *s = user;
    char missing[600] = "";
    gaussian_ply_list_missing(missing, sizeof missing, present, stg_names, 0, S_NX);
    gaussian_ply_list_missing(missing, sizeof missing, present, stg_names, S_CENTER, S_SLOTS);
    if (*missing)
        return rr_fail(err, "%s: a SpacetimeGaussians model lacks the vertex properties%s (lite has x y z trbf_center "
                            "trbf_scale motion_0..8 f_dc_0..2 opacity scale_0..2 rot_0..3 omega_0..3)", path, missing);
    if (gaussian_ply_begin_3d(s, path, "SpacetimeGaussians", count, err))
        return -1;
    s->m->sh_degree = 0, s->m->sh_coeffs = 1;
    return 0;
}

static int store(float *dst, const double *v, int slot, char *why, size_t why_size)
{
    return gaussian_ply_store(dst, v[slot], stg_names[slot], why, why_size);
}

static int store_run(float *dst, const double *v, int first, int n, char *why, size_t why_size)
{
    for (int k = 0; k < n; k++)
        if (store(&dst[k], v, first + k, why, why_size))
            return -1;
    return 0;
}

/* The static arrays (gaussian_stg.h: the state at D = 0): means within
 * RR_MAX_REACH, exp(scale) within RR_MAX_REACH, sigmoid of the
 * opacity, f_dc as RGB, normalize(rot) as F.normalize (0 stays 0). */
static int store_static(gaussian_model *m, size_t i, const double *v, char *why, size_t why_size)
{
    double len2 = 0;
    if (gaussian_ply_store_mean_scale(m, i, v, stg_names, S_X, S_SCALE, 3, why, why_size))
        return -1;
    float *rot = &gaussian_stg_of(m)->rot[4 * i];
    if (store_run(&m->sh[3 * i], v, S_DC, 3, why, why_size) || store_run(rot, v, S_ROT, 4, why, why_size))
        return -1;
    for (int k = 0; k < 4; k++)
        len2 += (double)rot[k] * rot[k];
    for (int k = 0; k < 4; k++)
        m->rotation[4 * i + k] = (float)(rot[k] / fmax(sqrt(len2), GAUSSIAN_STG_NORMALIZE_EPS));
    m->opacity[i] = (float)(1.0 / (1.0 + exp(-v[S_OPACITY])));
    return 0;
}

/* The motion as stored; the temporal scale exp(trbf_scale) must be a
 * normal float, as the official code holds it (ourslite.py:835): below,
 * its opacity at D = 0 is 0/0. */
static int store_motion(gaussian_stg *d, size_t i, const double *v, char *why, size_t why_size)
{
    if (!(exp(v[S_TSCALE]) >= FLT_MIN))
        return gaussian_ply_bad(why, why_size, "property '%s' = %g: exp() of it, the temporal scale, is below "
                                "float's smallest normal 1.2e-38", stg_names[S_TSCALE], v[S_TSCALE]);
    return store(&d->trbf_center[i], v, S_CENTER, why, why_size) || store(&d->trbf_scale[i], v, S_TSCALE, why, why_size) ||
                   store_run(&d->motion[9 * i], v, S_MOTION, 9, why, why_size) ||
                   store_run(&d->omega[4 * i], v, S_OMEGA, 4, why, why_size)
               ? -1
               : 0;
}

static int add_gaussian(void *user, const double *v, const int *present, char *why, size_t why_size)
{
    gaussian_ply_sink *s = user;
    gaussian_model *m = s->m;
    if (!m->mean && gaussian_ply_allocate(m, s->declared, gaussian_stg_alloc, why, why_size))
        return -1;
    if (gaussian_ply_check_finite(v, present, stg_names, S_SLOTS, why, why_size))
        return -1;
    size_t i = s->next;
    if (store_motion(gaussian_stg_of(m), i, v, why, why_size) || store_static(m, i, v, why, why_size))
        return -1;
    m->count = ++s->next;
    return 0;
}

static int stg_load(const char *name, const char *data, size_t len, input_file *src, gaussian_kind kind,
                    gaussian_model *m, rr_error *err)
{
    gaussian_ply_sink sink = {m, kind, 0, 0};
    ply_visitor v = {begin_model, add_gaussian, &sink, see_property};
    return gaussian_ply_load_layout(name, data, len, src, &stg_schema, &v, m, err);
}

const gaussian_dynamic_ply_reader gaussian_stg_ply = {"SpacetimeGaussians", "SpacetimeGaussians'",
                                                      "trbf_*, motion_*, omega_*", stg_claims, stg_load};
