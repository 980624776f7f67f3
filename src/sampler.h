/* The thesis sampler (sec. 4.5). Every number is a pure function of
 * (seed, pixel, sample index, dimension) through a counter-based hash, so
 * the image does not depend on the thread count or the tile order.
 *
 * Spatial: s_s = k*k positions on a jittered k x k grid over the pixel
 *   (the requested --spp is rounded to the nearest square, at least 1).
 * Temporal: a finer 1D jittered grid of M = s_t * time_factor strata over
 *   [t0, t1], jittered once per pixel; each spatial sample takes a random
 *   subset of s_t distinct strata (partial Fisher-Yates). Every stratum is
 *   equally likely to be chosen and its jitter is uniform, so each time is
 *   uniform on [t0, t1]: the estimator of eq. 3.1 is unbiased. */
#ifndef RR_SAMPLER_H
#define RR_SAMPLER_H

#include <stdint.h>

typedef struct {
    uint64_t seed;
    int grid;        /* k: spatial samples per pixel = k*k */
    int tspp;        /* s_t: temporal samples per spatial sample */
    int time_factor; /* fine time grid has tspp * time_factor strata */
    double t0, t1;
} sampler;

/* Largest accepted values (keep per-pixel scratch small and counts sane). */
#define SAMPLER_MAX_GRID 64
#define SAMPLER_MAX_TIME_STRATA (1 << 20)

/* k = max(1, round(sqrt(spp))). */
int sampler_grid_for_spp(int spp);

/* Uniform double in [0, 1) from (seed, a, b, dim). */
double sampler_uniform(uint64_t seed, uint64_t a, uint64_t b, uint32_t dim);

/* Position of spatial sample i of pixel (px, py) in raster space. */
void sampler_position(const sampler *s, uint64_t pixel, int px, int py, int i,
                      double *x, double *y);

/* Per pixel: the jitter of each fine time stratum (M values). */
void sampler_time_jitter(const sampler *s, uint64_t pixel, double *jitter);

/* The s_t times of spatial sample i, using the pixel's jitter; perm is
 * scratch of M ints. */
void sampler_times(const sampler *s, uint64_t pixel, int i, const double *jitter,
                   int *perm, double *times);

#endif
