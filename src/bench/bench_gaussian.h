/* make bench's Gaussian-splat rows: refrender's 2DGS and 3DGS paths
 * against Embree's built-in oriented discs gathering every hit, on the
 * same rays, in one run. */
#ifndef RR_BENCH_GAUSSIAN_H
#define RR_BENCH_GAUSSIAN_H

#include <stddef.h>
#include <stdio.h>

/* Runs run(in, out) in a forked child (so a case's peak memory is its
 * own) and copies its `size`-byte result back; -1 if the child failed. */
int bench_in_child(void (*run)(const void *in, void *out), const void *in, void *out, size_t size);
/* The process's peak resident memory so far (MB): in a bench_in_child
 * child, the case's own. */
double bench_peak_mb(void);

/* Runs the case (in a child process, for its own peak memory) and prints
 * its table; quick: a small model. Returns 0, or -1 if the case failed. */
int bench_gaussians(int quick, int threads, FILE *csv);

/* The benchmark-scale row alone (part of bench_gaussians; series
 * "scale"): seconds per 600x400 view of 3M layered Gaussians. */
int bench_gaussian_scale(int quick, int threads, FILE *csv);

/* The moving-Gaussians rows alone (part of bench_gaussians; series
 * "stg"): a SpacetimeGaussians-lite model against the same Gaussians
 * frozen at mid-shutter, seconds per 600x400 view. */
int bench_gaussian_stg(int quick, int threads, FILE *csv);

#endif
