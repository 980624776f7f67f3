/* The thesis's splatting methods on the CPU, as comparands for the ground
 * truth (Wolf 2008, sections 3.6, 4.1-4.4; src/SPLAT.md). No Embree: each
 * splat's footprint is found by projecting its bounds, and each pixel of
 * it is tested with the ground truth's own rules (the ray/ellipse test of
 * surfels/splat.h, the kernel weight, kbuffer.h's epsilon rule, the camera,
 * a(t) and scene/shade.h's blend and Phong), so that one instant splatted
 * without the EWA approximation is the ray tracer's image at that instant. */
#ifndef RR_SPLATTING_H
#define RR_SPLATTING_H

#include <stdint.h>

#include "scene/scene.h"
#include "splatting/splat_settings.h"

typedef struct {
    int width, height;
    float *rgba;           /* 4 per pixel; RGB already holds the background where A < 1 */
    uint64_t fragments;    /* footprint pixels tested, summed over every pass */
} splat_result;

/* Renders s (point models only; -1 with err naming the scene and object
 * otherwise, or when out of memory). out->rgba is allocated here. */
int splat_render(const scene *s, const splat_settings *set, splat_result *out, rr_error *err);
void splat_result_free(splat_result *r);

#endif
