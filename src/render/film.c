#include "render/film.h"

#include "core/common.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int film_add_batch(pixel_state *p, const double estimate[4])
{
    /* past the cap the 128-bit sums of squares may overflow (film_check) */
    RR_DCHECK_LT(p->batches, FILM_MAX_BATCHES);
    int clamped = 0;
    for (int c = 0; c < 4; c++) {
        double x = estimate[c];
        if (!(fabs(x) <= FILM_LIMIT)) { /* also catches NaN */
            x = isnan(x) ? 0.0 : copysign(FILM_LIMIT, x);
            clamped = 1;
        }
        int64_t q = llround(x * FILM_SCALE);
        p->sum[c] += q;
        p->sumsq[c] += (__int128)q * q;
    }
    p->batches++;
    return clamped;
}

int film_check(const pixel_state *p)
{
    const __int128 most = (__int128)1 << 44; /* FILM_LIMIT * FILM_SCALE */
    __int128 b = p->batches;
    if (p->batches > FILM_MAX_BATCHES)
        return -1;
    for (int c = 0; c < 4; c++) {
        __int128 s = p->sum[c], q = p->sumsq[c];
        if (s > b * most || s < -b * most || q < 0 || q > b * most * most)
            return -1;
        if (s * s > b * q)
            return -1;
    }
    return 0;
}

void film_merge(pixel_state *into, const pixel_state *from)
{
    into->batches += from->batches;
    for (int c = 0; c < 4; c++) {
        into->sum[c] += from->sum[c];
        into->sumsq[c] += from->sumsq[c];
    }
}

void film_resolve(const pixel_state *p, double mean[4], double var_of_mean[4])
{
    double b = p->batches;
    for (int c = 0; c < 4; c++) {
        mean[c] = b > 0 ? (double)p->sum[c] / b / FILM_SCALE : 0.0;
        if (p->batches < 2) {
            var_of_mean[c] = NAN;
            continue;
        }
        /* B * sum q^2 - (sum q)^2 is exact in 128 bits: no cancellation */
        __int128 centered = (__int128)p->batches * p->sumsq[c] - (__int128)p->sum[c] * p->sum[c];
        double s2 = (double)centered / (b * (b - 1)) / (FILM_SCALE * FILM_SCALE);
        var_of_mean[c] = s2 / b;
    }
}

double film_max_stderr(const pixel_state *p)
{
    double mean[4], var[4];
    if (p->batches < 2)
        return INFINITY;
    film_resolve(p, mean, var);
    return sqrt(fmax(var[0], fmax(var[1], var[2])));
}

int image_alloc(image *img, int width, int height)
{
    memset(img, 0, sizeof *img);
    img->width = width;
    img->height = height;
    img->px = calloc((size_t)width * (size_t)height, sizeof *img->px);
    return img->px ? 0 : -1;
}

void image_free(image *img)
{
    free(img->px);
    img->px = NULL;
}

void image_resolve(const image *img, int samples_per_batch, float *rgba, float *variance,
                   float *stderr_rgba, float *samples)
{
    size_t n = (size_t)img->width * img->height;
    for (size_t i = 0; i < n; i++) {
        double mean[4], var[4];
        film_resolve(&img->px[i], mean, var);
        for (int c = 0; c < 4; c++) {
            rgba[4 * i + c] = (float)mean[c];
            variance[4 * i + c] = (float)var[c];
            stderr_rgba[4 * i + c] = (float)sqrt(var[c]);
        }
        samples[i] = (float)img->px[i].batches * (float)samples_per_batch;
    }
}

int image_planes_resolve(const image *img, int samples_per_batch, image_planes *p)
{
    size_t n = (size_t)img->width * img->height;
    p->rgba = malloc(n * 4 * sizeof *p->rgba), p->var = malloc(n * 4 * sizeof *p->var);
    p->se = malloc(n * 4 * sizeof *p->se), p->samples = malloc(n * sizeof *p->samples);
    if (!p->rgba || !p->var || !p->se || !p->samples) {
        image_planes_free(p);
        return -1;
    }
    image_resolve(img, samples_per_batch, p->rgba, p->var, p->se, p->samples);
    return 0;
}

void image_planes_free(image_planes *p)
{
    free(p->rgba), free(p->var), free(p->se), free(p->samples);
    *p = (image_planes){0};
}
