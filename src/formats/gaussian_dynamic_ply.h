/* The dynamic models' PLY readers (the formats layer), one per layout, and
 * their table (gaussian_dynamic_ply.c): a file is read by the reader that
 * claims one of its vertex properties, and each reader refuses the
 * properties another one claims, so the table is the one place that says
 * which layout owns a property. What the values mean at a time t: the
 * kind's header (gaussians/gaussian_stg.h, gaussian_fdgs.h). Each layout's
 * vertex properties are found by name, any order and scalar type, as ply.h
 * reads.
 *
 * SpacetimeGaussians "lite" (gaussian_stg_ply.c):
 * oppo-us-research/SpacetimeGaussians at 427abfc5, scene/ourslite.py
 * save_ply (361-387) and construct_list_of_attributes (335-359): one
 * vertex element of float x y z trbf_center trbf_scale nx ny nz
 * motion_0..8 f_dc_0..2 opacity scale_0..2 rot_0..3 omega_0..3 (nx ny nz
 * ignored).
 *
 * Real-time 4DGS (gaussian_fdgs_ply.c; Yang et al., ICLR 2024;
 * fudan-zvg/4d-gaussian-splatting at 63725f21) as scripts/convert_4dgs.py
 * writes it (the layout: its docstring and src/GAUSSIANS.md "4DGS models
 * (converted)"): one vertex element of x y z t_center vel_0..2 t_var
 * opacity scale_0..2 rot_0..3 time_duration sh_degree sh_degree_t
 * sh4d_0.. */
#ifndef RR_GAUSSIAN_DYNAMIC_PLY_H
#define RR_GAUSSIAN_DYNAMIC_PLY_H

#include <stdint.h>

#include "core/inputfile.h"
#include "gaussians/gaussian.h"

typedef struct {
    const char *layout;     /* for messages: "SpacetimeGaussians" */
    const char *possessive; /* "SpacetimeGaussians'" */
    const char *own;        /* the properties that mark it, for messages: "trbf_*, motion_*, omega_*" */
    /* Whether a vertex property's name is one only this layout has: a file
     * with any of them is read by load, which refuses it unless it is a
     * whole model of the layout. */
    int (*claims)(const char *name);
    /* Reads a model into m (kind 3D, m->dynamic set) from len bytes at
     * data, or from the opened file src when it is not NULL (the file
     * gaussian_ply.c opened and looked at: read and hashed once).
     * kind GAUSSIAN_2D is refused. On failure m is left empty. */
    int (*load)(const char *name, const char *data, size_t len, input_file *src, gaussian_kind kind,
                gaussian_model *m, rr_error *err);
} gaussian_dynamic_ply_reader;

/* SpacetimeGaussians lite. claims: trbf_center, trbf_scale, motion_<k>,
 * omega_<k>, f_t_<k>. load: SH degree 0 holding f_dc as RGB. Errors name
 * the file and the properties: those missing from a partial model,
 * f_rest_* (lite has none), STG's "full" variant (f_t_*, f_dc_3 and up: it
 * needs STG's per-pixel MLP), values that are not finite or beyond float
 * range, means beyond RR_MAX_REACH, exp(scale) beyond
 * RR_MAX_REACH, and a temporal scale exp(trbf_scale) below FLT_MIN
 * (the official float opacity is 0/0 at its centre). A zero rot is
 * accepted (STG adds Gaussians with rot 0: ourslite.py:1235). */
extern const gaussian_dynamic_ply_reader gaussian_stg_ply;

/* 4DGS. claims: t_center, vel_<k>, t_var, time_duration, sh_degree,
 * sh_degree_t, sh4d_<k>. load: m->dynamic of kind 4DGS (gaussian_fdgs.h), sh_degree the
 * spatial degree, sh holding sh4d as it runs. Errors name the file and the
 * properties or the vertex and value: those missing from a partial
 * layout, properties of another layout beside them (SpacetimeGaussians' or
 * 3DGS's f_dc_* / f_rest_*), sh4d_* with gaps or a count other than
 * 3 (sh_degree + 1)^2 (sh_degree_t + 1), degrees that are not integers
 * (sh_degree 0 to 3, sh_degree_t 0 to 2 and 0 unless sh_degree is 3:
 * 4DGS's rasterizer reads the time harmonics only at degree 3, at most
 * two), time_duration, sh_degree or sh_degree_t differing between
 * vertices, time_duration or t_var not above 0, values not finite or
 * beyond float range, means beyond RR_MAX_REACH, exp(scale) beyond
 * RR_MAX_REACH, a zero quaternion. */
extern const gaussian_dynamic_ply_reader gaussian_fdgs_ply;

/* Every reader above, NULL-terminated: a new layout is one line here and
 * one in gaussian_dynamic_ply.c. */
extern const gaussian_dynamic_ply_reader *const gaussian_dynamic_ply_readers[];

/* The reader that claims the vertex property name; NULL if none does. */
const gaussian_dynamic_ply_reader *gaussian_dynamic_ply_claimant(const char *name);

/* For reader self's header: refuses (-1, naming file, line and both
 * layouts) a property another reader claims: a file mixing two layouts is
 * no model any trainer wrote, so it is refused rather than half read. */
int gaussian_dynamic_ply_refuse_other(const gaussian_dynamic_ply_reader *self, const char *path, long line,
                                      const char *name, rr_error *err);

#endif
