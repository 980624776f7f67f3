/* The tile loop and threads: ties sampler, accel, shading and the a(t)
 * weighted accumulation of thesis sec. 4.5 together, batch by batch. */
#ifndef RR_RENDER_H
#define RR_RENDER_H

#include <signal.h>
#include <stdint.h>

#include "accel/accel.h"
#include "render/film.h"
#include "render/sampler.h"
#include "motion/shutter.h"

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
/* Exact time integration with the blur space: refused (-1, err naming
 * --blur-space) for linear and clamped, whose change of each instant's
 * colour must come before the time average, while exact time integrates
 * colours over time first. One rule for the command line and render_image. */
int render_check_exact_blur(int exact_time, blur_space b, rr_error *err);

typedef struct {
    sampler smp;            /* kind, seed, counts */
    shutter shut;           /* the interval sampled and the weight a(t) */
    int threads;
    uint32_t batch_begin;   /* index of this render's first batch (passes) */
    uint32_t batches;       /* batches every pixel gets */
    uint32_t max_batches;   /* with target_error: cap per pixel (>= batches) */
    double target_error;    /* > 0: pixels whose RGB standard error is above it get more batches */
    int exact_time;         /* 1: each spatial sample integrated over the shutter exactly (exact.h);
                               the sampler's times are not used */
    int crop_x0, crop_y0, crop_x1, crop_y1; /* crop_x1 > 0: only pixels x0 <= x < x1, y0 <= y < y1 */
    pixel_filter filter;
    blur_space blur;
} render_settings;

/* One batch of one sample per pixel (the thesis sampler, seed 1, one spatial
 * stratum, one time, time factor 1) on one thread, over the default shutter
 * (shutter_default), every pixel, box filter, the model's colours, no
 * target error. Callers override what they need by field name, so that a
 * field added or moved in render_settings cannot shift their values. */
render_settings render_settings_default(void);

typedef struct {
    /* about 5 times a second, and once at the end with fraction 1 */
    void (*progress)(void *user, double fraction, uint64_t rays, double seconds);
    /* writes a checkpoint of a consistent state (workers are paused) */
    int (*checkpoint)(void *user, const image *img, rr_error *err);
    /* a periodic checkpoint failed (disk full...): the render goes on and the
     * previous checkpoint stays; only the one written when interrupted is
     * an error */
    void (*checkpoint_failed)(void *user, const rr_error *err);
    double checkpoint_every; /* seconds; 0: only when interrupted */
    void *user;
} render_hooks;

/* The pixel batches the pixels of img (of the crop window) are expected to
 * hold when a render with rs ends: each at least the first B, and with a
 * target error as many as its standard error says it needs (a standard
 * error falls as 1/sqrt(batches): b (se / target)^2, at least one more
 * while it wants another, at most the cap). Planned anew each round, it
 * is what the progress line's fraction and ETA measure against, so they
 * cover the adaptive rounds too (they said 99.9%, ETA 0 s, through them).
 * No pixel's batches depend on it. */
uint64_t render_planned_pixel_batches(const render_settings *rs, const image *img);

/* Renders into img (pixels continue from the batches they already have).
 * The result depends only on the scene, the settings and the seed, not on
 * the thread count. Returns -1 if *cancel became non-zero (after a final
 * checkpoint, if there is a hook) or on error (a batch that failed: an
 * exact sample past its bounds, a sample's Gaussians out of memory). The
 * workers read *cancel between pixels and within batches (the batch under
 * way is left out), and step out between pixels for a periodic checkpoint:
 * neither waits for the rest of a tile. */
int render_image(const scene *s, const accel *a, const render_settings *rs, image *img,
                 const render_hooks *hooks, volatile sig_atomic_t *cancel, rr_error *err);

#endif
