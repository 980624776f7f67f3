#include "render/integrator.h"

#include <math.h>
#include <string.h>

/* The built-in integrators, looked up by id. */
static const integrator_ops *const integrator_table[] = {&surfel_integrator_row, &gaussian_integrator_row,
                                                        &exact_integrator_row};

const integrator_ops *integrator_find(const integrator_ops *const *table, int n, const char *id)
{
    for (int i = 0; id && i < n; i++)
        if (!strcmp(table[i]->id, id))
            return table[i];
    return NULL;
}

const integrator_ops *integrator_named(const char *id)
{
    return integrator_find(integrator_table, (int)(sizeof integrator_table / sizeof *integrator_table), id);
}

const integrator_ops *integrator_for(const integrator_context *ctx)
{
    if (ctx->rs->integrator)
        return ctx->rs->integrator;
    return accel_has_gaussians(ctx->acc) ? &gaussian_integrator_row : &surfel_integrator_row;
}

static double clamp01(double v) { return fmin(fmax(v, 0.0), 1.0); }

/* The sRGB transfer function's inverse (IEC 61966-2-1) of a value clamped
 * to [0, 1], as an 8-bit frame would hold it. */
static double srgb_to_linear(double v)
{
    v = clamp01(v);
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

/* A sample's colour in the space the pixel averages (--blur-space). */
static void to_blur_space(blur_space blur, double rgba[4])
{
    if (blur == BLUR_SPACE_LINEAR)
        for (int c = 0; c < 3; c++)
            rgba[c] = srgb_to_linear(rgba[c]);
    else if (blur == BLUR_SPACE_CLAMPED)
        for (int c = 0; c < 3; c++)
            rgba[c] = clamp01(rgba[c]);
}

/* The thesis weights each sample by a(t) and divides by the sum of the
 * weights; here the times are drawn from a(t) instead (render.c's
 * batch_samples), the same expectation without a ratio that is 0/0 for a
 * batch that drew only times of zero weight. The weights left are the
 * sampler's (its random time halves with error bars, sampler.c): never all 0, and summing
 * to the count whenever each time stratum holds one sample, when the ratio
 * is the plain unbiased mean; dividing by their sum keeps a pixel of one
 * constant colour exactly that colour in every batch. */
int integrator_sampled_batch(void *thread, const integrator_context *ctx, const pixel_samples *ps,
                             integrator_group_fn *group, double est[4], integrator_counts *c)
{
    double acc[4] = {0, 0, 0, 0}, weight = 0;
    for (int first = 0; first < ps->count;) {
        if (ctx->cancel && *ctx->cancel) /* (a group is at most ACCEL_PACKET samples: microseconds) */
            return INTEGRATOR_INTERRUPTED; /* (its rays uncounted: a resumed render counts the batch's once) */
        double rgba[ACCEL_PACKET][4];
        int end = group(thread, ctx, ps, first, rgba, c);
        RR_DCHECK(end > first && end - first <= ACCEL_PACKET);
        for (int k = 0; k < end - first; k++) {
            double w = ps->w[first + k];
            to_blur_space(ctx->rs->blur, rgba[k]);
            for (int ch = 0; ch < 4; ch++)
                acc[ch] += w * rgba[k][ch];
            weight += w;
        }
        first = end;
    }
    RR_DCHECK(ps->count > 0 && weight > 0);
    for (int ch = 0; ch < 4; ch++)
        est[ch] = acc[ch] / weight;
    c->rays += (uint64_t)ps->count;
    return 0;
}
