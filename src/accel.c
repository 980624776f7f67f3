#include "accel.h"

#include <embree3/rtcore.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A top-level scene over a subset of the objects. Objects that do not move
 * during the shutter (static) and those that do (moving) get one each, so a
 * ray's static hits can be found once and reused for all its times. */
typedef struct {
    RTCScene scene;
    unsigned *ids; /* top-level primitive -> object index */
    unsigned count;
    const struct accel *acc;
} top_level;

enum { TOP_STATIC, TOP_MOVING };

typedef struct {
    vec3 center;
    double radius2;
} sphere_bound;

struct accel {
    RTCDevice device;
    top_level top[2];
    RTCScene *object_scenes;
    aabb *swept;  /* world bounds of each object over the shutter */
    sphere_bound *swept_sphere; /* and a world sphere holding it at every time */
    xform *rest;  /* transform of each static object (the same at every time) */
    int *is_static;
    int reuse_static;
    const scene *sc;
    float epsilon;
    double sigma;
    rr_error build_error; /* filled by Embree's error callback */
};

/* Per-ray state. The RTCIntersectContext must come first: Embree hands the
 * same pointer to every callback, also through the nested rtcIntersect1. */
typedef struct {
    struct RTCIntersectContext rtc;
    const accel *acc;
    double time;
    unsigned obj;
    xform xf; /* current object's transform at `time` */
    kbuffer *kb;
    int accepted; /* hits offered to the k-buffer in this traversal */
} trace_context;

/* ---- k-buffer ---------------------------------------------------------- */

void kbuffer_reset(kbuffer *kb, float epsilon)
{
    kb->count = 0;
    kb->dropped = 0;
    kb->closest = INFINITY;
    kb->epsilon = epsilon;
}

static int hit_before(const surface_hit *a, const surface_hit *b)
{
    if (a->t != b->t)
        return a->t < b->t;
    if (a->obj != b->obj)
        return a->obj < b->obj;
    return a->prim < b->prim;
}

void kbuffer_insert(kbuffer *kb, const surface_hit *h)
{
    if (!(h->t <= kb->closest + kb->epsilon))
        return;
    int pos = kb->count;
    while (pos > 0 && hit_before(h, &kb->hits[pos - 1]))
        pos--;
    if (kb->count == KBUFFER_MAX) {
        kb->dropped++;
        if (pos == KBUFFER_MAX)
            return;
        kb->count--; /* the farthest entry makes room */
    }
    memmove(&kb->hits[pos + 1], &kb->hits[pos], (size_t)(kb->count - pos) * sizeof *h);
    kb->hits[pos] = *h;
    kb->count++;
    if (h->t < kb->closest) {
        kb->closest = h->t;
        /* entries are sorted by t: drop the tail now beyond the window */
        while (kb->count > 0 && kb->hits[kb->count - 1].t > kb->closest + kb->epsilon)
            kb->count--;
    }
}

static float kbuffer_cutoff(const kbuffer *kb)
{
    return nextafterf(kb->closest + kb->epsilon, INFINITY);
}

/* ---- object-level callbacks (object space) ----------------------------- */

static void accept_hit(trace_context *c, struct RTCRayHit *rh, const struct RTCIntersectFunctionNArguments *args,
                       float t, float weight, float r2, vec3 normal, const float color[3])
{
    vec3 d = v3(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z);
    if (v3_dot(normal, d) > 0) /* two-sided surfaces: shade the side facing the eye */
        normal = v3_scale(normal, -1.0);
    vec3 wn = xform_normal(&c->xf, normal);
    surface_hit h = {t, c->obj, args->primID, weight, r2, {color[0], color[1], color[2]},
                     {(float)wn.x, (float)wn.y, (float)wn.z}};
    kbuffer_insert(c->kb, &h);
    c->accepted++;
    rh->ray.tfar = kbuffer_cutoff(c->kb);
    rh->hit.geomID = args->geomID;
    rh->hit.primID = args->primID;
}

