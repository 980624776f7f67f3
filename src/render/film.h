/* Per-pixel accumulation of independent batch estimates.
 *
 * A pixel's value is the mean of B independent batch estimates X_1..X_B
 * (each batch is a full run of the sampler with its own random stream), so
 * the sample variance s^2 = sum (X_b - mean)^2 / (B - 1) is an unbiased
 * estimate of Var(X_b), and s^2 / B of the variance of the pixel value.
 *
 * Sums are kept exactly in fixed point: each batch estimate is rounded to a
 * multiple of 2^-24 (FILM_SCALE) and added as an integer (sum in 64 bits,
 * sum of squares in 128 bits). Integer sums do not depend on the order of
 * addition, so renders split into passes and merged, or checkpointed and
 * resumed, give bit-identical images. Estimates beyond +-2^20 are clamped
 * (and counted) to keep the sums exact. */
#ifndef RR_FILM_H
#define RR_FILM_H

#include <stdint.h>

#include "render/counters.h"

#define FILM_SCALE 16777216.0 /* 2^24 */
#define FILM_LIMIT 1048576.0  /* 2^20 */
/* Most batches a pixel may hold: each adds at most 2^44 (FILM_LIMIT *
 * FILM_SCALE) to a 64-bit sum, so 2^19 batches can never overflow it. */
#define FILM_MAX_BATCHES 524288u

typedef struct {
    uint32_t batches;
    int64_t sum[4];     /* RGBA */
    __int128 sumsq[4];
} pixel_state;

/* Adds one batch estimate; returns 1 if a value had to be clamped. */
int film_add_batch(pixel_state *p, const double estimate[4]);

/* 0 if the state can come from adding `batches` clamped estimates
 * (batches <= FILM_MAX_BATCHES, |sum| <= batches 2^44, 0 <= sum of squares <=
 * batches 2^88, and sum^2 <= batches * sum of squares by Cauchy-Schwarz);
 * -1 otherwise. A state read from a file is checked before it is used: sums
 * that no render can make would overflow film_merge and film_resolve. */
int film_check(const pixel_state *p);

/* Adds the sums of another partial state of the same pixel. The two may
 * hold at most FILM_MAX_BATCHES batches together (then nothing overflows). */
void film_merge(pixel_state *into, const pixel_state *from);

/* Mean, variance of the mean (s^2 / B; NaN for B < 2) per channel. */
void film_resolve(const pixel_state *p, double mean[4], double var_of_mean[4]);

/* Largest standard error of the pixel's RGB mean (INFINITY for B < 2). */
double film_max_stderr(const pixel_state *p);

/* An image of pixel states, with the render's counters. */
typedef struct {
    int width, height;
    pixel_state *px;        /* width * height; may hold batches from a checkpoint */
    uint64_t rays, kbuffer_overflows, clamped;
    uint64_t static_traversals; /* traversals of the static objects: one per raster position when
                                   a fixed camera's samples share them (static reuse), one per
                                   sample otherwise; statistics, not written to any file */
    double seconds;
    counter_set counters; /* the integrator's own counters, summed over the render (counters.h) */
} image;

int image_alloc(image *img, int width, int height);
void image_free(image *img);

/* Final values per pixel: mean RGBA, variance of the mean and standard
 * error (NaN with fewer than 2 batches), and the number of samples. */
void image_resolve(const image *img, int samples_per_batch, float *rgba, float *variance,
                   float *stderr_rgba, float *samples);

/* An image resolved into its four planes (image_resolve): rgba, var and se
 * hold 4 floats a pixel, samples 1. Every writer of a final image or
 * preview takes them from here. */
typedef struct {
    float *rgba, *var, *se, *samples;
} image_planes;

/* Allocates p's planes and resolves img into them; -1, with nothing left
 * allocated, when memory runs out. */
int image_planes_resolve(const image *img, int samples_per_batch, image_planes *p);
void image_planes_free(image_planes *p);

#endif
