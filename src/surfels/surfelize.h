/* Surfels from scanned data: triangle meshes and point clouds with normals
 * become circular splats that overlap without holes.
 *
 * Mesh: one splat per vertex, with the mesh's vertex normal and the radius
 * of the disk whose area is the vertex's share of its one-ring (a third of
 * each adjacent triangle), times `overlap`.
 * Point cloud: the area per point is estimated from its 6 nearest
 * neighbours (pi d6^2 / 7, d6 the distance to the 6th), and the radius is
 * that of the equal-area disk times `overlap`.
 * On a regular grid both give about 0.56 `overlap` times the spacing. */
#ifndef RR_SURFELIZE_H
#define RR_SURFELIZE_H

#include "surfels/surfel.h"

/* pos, nrm: 3 per vertex; tri: 3 vertex indices per triangle. Vertices in
 * no triangle are dropped. */
int surfels_from_mesh(const double *pos, const double *nrm, size_t nv, const unsigned *tri, size_t nt,
                      double overlap, surfel **out, size_t *n, rr_error *err);

int surfels_from_points(const double *pos, const double *nrm, size_t np, double overlap, surfel **out,
                        size_t *n, rr_error *err);

/* A 3D checkerboard of cubes of side `cell` in two colors (cell <= 0: c1
 * only), so that the motion blur of texture shows. */
void surfels_color(surfel *s, size_t n, vec3 c1, vec3 c2, double cell);

#endif