static void splats_intersect(const struct RTCIntersectFunctionNArguments *args)
{
    if (!args->valid[0])
        return;
    trace_context *c = (trace_context *)args->context;
    struct RTCRayHit *rh = (struct RTCRayHit *)args->rayhit;
    const scene_object *o = args->geometryUserPtr;
    const float org[3] = {rh->ray.org_x, rh->ray.org_y, rh->ray.org_z};
    const float dir[3] = {rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z};
    float t, r2;
    if (!splat_intersect(&o->model.geom[args->primID], org, dir, rh->ray.tnear, rh->ray.tfar, &t, &r2))
        return;
    const float *n = pointmodel_normal(&o->model, args->primID);
    /* weight -1: computed after the traversal, if the hit is still in the buffer */
    accept_hit(c, rh, args, t, -1.0f, r2, v3(n[0], n[1], n[2]), pointmodel_color(&o->model, args->primID));
}

static void sphere_intersect(const struct RTCIntersectFunctionNArguments *args)
{
    if (!args->valid[0])
        return;
    trace_context *c = (trace_context *)args->context;
    struct RTCRayHit *rh = (struct RTCRayHit *)args->rayhit;
    const scene_object *o = args->geometryUserPtr;
    vec3 org = v3(rh->ray.org_x, rh->ray.org_y, rh->ray.org_z);
    vec3 dir = v3(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z);
    vec3 oc = v3_sub(org, o->sphere_center);
    double a = v3_dot(dir, dir), b = v3_dot(oc, dir), cc = v3_dot(oc, oc) - o->sphere_radius * o->sphere_radius;
    double disc = b * b - a * cc;
    if (disc < 0)
        return;
    double sq = sqrt(disc);
    /* The visible crossing of the opaque surface: the nearer root in range. */
    double roots[2] = {(-b - sq) / a, (-b + sq) / a};
    for (int i = 0; i < 2; i++) {
        float t = (float)roots[i];
        if (t >= rh->ray.tnear && t <= rh->ray.tfar) {
            vec3 p = v3_add(oc, v3_scale(dir, roots[i]));
            const float col[3] = {(float)o->sphere_color.x, (float)o->sphere_color.y, (float)o->sphere_color.z};
            accept_hit(c, rh, args, t, 1.0f, 0.0f, v3_scale(p, 1.0 / o->sphere_radius), col);
            return;
        }
    }
}

static void splat_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const scene_object *o = args->geometryUserPtr;
    const float *c = o->model.geom[args->primID].center;
    const float *e = &o->model.extent[3 * args->primID];
    /* pad by a few ulps so float rounding never clips a splat */
    float pad[3];
    for (int k = 0; k < 3; k++)
        pad[k] = e[k] * 1.00001f + 1e-6f * fabsf(c[k]) + 1e-30f;
    struct RTCBounds *b = args->bounds_o;
    b->lower_x = c[0] - pad[0], b->lower_y = c[1] - pad[1], b->lower_z = c[2] - pad[2];
    b->upper_x = c[0] + pad[0], b->upper_y = c[1] + pad[1], b->upper_z = c[2] + pad[2];
}

static void sphere_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const scene_object *o = args->geometryUserPtr;
    aabb b = scene_object_bounds(o);
    double pad = 1e-5 * o->sphere_radius;
    struct RTCBounds *r = args->bounds_o;
    r->lower_x = (float)(b.lo.x - pad), r->lower_y = (float)(b.lo.y - pad), r->lower_z = (float)(b.lo.z - pad);
    r->upper_x = (float)(b.hi.x + pad), r->upper_y = (float)(b.hi.y + pad), r->upper_z = (float)(b.hi.z + pad);
}

/* We never call rtcOccluded; the callback exists so the geometry is complete. */
static void no_occluded(const struct RTCOccludedFunctionNArguments *args) { (void)args; }

/* ---- top level (world space) ------------------------------------------- */

/* Does the ray org + t dir, t >= 0, pass within the sphere? (dir need not be
 * unit; the sphere is padded far above float rounding at build time.) */
static int ray_meets_sphere(vec3 org, vec3 dir, const sphere_bound *b)
{
    vec3 oc = v3_sub(b->center, org);
    double dd = v3_dot(dir, dir), along = v3_dot(oc, dir), oc2 = v3_dot(oc, oc);
    if (oc2 <= b->radius2)
        return 1; /* origin inside */
    if (along <= 0)
        return 0; /* sphere behind the origin */
    return oc2 - along * along / dd <= b->radius2;
}

