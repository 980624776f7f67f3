/* Blending of epsilon-window hits and Phong shading (thesis sec. 4.5 step c:
 * blend the hits with their kernel weights, then shade the blended
 * attributes, like deferred splat shading). */
#ifndef RR_SHADE_H
#define RR_SHADE_H

#include "surfels/kbuffer.h"
#include "scene/scene.h"

/* The kernel-weighted sums of the surface attributes of the hits (or
 * splatted fragments) one pixel blends: the attribute pass of the thesis's
 * three-pass splatting (sec. 4.1.1) and the blend of sec. 4.5 step c are
 * the same sums, kept here once for the ray tracer and src/splatting/. */
typedef struct {
    double wsum;
    vec3 color, normal;
    double lit, diffuse, specular, shininess; /* lit: weight of phong materials */
} shade_sums;

void shade_sums_init(shade_sums *b);
void shade_sums_add(shade_sums *b, const material *m, const float color[3], const float normal[3], double w);
/* Normalisation and deferred Phong (sec. 4.1.1's last pass) at the point
 * org + closest * dir seen along the unit direction dir; wsum must be > 0. */
vec3 shade_sums_color(const scene *s, const shade_sums *sums, vec3 org, vec3 dir, double closest);

/* Color of a sample whose k-buffer is non-empty: weighted mean of colors,
 * normals and material parameters of the hits, then Phong (or the blended
 * color for unlit materials) at the closest hit point. */
vec3 shade_hits(const scene *s, const kbuffer *kb, vec3 org, vec3 dir);

#endif
