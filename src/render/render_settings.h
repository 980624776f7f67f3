/* What a render is asked for: sampler and counts, batches and target
 * error, crop window, pixel filter, blur space and integrator
 * (render_image in render.h takes them; integrators read them). The
 * shutter is not among them: the scene rendered owns it (scene.h,
 * scene.shut), the one accel was built for. */
#ifndef RR_RENDER_SETTINGS_H
#define RR_RENDER_SETTINGS_H

#include <stdint.h>

#include "render/sampler.h"

struct integrator_ops; /* (integrator.h) */

/* Where a pixel's spatial samples lie: over its area (box, the default),
 * or all at its centre (point: the official Gaussian rasterizers evaluate
 * a pixel there, so the render is the limit of averaging N of their sharp
 * frames as N grows). */
typedef enum { PIXEL_FILTER_BOX, PIXEL_FILTER_POINT } pixel_filter;
/* What a pixel averages over time: the colours as the model gives them
 * (model), or those clamped to [0, 1] and decoded from sRGB first
 * (linear): the two conventions deblurring benchmarks use when they
 * average sharp frames; or those clamped to [0, 1] and nothing more
 * (clamped), as SpacetimeGaussians' test.py:131 clamps each rendered
 * instant before it is scored. */
typedef enum { BLUR_SPACE_MODEL, BLUR_SPACE_LINEAR, BLUR_SPACE_CLAMPED } blur_space;

const char *pixel_filter_name(pixel_filter f);
const char *blur_space_name(blur_space b);

typedef struct {
    sampler smp;            /* kind, seed, counts */
    int threads;
    uint32_t batch_begin;   /* index of this render's first batch (passes) */
    uint32_t batches;       /* batches every pixel gets */
    uint32_t max_batches;   /* with target_error: cap per pixel (>= batches) */
    double target_error;    /* > 0: pixels whose RGB standard error is above it get more batches */
    /* the integrator (integrator.h, one of its table's rows: integrator_named);
     * NULL: sampled time, by the scene's sampled integrator (integrator_for) */
    const struct integrator_ops *integrator;
    int crop_x0, crop_y0, crop_x1, crop_y1; /* crop_x1 > 0: only pixels x0 <= x < x1, y0 <= y < y1 */
    pixel_filter filter;
    blur_space blur;
} render_settings;

/* One batch of one sample per pixel (the thesis sampler, seed 1, one spatial
 * stratum, one time, time factor 1) on one thread, every pixel, box
 * filter, the model's colours, no target error. Callers override what they need by field name, so that a
 * field added or moved in render_settings cannot shift their values. */
render_settings render_settings_default(void);

#endif