/* A sphere about the object's box center holding the object (rest pose). */
static void object_sphere(const scene_object *o, vec3 *center, double *radius)
{
    if (o->kind != OBJECT_POINTS) {
        *center = o->sphere_center, *radius = o->sphere_radius;
        return;
    }
    const pointmodel *m = &o->model;
    vec3 c = v3_scale(v3_add(m->bounds.lo, m->bounds.hi), 0.5);
    double r2 = 0;
    for (size_t i = 0; i < m->count; i++) {
        const float *p = m->geom[i].center, *e = &m->extent[3 * i];
        vec3 far = v3(fabs(p[0] - c.x) + e[0], fabs(p[1] - c.y) + e[1], fabs(p[2] - c.z) + e[2]);
        double d2 = v3_dot(far, far); /* farthest corner of the splat's box */
        r2 = d2 > r2 ? d2 : r2;
    }
    *center = c, *radius = sqrt(r2);
}

/* Rigid motion keeps every point within the rest radius of the moving center,
 * so the sphere about the center's swept box bounds the object at all times. */
static sphere_bound swept_sphere(const scene_object *o, double t0, double t1)
{
    vec3 c;
    double r;
    object_sphere(o, &c, &r);
    r *= animation_max_scale(&o->anim, t0, t1);
    aabb path = animation_swept_bounds(&o->anim, (aabb){c, c}, t0, t1);
    vec3 half = v3_scale(v3_sub(path.hi, path.lo), 0.5);
    sphere_bound b;
    b.center = v3_add(path.lo, half);
    r = (r + sqrt(v3_dot(half, half))) * (1 + 1e-4) + 1e-4 * sqrt(v3_dot(b.center, b.center)) + 1e-6;
    b.radius2 = r * r;
    return b;
}

static void object_intersect(const struct RTCIntersectFunctionNArguments *args)
{
    if (!args->valid[0])
        return;
    trace_context *c = (trace_context *)args->context;
    struct RTCRayHit *rh = (struct RTCRayHit *)args->rayhit;
    const top_level *top = args->geometryUserPtr;
    unsigned obj = top->ids[args->primID];
    const accel *a = c->acc;
    /* the swept sphere is often much tighter than the swept box (a spinning
     * ball): skip the transform and the object's BVH when the ray misses it */
    if (!ray_meets_sphere(v3(rh->ray.org_x, rh->ray.org_y, rh->ray.org_z),
                          v3(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z), &a->swept_sphere[obj]))
        return;
    float saved[6] = {rh->ray.org_x, rh->ray.org_y, rh->ray.org_z,
                      rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z};
    c->xf = a->is_static[obj] ? a->rest[obj] : animation_at(&a->sc->objects[obj].anim, c->time);
    c->obj = obj;
    vec3 org = xform_inverse_point(&c->xf, v3(saved[0], saved[1], saved[2]));
    vec3 dir = xform_inverse_vector(&c->xf, v3(saved[3], saved[4], saved[5]));
    rh->ray.org_x = (float)org.x, rh->ray.org_y = (float)org.y, rh->ray.org_z = (float)org.z;
    rh->ray.dir_x = (float)dir.x, rh->ray.dir_y = (float)dir.y, rh->ray.dir_z = (float)dir.z;
    c->rtc.instID[0] = obj;
    rtcIntersect1(c->acc->object_scenes[obj], &c->rtc, rh);
    c->rtc.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rh->ray.org_x = saved[0], rh->ray.org_y = saved[1], rh->ray.org_z = saved[2];
    rh->ray.dir_x = saved[3], rh->ray.dir_y = saved[4], rh->ray.dir_z = saved[5];
}

static void object_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const top_level *top = args->geometryUserPtr;
    aabb b = top->acc->swept[top->ids[args->primID]];
    struct RTCBounds *r = args->bounds_o;
    r->lower_x = nextafterf((float)b.lo.x, -INFINITY), r->lower_y = nextafterf((float)b.lo.y, -INFINITY);
    r->lower_z = nextafterf((float)b.lo.z, -INFINITY);
    r->upper_x = nextafterf((float)b.hi.x, INFINITY), r->upper_y = nextafterf((float)b.hi.y, INFINITY);
    r->upper_z = nextafterf((float)b.hi.z, INFINITY);
}

/* ---- building ------------------------------------------------------------ */

