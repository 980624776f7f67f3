/* Samplers: where in the pixel and when in the shutter each sample goes,
 * and the sample's weight. Every number is a pure function of (seed, pixel,
 * batch, sample index, dimension) through counter-based hashing, so the
 * image does not depend on the thread count, the tile order, or on how
 * batches are split into passes.
 *
 * A batch is one complete set of n = K*K*tspp samples of a pixel; batches
 * of one pixel are statistically independent replicates (film.h), so their
 * spread is an honest error estimate.
 *
 * sobol (the default): the 3D Sobol' sequence (dimensions: van der Corput,
 *   x+1, x^2+x+1 with Joe-Kuo direction numbers) with hash-based Owen
 *   scrambling (Burley 2020, Laine-Karras permutation) seeded per pixel,
 *   dimension and batch: every batch is its own scramble of the first n
 *   points, so power-of-two n keeps it a scrambled (0, m, 2)-net in (x, y)
 *   (a (1, m, 3)-net with t), and it is traced in time order. Its times
 *   fall one in each 1/n of the shutter for any n (another n takes its
 *   times by their rank: sampler.c, rank_stratified_times).
 * jittered3d: one sample in each cell of a K x K x tspp grid over
 *   (x, y, t): position and time stratified jointly.
 * thesis (Wolf 2008, sec. 4.5): K x K jittered positions; for each, tspp
 *   times taken as a random subset of a finer jittered grid of
 *   tspp * time_factor strata over the shutter [t0, t1] (jittered once per
 *   pixel and batch, subset by partial Fisher-Yates). Each stratum is
 *   equally likely and its jitter uniform, so each time is uniform on
 *   [t0, t1]; the random subsets converge like plain Monte Carlo
 *   (src/bench/BENCH.md, Sampler convergence). Weights all 1: its images are
 *   the thesis's, unchanged.
 *
 * Where error bars are asked for (random_strata), sobol and jittered3d draw
 * each batch's time strata boundaries at random and weigh each sample by
 * its stratum's width (stratified_time in sampler.c): with the same equal
 * strata in every batch, a pixel that steps in time gets batch estimates on
 * a lattice and a standard error of 0 where it is off. A pixel's estimate
 * is sum w c / sum w (integrator.c, integrator_sampled_batch); the weights sum to n whenever each time
 * stratum holds one sample (jittered3d always, sobol for even n). */
#ifndef RR_SAMPLER_H
#define RR_SAMPLER_H

#include <stdint.h>

#include "core/common.h"

typedef enum { SAMPLER_THESIS, SAMPLER_JITTERED3D, SAMPLER_SOBOL } sampler_kind;

/* The default: the lowest error at equal samples on every measured view
 * (src/bench/BENCH.md, Sampler convergence); the thesis's own sampler
 * converges like plain Monte Carlo there. */
#define SAMPLER_DEFAULT SAMPLER_SOBOL

typedef struct {
    sampler_kind kind;
    uint64_t seed;
    int grid;        /* K: spatial strata per axis (thesis, jittered3d); n = K*K*tspp */
    int tspp;        /* temporal samples per spatial sample */
    int time_factor; /* thesis: fine time grid factor */
    int random_strata; /* sobol, jittered3d: each batch draws its own time strata boundaries, so the
                          batches' spread is an honest error (sampler.c); set where error bars are asked for */
} sampler;

/* Largest accepted values (keep per-pixel scratch small and counts sane). */
#define SAMPLER_MAX_TIME_STRATA (1 << 20)

/* k = max(1, round(sqrt(spp))). */
int sampler_grid_for_spp(int spp);

const char *sampler_name(sampler_kind k);
/* Returns -1 for an unknown name. */
int sampler_from_name(const char *name, sampler_kind *k);

/* Samples per batch, in 64 bits: K*K*tspp overflowed an int (spp 4096 and
 * tspp 10^6 gave a negative count that passed the limit). */
static inline int64_t sampler_count(const sampler *s) { return (int64_t)s->grid * s->grid * s->tspp; }


/* 0 if the counts are positive and within SAMPLER_MAX_TIME_STRATA (which
 * also keeps a batch inside the 2^32 points of the Sobol' sequence: every
 * batch is its own scramble of its first n); else -1 with the reason.
 * Checked before anything is allocated from the counts. */
int sampler_check(const sampler *s, rr_error *err);

typedef struct {
    double t;
    uint32_t index;
} sampler_time_key;

/* Scratch for one thread: thesis needs tspp * time_factor doubles and ints,
 * sobol a batch's points and their time order. */
typedef struct {
    double *jitter;
    int *perm;
    uint64_t *taken; /* thesis: bitset of the strata taken by the current ray */
    sampler_time_key *keys; /* sobol: the batch's points by time */
    double *points;         /* sobol: x, y, w of each point before the sort (its t is in its key) */
} sampler_scratch;

int sampler_scratch_init(sampler_scratch *sc, const sampler *s);
void sampler_scratch_free(sampler_scratch *sc);

/* The n samples of batch `batch` of pixel (px, py) (pixel = py * width + px):
 * raster positions x, y, times t in [t0, t1) (the shutter) and weights w
 * (mean 1). For the thesis sampler, samples k*tspp .. k*tspp + tspp - 1
 * share spatial position k. */
void sampler_batch(const sampler *s, double t0, double t1, uint64_t pixel, int px, int py, uint32_t batch,
                   sampler_scratch *sc, double *x, double *y, double *t, double *w);

/* Building blocks, exposed for tests. */
double sampler_uniform(uint64_t seed, uint64_t a, uint64_t b, uint32_t dim);
uint32_t sobol_u32(uint32_t index, int dim);
uint32_t owen_scramble_u32(uint32_t x, uint32_t seed);

#endif
