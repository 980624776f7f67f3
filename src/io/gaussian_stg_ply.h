/* SpacetimeGaussians "lite" models read from their PLY (the io layer):
 * oppo-us-research/SpacetimeGaussians at 427abfc5, scene/ourslite.py
 * save_ply (361-387) and construct_list_of_attributes (335-359): one
 * vertex element of float x y z trbf_center trbf_scale nx ny nz
 * motion_0..8 f_dc_0..2 opacity scale_0..2 rot_0..3 omega_0..3 (found by
 * name, any order and scalar type, as ply.h reads; nx ny nz ignored).
 * What the values mean at a time t: gaussian_dynamic.h. */
#ifndef RR_GAUSSIAN_STG_PLY_H
#define RR_GAUSSIAN_STG_PLY_H

#include <stdint.h>

#include "gaussians/gaussian.h"

/* Whether a vertex property's name is one only SpacetimeGaussians writes
 * (trbf_center, trbf_scale, motion_<k>, omega_<k>, f_t_<k>): a file with
 * any of them is read by gaussian_stg_load, which refuses it unless it is
 * a whole STG-lite model. */
int gaussian_stg_claims(const char *name);

/* Reads an STG-lite model into m (kind 3D, SH degree 0 holding f_dc as
 * RGB, m->dynamic set) from len bytes at data, or from the file name when
 * data is NULL (its bytes folded into *content_hash unless NULL). kind
 * GAUSSIAN_2D is refused. Errors name the file and the properties: those
 * missing from a partial model, f_rest_* (lite has none), STG's "full"
 * variant (f_t_*, f_dc_3 and up: it needs STG's per-pixel MLP), values
 * that are not finite or beyond float range, means beyond
 * GAUSSIAN_MAX_ABS, exp(scale) beyond GAUSSIAN_MAX_SCALE, and a temporal
 * scale exp(trbf_scale) below FLT_MIN (the official float opacity is 0/0
 * at its centre). A zero rot is accepted (STG adds Gaussians with rot 0:
 * ourslite.py:1235). On failure m is left empty. */
int gaussian_stg_load(const char *name, const char *data, size_t len, gaussian_kind kind, gaussian_model *m,
                      uint64_t *content_hash, rr_error *err);

#endif
