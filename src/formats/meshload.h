/* Scanned inputs for 'refrender surfels': triangle meshes read with Assimp
 * (OBJ, OFF, PLY, ...; every mesh of the file concatenated, triangulated,
 * identical vertices joined, smooth normals generated where missing) and
 * point clouds with normals as text (.xyz, .pts: x y z nx ny nz per line,
 * '#' starts a comment). Arrays are malloc'ed, 3 doubles per vertex. */
#ifndef RR_MESHLOAD_H
#define RR_MESHLOAD_H

#include <stddef.h>

#include "core/common.h"

int meshload_mesh(const char *path, double **pos, double **nrm, size_t *nv, unsigned **tri, size_t *nt,
                  rr_error *err);

/* A line that is not six finite numbers is an error naming file and line. */
int meshload_points(const char *path, double **pos, double **nrm, size_t *np, rr_error *err);

/* Whether the name says point cloud (.xyz or .pts, any case). */
int meshload_is_point_cloud(const char *path);

#endif
