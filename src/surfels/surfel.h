/* A circular surfel: the record the procedural shapes, the surfelizer and
 * the generator ('refrender gen') produce and the PLY writer stores (ply.h).
 * It belongs to the surfels layer, not to the reader: shapes, surfelize and
 * Gaussians from surfels use it without any file format. */
#ifndef RR_SURFEL_H
#define RR_SURFEL_H

#include "core/common.h"

typedef struct surfel_s {
    vec3 center, normal;
    double radius;
    vec3 color;
} surfel;

#endif
