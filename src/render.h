/* The tile loop and threads: ties sampler, accel, shading and the a(t)
 * weighted accumulation of thesis sec. 4.5 together. */
#ifndef RR_RENDER_H
#define RR_RENDER_H

#include <signal.h>
#include <stdint.h>

#include "accel.h"

typedef struct {
    int spp_grid;    /* k: k*k spatial samples per pixel */
    int tspp;        /* temporal samples per spatial sample */
    int time_factor; /* fine time grid factor */
    uint64_t seed;
    int threads;
} render_settings;

typedef struct {
    int width, height;
    float *rgba;     /* interleaved, width*height*4 */
    uint64_t rays;   /* rays traced */
    uint64_t kbuffer_overflows;
    double seconds;
} image;

/* Called from the coordinating thread about 5 times a second and once at
 * the end with fraction 1. */
typedef void (*render_progress_fn)(void *user, double fraction, uint64_t rays, double seconds);

/* Renders the scene. Output depends only on the scene, settings and seed,
 * not on the thread count. Returns -1 if *cancel became non-zero. */
int render_image(const scene *s, const accel *a, const render_settings *rs, image *out,
                 render_progress_fn progress, void *user, volatile sig_atomic_t *cancel,
                 rr_error *err);

void image_free(image *img);

#endif
