/* make bench's splatting rows (src/SPLAT.md): each `refrender splat`
 * method's time against the ground truth's on the same scene. */
#ifndef RR_BENCH_SPLAT_H
#define RR_BENCH_SPLAT_H

#include <stdio.h>

#include "accel/accel.h"

/* Prints a markdown table and appends CSV rows (series "splat"): for each
 * method its seconds, and the ratio to the ray tracer sampling as many
 * instants at every pixel centre (--pixel-filter point --spp 1 --tspp N),
 * both on one thread (the splatting path has one). */
void bench_splat(const scene *s, const accel *acc, int res, FILE *csv);

#endif
