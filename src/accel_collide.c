/* Candidates for exact time integration (exact.h): which primitives of an
 * object a moving ray may meet, found by Embree's own BVH of the object
 * (rtcCollide against a small BVH of query boxes), never by a second
 * hand-written hierarchy over the splats. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "accel_internal.h"

typedef struct {
    pthread_mutex_t lock; /* Embree may call back from several of its own tasks */
    accel_prims *out;
    int failed;
} collide_sink;

static void query_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const aabb *b = &((const aabb *)args->geometryUserPtr)[args->primID];
    struct RTCBounds *r = args->bounds_o;
    /* rounded outwards: a float box never cuts into the double one */
    r->lower_x = nextafterf((float)b->lo.x, -INFINITY), r->lower_y = nextafterf((float)b->lo.y, -INFINITY);
    r->lower_z = nextafterf((float)b->lo.z, -INFINITY);
    r->upper_x = nextafterf((float)b->hi.x, INFINITY), r->upper_y = nextafterf((float)b->hi.y, INFINITY);
    r->upper_z = nextafterf((float)b->hi.z, INFINITY);
}

static void query_intersect_cb(const struct RTCIntersectFunctionNArguments *args) { (void)args; }

static int prims_push(accel_prims *p, unsigned id)
{
    if (p->count == p->cap) {
        size_t cap = p->cap ? 2 * p->cap : 256;
        unsigned *ids = realloc(p->ids, cap * sizeof *ids);
        if (!ids)
            return -1;
        p->ids = ids, p->cap = cap;
    }
    p->ids[p->count++] = id;
    return 0;
}

/* Embree reports pairs whose float bounds overlap: a superset of what the
 * double boxes meet, which is what conservative gathering needs. */
static void collide_cb(void *user, struct RTCCollision *pairs, unsigned int n)
{
    collide_sink *sink = user;
    pthread_mutex_lock(&sink->lock);
    for (unsigned i = 0; i < n && !sink->failed; i++)
        sink->failed = prims_push(sink->out, pairs[i].primID0);
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

int accel_collide_boxes(const accel *a, unsigned obj, const aabb *boxes, unsigned nboxes, accel_prims *out)
{
    size_t from = out->count;
    if (nboxes == 0)
        return 0;
    RTCScene query = accel_user_scene(a->device, nboxes, (void *)boxes, query_bounds_cb, query_intersect_cb);
    collide_sink sink = {PTHREAD_MUTEX_INITIALIZER, out, 0};
    rtcCollide(a->object_scenes[obj], query, collide_cb, &sink);
    rtcReleaseScene(query);
    pthread_mutex_destroy(&sink.lock);
    if (sink.failed)
        return -1;
    prims_sort_unique(out, from);
    return 0;
}

int accel_object_moves(const accel *a, unsigned obj) { return !a->is_static[obj]; }

void accel_object_swept_sphere(const accel *a, unsigned obj, vec3 *center, double *radius)
{
    *center = a->swept_sphere[obj].center;
    *radius = sqrt(a->swept_sphere[obj].radius2);
}
