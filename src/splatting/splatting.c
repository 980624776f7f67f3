#include "splatting/splatting.h"

#include <stdlib.h>
#include <string.h>

#include "accel/accel.h"
#include "splatting/frame.h"
#include "splatting/guan_mueller.h"
#include "splatting/volumetric.h"

/* Eq. 4.14: (Rd, Gd, Bd, Ad) += As (Rs, Gs, Bs, 1) with As = a(t_j), the
 * sum then divided by the summed weights; alpha is the accumulated coverage. */
static void accumulate(double *acc, const float *rgba, size_t n, double w)
{
    for (size_t i = 0; i < 4 * n; i++)
        acc[i] += w * rgba[i];
}

/* Instants [begin, end) splatted as one object (sec. 4.4): one visibility
 * pass over all of them, one attribute pass, one normalisation. One
 * instant is the static three-pass algorithm of sec. 4.1.1. */
static void splat_group(splat_frame *f, const double *times, int begin, int end, float *rgba)
{
    splat_frame_clear(f);
    for (int j = begin; j < end; j++)
        splat_visibility_pass(f, times[j]);
    for (int j = begin; j < end; j++)
        splat_attribute_pass(f, times[j]);
    splat_shade_pass(f, rgba);
}

/* Accumulation (B = N, sec. 4.3) and time buckets (sec. 4.4): bucket b
 * holds instants [b N / B, (b + 1) N / B); its image enters eq. 4.14 with
 * the summed a(t_j) of its instants as its weight. */
static int splat_buckets(splat_frame *f, const splat_settings *set, int buckets, float *rgba, rr_error *err)
{
    size_t n = (size_t)f->width * f->height;
    double *times = malloc((size_t)set->samples * sizeof *times), *acc = calloc(4 * n, sizeof *acc);
    float *img = malloc(4 * n * sizeof *img);
    int rc = times && acc && img ? 0 : rr_fail(err, "out of memory for the accumulation buffer");
    double wsum = 0;
    if (!rc)
        splat_instants(set, &f->sc->shut, times);
    for (int b = 0; !rc && b < buckets; b++) {
        int begin = (int)((int64_t)b * set->samples / buckets), end = (int)((int64_t)(b + 1) * set->samples / buckets);
        double w = 0;
        for (int j = begin; j < end; j++)
            w += shutter_weight(&f->sc->shut, times[j]);
        if (begin == end || !(w > 0))
            continue;
        splat_group(f, times, begin, end, img);
        accumulate(acc, img, n, w);
        wsum += w;
    }
    if (!rc && !(wsum > 0))
        rc = rr_fail(err, "every instant has weight a(t) = 0: nothing to accumulate");
    for (size_t i = 0; !rc && i < 4 * n; i++)
        rgba[i] = (float)(acc[i] / wsum);
    free(times), free(acc), free(img);
    return rc;
}

/* The ray tracer's reach rule (accel_check_reach) over the instants
 * splatted: an instant or a shutter the renderer refuses (a --time of
 * 1e300 moving an object past RR_MAX_REACH) is refused here too. */
static int check_reach(const scene *s, const splat_settings *set, rr_error *err)
{
    double open = set->method == SPLAT_INSTANT ? set->instant : s->shut.open;
    double close = set->method == SPLAT_INSTANT ? set->instant : s->shut.close;
    aabb *swept = malloc(((size_t)s->nobjects + 1) * sizeof *swept);
    if (!swept)
        return rr_fail(err, "out of memory for the objects' bounds");
    for (int i = 0; i < s->nobjects; i++)
        swept[i] = animation_swept_bounds(&s->objects[i].anim, scene_object_bounds(&s->objects[i]), open, close);
    int rc = accel_check_reach(s, swept, open, close, err);
    free(swept);
    return rc;
}

static int check_scene(const scene *s, const splat_settings *set, rr_error *err)
{
    for (int i = 0; i < s->nobjects; i++)
        if (!scene_object_row(&s->objects[i])->point_model)
            return rr_fail(err, "%s: object '%s' is %s: refrender splat renders point models (surfels) only", s->path,
                           s->objects[i].name, scene_object_row(&s->objects[i])->name);
    if (s->shut.rolling.kind != ROLLING_OFF)
        return rr_fail(err, "%s: a rolling shutter: refrender splat renders global-shutter instants only", s->path);
    return check_reach(s, set, err);
}

int splat_render(const scene *s, const splat_settings *set, splat_result *out, rr_error *err)
{
    memset(out, 0, sizeof *out);
    if (check_scene(s, set, err))
        return -1;
    splat_frame f;
    size_t n = (size_t)s->cam.width * s->cam.height;
    if (splat_frame_init(&f, s, set->filter))
        return rr_fail(err, "out of memory for the %dx%d splatting buffers", s->cam.width, s->cam.height);
    out->width = s->cam.width, out->height = s->cam.height;
    out->rgba = malloc(4 * n * sizeof *out->rgba);
    int rc = out->rgba ? 0 : rr_fail(err, "out of memory for the image");
    if (!rc && set->method == SPLAT_INSTANT)
        splat_group(&f, &set->instant, 0, 1, out->rgba);
    else if (!rc && set->method == SPLAT_VOLUMETRIC)
        rc = splat_volumetric(&f, set, out->rgba, err);
    else if (!rc && set->method == SPLAT_GUAN_MUELLER)
        rc = splat_guan_mueller(&f, set, out->rgba, err);
    else if (!rc)
        rc = splat_buckets(&f, set, set->method == SPLAT_ACCUM ? set->samples : set->buckets, out->rgba, err);
    out->fragments = f.fragments;
    splat_frame_free(&f);
    if (rc)
        splat_result_free(out);
    return rc;
}

void splat_result_free(splat_result *r)
{
    free(r->rgba);
    r->rgba = NULL;
}