static RTCScene user_scene(RTCDevice dev, unsigned nprims, void *user, RTCBoundsFunction bounds,
                           RTCIntersectFunctionN intersect)
{
    RTCScene scene = rtcNewScene(dev);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, nprims);
    rtcSetGeometryUserData(g, user);
    rtcSetGeometryBoundsFunction(g, bounds, user);
    rtcSetGeometryIntersectFunction(g, intersect);
    rtcSetGeometryOccludedFunction(g, no_occluded);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    return scene;
}

static void embree_error(void *user, enum RTCError code, const char *str)
{
    rr_error *e = user;
    if (!e->msg[0])
        snprintf(e->msg, sizeof e->msg, "Embree error %d: %s", (int)code, str ? str : "");
}

/* The top levels depend on the shutter interval (swept bounds, which
 * objects stand still); the objects' own BVHs do not. */
static void build_top_levels(accel *a)
{
    const scene *s = a->sc;
    for (int k = 0; k < 2; k++) {
        if (a->top[k].scene)
            rtcReleaseScene(a->top[k].scene);
        a->top[k].scene = NULL;
        a->top[k].count = 0;
    }
    for (int i = 0; i < s->nobjects; i++) {
        const scene_object *o = &s->objects[i];
        a->swept[i] = animation_swept_bounds(&o->anim, scene_object_bounds(o), s->shut.open, s->shut.close);
        a->swept_sphere[i] = swept_sphere(o, s->shut.open, s->shut.close);
        a->is_static[i] = a->reuse_static && animation_is_static(&o->anim);
        a->rest[i] = animation_at(&o->anim, s->shut.open);
        top_level *top = &a->top[a->is_static[i] ? TOP_STATIC : TOP_MOVING];
        top->ids[top->count++] = (unsigned)i;
    }
    for (int k = 0; k < 2; k++)
        if (a->top[k].count)
            a->top[k].scene = user_scene(a->device, a->top[k].count, &a->top[k], object_bounds_cb, object_intersect);
}

int accel_set_shutter(accel *a, rr_error *err)
{
    build_top_levels(a);
    if (a->build_error.msg[0])
        return rr_fail(err, "%s", a->build_error.msg);
    return 0;
}

int accel_build(const scene *s, double epsilon, double sigma, int reuse_static, accel **out, rr_error *err)
{
    accel *a = calloc(1, sizeof *a);
    if (!a)
        return rr_fail(err, "out of memory");
    a->sc = s;
    a->epsilon = (float)epsilon;
    a->sigma = sigma;
    a->device = rtcNewDevice(NULL);
    if (!a->device) {
        free(a);
        return rr_fail(err, "cannot create Embree device (error %d)", (int)rtcGetDeviceError(NULL));
    }
    rtcSetDeviceErrorFunction(a->device, embree_error, &a->build_error);
    size_t n = (size_t)s->nobjects;
    a->object_scenes = calloc(n, sizeof *a->object_scenes);
    a->swept = calloc(n, sizeof *a->swept);
    a->swept_sphere = calloc(n, sizeof *a->swept_sphere);
    a->rest = calloc(n, sizeof *a->rest);
    a->is_static = calloc(n, sizeof *a->is_static);
    for (int k = 0; k < 2; k++)
        a->top[k] = (top_level){NULL, calloc(n, sizeof(unsigned)), 0, a};
    if (!a->object_scenes || !a->swept || !a->swept_sphere || !a->rest || !a->is_static || !a->top[0].ids || !a->top[1].ids) {
        accel_free(a);
        return rr_fail(err, "out of memory");
    }
    for (int i = 0; i < s->nobjects; i++) {
        scene_object *o = &s->objects[i];
        int points = o->kind == OBJECT_POINTS;
        a->object_scenes[i] = user_scene(a->device, points ? (unsigned)o->model.count : 1u, o,
                                         points ? splat_bounds_cb : sphere_bounds_cb,
                                         points ? splats_intersect : sphere_intersect);
    }
    a->reuse_static = reuse_static;
    build_top_levels(a);
    if (a->build_error.msg[0]) {
        rr_fail(err, "%s", a->build_error.msg);
        accel_free(a);
        return -1;
    }
    *out = a;
    return 0;
}

