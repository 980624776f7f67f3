#include "cmd/noise_report.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/render_attrs.h"

int noise_parse_target(const char *text, double *value, rr_error *err)
{
    char *end;
    double v = strtod(text, &end);
    int levels = !strcmp(end, "lv");
    if (end == text || (*end && !levels) || !isfinite(v) || !(v > 0))
        return rr_fail(err, "--target-error: expected a positive number in value units (0.002) or in 8-bit "
                            "levels (0.5lv), got '%s'", text);
    *value = levels ? v / NOISE_LEVEL : v;
    return 0;
}

/* How many of the pixels holding batches reached the target. */
static size_t pixels_reached(const image *img, double target_error)
{
    size_t n = (size_t)img->width * img->height, reached = 0;
    for (size_t i = 0; i < n; i++)
        reached += img->px[i].batches > 0 && film_max_stderr(&img->px[i]) <= target_error;
    return reached;
}

static void report_target(const image *img, const noise_stats *ns, double target_error, uint32_t cap, int quiet,
                          attr_list *attrs)
{
    size_t reached = pixels_reached(img, target_error);
    attrs_set(attrs, ATTR_TARGET_ERROR, "%.17g", target_error);
    attrs_set(attrs, ATTR_TARGET_REACHED, "%zu of %zu pixels", reached, ns->pixels);
    if (!quiet)
        fprintf(stderr, "refrender: %zu of %zu pixels reached standard error <= %.3g 8-bit levels (%.3g); %zu stopped "
                        "at %u batches\n", reached, ns->pixels, target_error * NOISE_LEVEL, target_error,
                ns->pixels - reached, cap);
}

int noise_report(const image *img, double target_error, uint32_t cap, int quiet, attr_list *attrs, rr_error *err)
{
    noise_stats ns;
    if (noise_stats_of(img, &ns))
        return rr_fail(err, "out of memory");
    if (target_error > 0)
        report_target(img, &ns, target_error, cap, quiet, attrs);
    attrs_for_noise(attrs, &ns);
    if (quiet || !noise_has_stderr(&ns))
        return 0;
    char text[160];
    noise_text(&ns, text, sizeof text);
    fprintf(stderr, "refrender: standard error reached (each pixel's largest RGB channel): %s; %u to %u batches a "
                    "pixel\n", text, ns.batches_min, ns.batches_max);
    return 0;
}
