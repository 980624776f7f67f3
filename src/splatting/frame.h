/* The splatting frame buffer and the passes of one instant (thesis sec.
 * 4.1.1): a visibility pass filling a depth buffer, an attribute pass
 * summing kernel-weighted attributes of the fragments within epsilon of it
 * (scene/shade.h's sums), and the normalisation and deferred Phong pass.
 * Time buckets (sec. 4.4) run the first two passes for several instants
 * into the same buffers before one normalisation. Internal to src/splatting/. */
#ifndef RR_SPLAT_FRAME_H
#define RR_SPLAT_FRAME_H

#include "scene/shade.h"
#include "splatting/splat_settings.h"

typedef struct {
    const scene *sc;
    splat_filter filter;
    int width, height;
    int camera_moves;
    vec3 *org, *dir;     /* per pixel: the ray through its centre at the current instant */
    double ray_time;     /* the instant org/dir hold */
    float *depth;        /* visibility pass: closest crossing along the ray (INFINITY: none) */
    double *depth_time;  /* the instant of that crossing (its ray is the one shaded) */
    float *attr_depth;   /* attribute pass: closest accepted fragment (a screen-filter-only pixel's) */
    double *attr_time;
    shade_sums *sums;
    uint64_t fragments;
} splat_frame;

int splat_frame_init(splat_frame *f, const scene *s, splat_filter filter);
void splat_frame_free(splat_frame *f);
/* Clears depth and sums (a new instant or bucket). */
void splat_frame_clear(splat_frame *f);
/* The passes at instant t (the scene's objects and camera placed at t). */
void splat_visibility_pass(splat_frame *f, double t);
void splat_attribute_pass(splat_frame *f, double t);
/* The rays through the pixel centres at instant t into org/dir. */
void splat_frame_set_rays(splat_frame *f, double t);
/* Raster position of world point p; 0 when p is not in front of the camera. */
int splat_project(const camera_view *v, vec3 p, double *x, double *y);
/* The pixels x0..x1, y0..y1 (box[0..3]) whose centres may see something
 * inside the world box with these corners (sec. 4.2.1: the projected
 * bounds, padded by a pixel against rounding; the whole image when the box
 * reaches behind the camera). */
void splat_footprint_of(const splat_frame *f, const camera_view *v, const vec3 corners[8], int box[4]);
/* Normalisation and deferred shading into rgba (4 per pixel), covered
 * pixels with alpha 1, the others the background with alpha 0. */
void splat_shade_pass(splat_frame *f, float *rgba);

#endif
