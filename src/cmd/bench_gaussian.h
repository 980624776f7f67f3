/* make bench's Gaussian-splat row (issue 24): refrender's 2DGS path
 * against Embree's built-in oriented discs gathering every hit, on the
 * same rays, in one run. */
#ifndef RR_BENCH_GAUSSIAN_H
#define RR_BENCH_GAUSSIAN_H

#include <stddef.h>
#include <stdio.h>

/* Runs run(in, out) in a forked child (so a case's peak memory is its
 * own) and copies its `size`-byte result back; -1 if the child failed. */
int bench_in_child(void (*run)(const void *in, void *out), const void *in, void *out, size_t size);

/* Runs the case (in a child process, for its own peak memory) and prints
 * its table; quick: a small model. Returns 0, or -1 if the case failed. */
int bench_gaussians(int quick, int threads, FILE *csv);

#endif
