/* Real-time 4DGS models (Yang et al., ICLR 2024; fudan-zvg/4d-gaussian-
 * splatting at 63725f21) read from the PLY scripts/convert_4dgs.py writes
 * (the io layer; the layout: its docstring and src/GAUSSIANS.md "4DGS
 * models (converted)"): one vertex element of x y z t_center vel_0..2
 * t_var opacity scale_0..2 rot_0..3 time_duration sh_degree sh_degree_t
 * sh4d_0.. (found by name, any order and scalar type, as ply.h reads).
 * What the values mean at a time t: gaussian_dynamic.h. */
#ifndef RR_GAUSSIAN_FDGS_PLY_H
#define RR_GAUSSIAN_FDGS_PLY_H

#include <stdint.h>

#include "gaussians/gaussian.h"

/* Whether a vertex property's name is one only the 4DGS layout has
 * (t_center, vel_<k>, t_var, time_duration, sh_degree, sh_degree_t,
 * sh4d_<k>): a file with any of them is read by gaussian_fdgs_load, which
 * refuses it unless it is a whole 4DGS model. */
int gaussian_fdgs_claims(const char *name);

/* Reads a 4DGS model into m (kind 3D, m->dynamic of kind FDGS, sh_degree
 * the spatial degree, sh holding sh4d as it runs) from len bytes at data,
 * or from the file name when data is NULL (its bytes folded into
 * *content_hash unless NULL). kind GAUSSIAN_2D is refused. Errors name the
 * file and the properties or the vertex and value: those missing from a
 * partial layout, properties of another layout beside them
 * (SpacetimeGaussians' or 3DGS's f_dc_* / f_rest_*), sh4d_* with gaps or
 * a count other than 3 (sh_degree + 1)^2 (sh_degree_t + 1), degrees that
 * are not integers (sh_degree 0 to 3, sh_degree_t 0 to 2 and 0 unless
 * sh_degree is 3: 4DGS's rasterizer reads the time harmonics only at
 * degree 3, at most two), time_duration, sh_degree or sh_degree_t
 * differing between vertices, time_duration or t_var not above 0, values
 * not finite or beyond float range, means beyond GAUSSIAN_MAX_ABS,
 * exp(scale) beyond GAUSSIAN_MAX_SCALE, a zero quaternion. On failure m is
 * left empty. */
int gaussian_fdgs_load(const char *name, const char *data, size_t len, gaussian_kind kind, gaussian_model *m,
                       uint64_t *content_hash, rr_error *err);

#endif
