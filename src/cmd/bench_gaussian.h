/* make bench's Gaussian-splat row (issue 24): refrender's 2DGS path
 * against Embree's built-in oriented discs gathering every hit, on the
 * same rays, in one run. */
#ifndef RR_BENCH_GAUSSIAN_H
#define RR_BENCH_GAUSSIAN_H

#include <stdio.h>

/* Runs the case (in a child process, for its own peak memory) and prints
 * its table; quick: a small model. Returns 0, or -1 if the case failed. */
int bench_gaussians(int quick, int threads, FILE *csv);

#endif