void accel_free(accel *a)
{
    if (!a)
        return;
    for (int i = 0; a->object_scenes && i < a->sc->nobjects; i++)
        if (a->object_scenes[i])
            rtcReleaseScene(a->object_scenes[i]);
    for (int k = 0; k < 2; k++) {
        if (a->top[k].scene)
            rtcReleaseScene(a->top[k].scene);
        free(a->top[k].ids);
    }
    free(a->object_scenes);
    free(a->swept);
    free(a->swept_sphere);
    free(a->rest);
    free(a->is_static);
    rtcReleaseDevice(a->device);
    free(a);
}

/* Traverses one top-level scene, adding to kb (whose hits bound the ray). */
static int trace_top(const accel *a, int which, vec3 org, vec3 dir, double time, kbuffer *kb)
{
    if (!a->top[which].scene)
        return 0;
    trace_context c;
    rtcInitIntersectContext(&c.rtc);
    c.acc = a;
    c.time = time;
    c.obj = 0;
    c.kb = kb;
    c.accepted = 0;
    struct RTCRayHit rh;
    rh.ray.org_x = (float)org.x, rh.ray.org_y = (float)org.y, rh.ray.org_z = (float)org.z;
    rh.ray.dir_x = (float)dir.x, rh.ray.dir_y = (float)dir.y, rh.ray.dir_z = (float)dir.z;
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = kb->count ? kbuffer_cutoff(kb) : INFINITY;
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(a->top[which].scene, &c.rtc, &rh);
    for (int k = 0; k < kb->count; k++)
        if (kb->hits[k].weight < 0)
            kb->hits[k].weight = (float)splat_kernel_weight(kb->hits[k].r2, a->sigma);
    return c.accepted;
}

/* Slab test against a box grown by a relative margin far above float
 * rounding, so that it never rejects a ray Embree's float traversal of the
 * (outward-rounded) swept bounds would accept. */
static int ray_meets_box(vec3 org, vec3 dir, aabb b)
{
    double o[3] = {org.x, org.y, org.z}, d[3] = {dir.x, dir.y, dir.z};
    double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
    double tmin = 0.0, tmax = INFINITY;
    for (int k = 0; k < 3; k++) {
        double pad = 1e-4 * (hi[k] - lo[k] + fabs(lo[k]) + fabs(hi[k])) + 1e-6;
        double l = lo[k] - pad, h = hi[k] + pad;
        if (d[k] == 0.0) {
            if (o[k] < l || o[k] > h)
                return 0;
            continue;
        }
        double t1 = (l - o[k]) / d[k], t2 = (h - o[k]) / d[k];
        if (t1 > t2) {
            double tmp = t1;
            t1 = t2, t2 = tmp;
        }
        tmin = t1 > tmin ? t1 : tmin;
        tmax = t2 < tmax ? t2 : tmax;
        if (tmin > tmax)
            return 0;
    }
    return 1;
}

int accel_may_hit_moving(const accel *a, vec3 org, vec3 dir)
{
    const top_level *top = &a->top[TOP_MOVING];
    if (top->count > 64)
        return 1; /* many objects: testing them all per ray would cost more than it saves */
    for (unsigned i = 0; i < top->count; i++) {
        unsigned obj = top->ids[i];
        if (ray_meets_box(org, dir, a->swept[obj]) && ray_meets_sphere(org, dir, &a->swept_sphere[obj]))
            return 1;
    }
    return 0;
}

void accel_trace_static(const accel *a, vec3 org, vec3 dir, kbuffer *kb)
{
    kbuffer_reset(kb, a->epsilon);
    trace_top(a, TOP_STATIC, org, dir, 0.0, kb);
}

int accel_trace_moving(const accel *a, vec3 org, vec3 dir, double time, const kbuffer *static_hits, kbuffer *kb)
{
    kb->count = static_hits->count;
    kb->dropped = static_hits->dropped;
    kb->closest = static_hits->closest;
    kb->epsilon = static_hits->epsilon;
    memcpy(kb->hits, static_hits->hits, (size_t)static_hits->count * sizeof *kb->hits);
    return trace_top(a, TOP_MOVING, org, dir, time, kb);
}

void accel_trace(const accel *a, vec3 org, vec3 dir, double time, kbuffer *kb)
{
    kbuffer static_hits;
    accel_trace_static(a, org, dir, &static_hits);
    accel_trace_moving(a, org, dir, time, &static_hits, kb);
}
