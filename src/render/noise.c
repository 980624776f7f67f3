#include "render/noise.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Nearest rank: the value at rank ceil(0.99 n) (1-based) of the sorted n. */
static double percentile_99(double *v, size_t n)
{
    qsort(v, n, sizeof *v, by_value);
    size_t rank = (size_t)ceil(0.99 * (double)n);
    return v[(rank > 0 ? rank : 1) - 1];
}

int noise_stats_of(const image *img, noise_stats *out)
{
    size_t n = (size_t)img->width * img->height, k = 0;
    *out = (noise_stats){.batches_min = UINT32_MAX, .mean = NAN, .p99 = NAN, .max = NAN};
    double *se = malloc((n ? n : 1) * sizeof *se);
    if (!se)
        return -1;
    double sum = 0.0, most = 0.0;
    for (size_t i = 0; i < n; i++) {
        const pixel_state *p = &img->px[i];
        if (!p->batches) /* outside a crop window */
            continue;
        out->batches_min = p->batches < out->batches_min ? p->batches : out->batches_min;
        out->batches_max = p->batches > out->batches_max ? p->batches : out->batches_max;
        se[k] = film_max_stderr(p); /* INFINITY for one batch: no figures then */
        sum += se[k], most = fmax(most, se[k]);
        k++;
    }
    out->pixels = k;
    if (!k)
        out->batches_min = 0;
    if (k && out->batches_min >= 2)
        out->mean = sum / (double)k, out->max = most, out->p99 = percentile_99(se, k);
    free(se);
    return 0;
}

int noise_has_stderr(const noise_stats *n) { return n->pixels > 0 && n->batches_min >= 2; }

void noise_text(const noise_stats *n, char *buf, size_t size)
{
    if (!noise_has_stderr(n)) {
        snprintf(buf, size, "no standard errors (pixels with one batch)");
        return;
    }
    snprintf(buf, size, "mean %.3g, 99th percentile %.3g, max %.3g 8-bit levels (%.3g, %.3g, %.3g)",
             n->mean * NOISE_LEVEL, n->p99 * NOISE_LEVEL, n->max * NOISE_LEVEL, n->mean, n->p99, n->max);
}
