/* The tile loop and threads: draws each pixel's batch of samples (the
 * sampler's positions, times from a(t)), hands it to the integrator
 * (integrator.h), which traces and shades, and adds the estimate to the
 * pixel's film state, batch by batch (thesis sec. 4.5). */
#ifndef RR_RENDER_H
#define RR_RENDER_H

#include <signal.h>
#include <stdint.h>

#include "accel/accel.h"
#include "render/film.h"
#include "render/render_settings.h"

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

/* Renders the scene accel traces (accel_scene: its shutter is the one the
 * swept bounds were built for, so no other can be asked for) into img, an
 * image of its camera's size (pixels continue from the batches they
 * already have). The result depends only on the scene, the settings and
 * the seed, not on the thread count. Returns -1 if *cancel became non-zero (after a final
 * checkpoint, if there is a hook) or on error (a batch that failed, in the
 * words of its integrator's batch_failure: an exact sample past its
 * bounds, a sample's Gaussians out of memory). The workers read *cancel
 * between pixels and within batches (the batch under way is left out),
 * and step out between pixels for a periodic checkpoint:
 * neither waits for the rest of a tile. */
int render_image(const accel *a, const render_settings *rs, image *img, const render_hooks *hooks,
                 volatile sig_atomic_t *cancel, rr_error *err);

#endif
