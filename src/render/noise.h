/* The noise an image reached: each pixel's standard error (its largest RGB
 * channel's, the quantity --target-error stops on) summarised over the
 * image, and the range of batches its pixels hold. Every writer of a final
 * image (a render, refrender merge) takes its noise attributes from here,
 * and the summary line its figures, so the two always agree. */
#ifndef RR_NOISE_H
#define RR_NOISE_H

#include <stddef.h>
#include <stdint.h>

#include "render/film.h"

/* 8-bit levels per value unit: a level is 1/255 (the docs' unit). */
#define NOISE_LEVEL 255.0

typedef struct {
    size_t pixels;                     /* pixels holding batches (a crop window's, or all) */
    uint32_t batches_min, batches_max; /* batches held, over those pixels */
    /* over those pixels, each its largest RGB standard error (value units);
     * NaN unless every pixel holds 2 or more batches */
    double mean, p99, max;
} noise_stats;

/* The noise of img's pixels that hold at least one batch. p99 is the
 * nearest-rank 99th percentile: the smallest value that at least 99% of the
 * pixels are at or below. Returns -1 when out of memory (the percentile
 * sorts a copy). */
int noise_stats_of(const image *img, noise_stats *out);

/* Whether the image has standard errors at all (every pixel >= 2 batches). */
int noise_has_stderr(const noise_stats *n);

/* "mean A, 99th percentile B, max C 8-bit levels (a, b, c)" or, for one
 * batch, no figures: the text of the summary line and of
 * refrender:stderrReached. */
void noise_text(const noise_stats *n, char *buf, size_t size);

#endif
