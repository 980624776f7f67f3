/* Candidates for exact time integration (exact.h): which primitives of an
 * object a moving ray may meet, found by Embree's own BVH of the object
 * (rtcCollide against a small BVH of query boxes), never by a second
 * hand-written hierarchy over the splats. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "accel/accel_internal.h"

typedef struct {
    pthread_mutex_t lock; /* Embree may call back from several of its own tasks */
    accel_prims *out;
    size_t from, limit, compact_at;
    int failed; /* an ACCEL_COLLIDE_ status */
} collide_sink;

static void query_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const aabb *b = &((const aabb *)args->geometryUserPtr)[args->primID];
    struct RTCBounds *r = args->bounds_o;
    float lo[3], hi[3];
    aabb_round_out(*b, lo, hi); /* a float box never cuts into the double one */
    r->lower_x = lo[0], r->lower_y = lo[1], r->lower_z = lo[2];
    r->upper_x = hi[0], r->upper_y = hi[1], r->upper_z = hi[2];
}

static void query_intersect_cb(const struct RTCIntersectFunctionNArguments *args) { (void)args; }

static int prims_push(accel_prims *p, unsigned id)
{
    if (rr_grow((void **)&p->ids, &p->cap, p->count + 1, sizeof *p->ids))
        return -1;
    p->ids[p->count++] = id;
    return 0;
}

static void prims_sort_unique(accel_prims *p, size_t from);

/* A primitive is reported once per box it meets, so the pairs can far
 * outnumber the primitives (148 million ids for one pixel of a small
 * scene): the list is made unique whenever it reaches compact_at, and the
 * gathering fails once more than `limit` distinct primitives remain. */
static void sink_compact(collide_sink *sink)
{
    prims_sort_unique(sink->out, sink->from);
    if (sink->out->count - sink->from > sink->limit)
        sink->failed = ACCEL_COLLIDE_TOO_MANY;
    sink->compact_at = sink->out->count + 4 * sink->limit + 1024;
}

/* Embree reports pairs whose float bounds overlap: a superset of what the
 * double boxes meet, which is what conservative gathering needs. */
static void collide_cb(void *user, struct RTCCollision *pairs, unsigned int n)
{
    collide_sink *sink = user;
    pthread_mutex_lock(&sink->lock);
    for (unsigned i = 0; i < n && !sink->failed; i++) {
        if (prims_push(sink->out, pairs[i].primID0))
            sink->failed = ACCEL_COLLIDE_NO_MEMORY;
        else if (sink->out->count >= sink->compact_at)
            sink_compact(sink);
    }
    pthread_mutex_unlock(&sink->lock);
}

static int cmp_unsigned(const void *a, const void *b)
{
    unsigned x = *(const unsigned *)a, y = *(const unsigned *)b;
    return (x > y) - (x < y);
}

/* Sorted and unique: the candidate list, and so the image, does not depend
 * on the order in which Embree's tasks report pairs. */
static void prims_sort_unique(accel_prims *p, size_t from)
{
    size_t n = p->count - from, m = 0;
    if (n == 0)
        return;
    unsigned *ids = p->ids + from;
    qsort(ids, n, sizeof *ids, cmp_unsigned);
    for (size_t i = 0; i < n; i++)
        if (m == 0 || ids[i] != ids[m - 1])
            ids[m++] = ids[i];
    p->count = from + m;
}

int accel_collide_boxes(const accel *a, unsigned obj, const aabb *boxes, unsigned nboxes, size_t limit,
                        accel_prims *out)
{
    size_t from = out->count;
    if (nboxes == 0)
        return 0;
    rtcGetDeviceError(a->device); /* Embree keeps an error per thread: start from none */
    RTCScene query = accel_user_scene(a->device, nboxes, (void *)boxes, query_bounds_cb, query_intersect_cb, 0);
    collide_sink sink = {PTHREAD_MUTEX_INITIALIZER, out, from, limit, from + 4 * limit + 1024, 0};
    if (query)
        rtcCollide(a->object_scenes[obj], query, collide_cb, &sink);
    if (query)
        rtcReleaseScene(query);
    pthread_mutex_destroy(&sink.lock);
    if (!query || rtcGetDeviceError(a->device) != RTC_ERROR_NONE)
        return ACCEL_COLLIDE_EMBREE;
    if (!sink.failed)
        sink_compact(&sink);
    return sink.failed;
}

int accel_object_moves(const accel *a, unsigned obj) { return !a->is_static[obj]; }

void accel_object_swept_sphere(const accel *a, unsigned obj, vec3 *center, double *radius)
{
    *center = a->swept_sphere[obj].center;
    *radius = sqrt(a->swept_sphere[obj].radius2);
}
