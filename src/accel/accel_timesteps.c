/* Bounds per time segment for moving Gaussians (issue 58, lever 3). A
 * dynamic model's BVH held one box per Gaussian over the whole shutter: a
 * ray at any time listed every Gaussian whose path came near it at some
 * time, and the cull at the ray's time threw most of those away. Here the
 * shutter is cut into TIME_SEGMENTS equal segments with a BVH each, whose
 * boxes hold each Gaussian over that segment's times only; a ray at time t
 * asks the BVH of t's segment.
 *
 * Why the boxes hold every Gaussian that can meet the ray (the boxes only
 * prune: the hits found are the same): segment k's box is the one
 * accel_dynamic_reach_box makes for the whole shutter, from the mean's box
 * and the largest opacity over the segment's window [k, k + 1] / S of the
 * shutter grown by TIME_ROOM of it each side (so a time on a boundary, or
 * computed a rounding off, is inside the window of the segment it is
 * given to), met with the whole shutter's (both hold the Gaussian).
 *
 * Embree 3's own motion blur (rtcSetGeometryTimeStepCount, boxes per time
 * step blended linearly, the ray's time in the traversal) was tried first
 * and measured no faster: on make bench's stg case it cut the Gaussians
 * listed per query from 20.6 to 13.1 (8 segments) but its traversal ate
 * the gain, and its build took 4x-20x as long with 4.6x-17x the memory
 * (src/cmd/BENCH.md, moving Gaussians). */
#include "accel/accel_internal.h"
#include "gaussians/gaussian_dynamic.h"

#include <math.h>
#include <stdlib.h>

/* How many segments a shutter is cut into: chosen by `make bench`'s stg
 * series (src/cmd/BENCH.md, moving Gaussians). */
enum { TIME_SEGMENTS = 4 };
static const double TIME_ROOM = 1e-6;

/* The mean's box and largest opacity over segment k's window, met with the
 * whole shutter's (a window's bound is then never looser, and its reach
 * was checked: dynamic_paths). */
static void segment_path(const gaussian_footprint *f, const gaussian_model *m, unsigned prim, unsigned k,
                         double path[PATH_DOUBLES])
{
    double span = f->close - f->open, S = f->time_segments;
    double t0 = fmax(f->open, f->open + span * (k / S - TIME_ROOM));
    double t1 = fmin(f->close, f->open + span * ((k + 1.0) / S + TIME_ROOM));
    const double *whole = &f->paths[PATH_DOUBLES * prim];
    if (gaussian_dynamic_bounds(m, prim, t0, t1, path, path + 3, path + 6)) {
        for (int j = 0; j < PATH_DOUBLES; j++)
            path[j] = whole[j];
        return;
    }
    for (int j = 0; j < 3; j++) {
        path[j] = fmax(path[j], whole[j]);
        path[3 + j] = fmin(path[3 + j], whole[3 + j]);
    }
    path[6] = fmin(path[6], whole[6]);
}

/* Every Gaussian's box in every segment, rounded outward to floats, as the
 * whole shutter's are (embree_bounds in accel.c): computed once, as
 * Embree may ask for a box more than once. */
static int segment_boxes(gaussian_footprint *f, size_t count)
{
    size_t S = f->time_segments;
    if (count > SIZE_MAX / (6 * S * sizeof *f->segment_boxes))
        return -1;
    f->segment_boxes = malloc(count * S * 6 * sizeof *f->segment_boxes);
    if (!f->segment_boxes)
        return -1;
    const gaussian_model *m = f->acc->models[f->obj];
    for (size_t i = 0; i < count; i++)
        for (unsigned k = 0; k < S; k++) {
            double path[PATH_DOUBLES];
            segment_path(f, m, (unsigned)i, k, path);
            float *box = &f->segment_boxes[6 * (S * i + k)];
            aabb_round_out(accel_dynamic_reach_box(f, (unsigned)i, path), box, box + 3);
        }
    return 0;
}

static void segment_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const gaussian_footprint *f = args->geometryUserPtr;
    const float *box = &f->segment_boxes[6 * ((size_t)f->time_segments * args->primID + f->building)];
    struct RTCBounds *r = args->bounds_o;
    r->lower_x = box[0], r->lower_y = box[1], r->lower_z = box[2];
    r->upper_x = box[3], r->upper_y = box[4], r->upper_z = box[5];
}

int accel_build_segments(gaussian_footprint *f, size_t count)
{
    f->time_segments = TIME_SEGMENTS;
    if (!(f->close > f->open) || f->time_segments < 2 || segment_boxes(f, count))
        return f->time_segments = 1, -1;
    if (!(f->segments = calloc(f->time_segments, sizeof *f->segments))) {
        free(f->segment_boxes);
        f->segment_boxes = NULL;
        return f->time_segments = 1, -1;
    }
    for (f->building = 0; f->building < f->time_segments; f->building++)
        f->segments[f->building] = accel_user_scene(f->acc->device, (unsigned)count, f, segment_bounds_cb,
                                                    accel_gaussian_gather, 1);
    free(f->segment_boxes);
    f->segment_boxes = NULL;
    return 0;
}

void accel_release_segments(gaussian_footprint *f)
{
    for (unsigned k = 0; f->segments && k < f->time_segments; k++)
        if (f->segments[k])
            rtcReleaseScene(f->segments[k]);
    free(f->segments);
    f->segments = NULL;
    f->time_segments = 1;
}

RTCScene accel_segment_scene(const gaussian_footprint *f, double time)
{
    double u = (time - f->open) / (f->close - f->open) * f->time_segments;
    RR_DCHECK(u >= -TIME_ROOM * f->time_segments && u <= (1 + TIME_ROOM) * f->time_segments);
    int k = (int)floor(u);
    k = k < 0 ? 0 : k >= (int)f->time_segments ? (int)f->time_segments - 1 : k;
    return f->segments[k];
}

void accel_gaussian_scene_bounds(const struct accel *a, unsigned obj, struct RTCBounds *b)
{
    const gaussian_footprint *f = &a->footprint[obj];
    if (!f->segments) {
        rtcGetSceneBounds(a->object_scenes[obj], b);
        return;
    }
    rtcGetSceneBounds(f->segments[0], b);
    for (unsigned k = 1; k < f->time_segments; k++) {
        struct RTCBounds s;
        rtcGetSceneBounds(f->segments[k], &s);
        b->lower_x = fminf(b->lower_x, s.lower_x), b->lower_y = fminf(b->lower_y, s.lower_y);
        b->lower_z = fminf(b->lower_z, s.lower_z), b->upper_x = fmaxf(b->upper_x, s.upper_x);
        b->upper_y = fmaxf(b->upper_y, s.upper_y), b->upper_z = fmaxf(b->upper_z, s.upper_z);
    }
}
