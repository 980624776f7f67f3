/* Blending of epsilon-window hits and Phong shading (thesis sec. 4.5 step c:
 * blend the hits with their kernel weights, then shade the blended
 * attributes, like deferred splat shading). */
#ifndef RR_SHADE_H
#define RR_SHADE_H

#include "accel/kbuffer.h"
#include "scene/scene.h"

/* Color of a sample whose k-buffer is non-empty: weighted mean of colors,
 * normals and material parameters of the hits, then Phong (or the blended
 * color for unlit materials) at the closest hit point. */
vec3 shade_hits(const scene *s, const kbuffer *kb, vec3 org, vec3 dir);

#endif
