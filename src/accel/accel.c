#include "accel/accel.h"

#include <embree3/rtcore.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/accel_internal.h"
#include "core/interval.h"
#include "gaussians/gaussian_dynamic.h"
#include "surfels/hitrules.h"

static float *lane_f(void *rayhit, unsigned n, unsigned field, unsigned i)
{
    return &((float *)rayhit)[field * n + i];
}

static unsigned *lane_u(void *rayhit, unsigned n, unsigned field, unsigned i)
{
    return &((unsigned *)rayhit)[field * n + i];
}

/* ---- object-level callbacks (object space) ----------------------------- */

/* Which of our rays a lane of the callback's packet is (its ray ID), and
 * whether it is one of ours at all. Embree may split a packet (on an AVX2
 * machine rtcIntersect16 runs as two 8-wide halves: a callback's lane 0
 * can be our ray 8), and there it has been seen to call the callback for
 * lanes the valid mask of rtcIntersect16 switched off (ray 12 of a
 * 10-ray packet, with tfar 0): the lane index alone picked another ray's
 * k-buffer and transform, and such a lane must be ignored. */
static int live_lane(const trace_context *c, const struct RTCIntersectFunctionNArguments *args, unsigned lane,
                     unsigned *id)
{
    *id = *lane_u(args->rayhit, args->N, F_ID, lane); /* init_rayhit1 gives a single ray ID 0 */
    return args->valid[lane] && *id < c->lanes;
}

static void accept_hit(trace_context *c, const struct RTCIntersectFunctionNArguments *args, unsigned lane,
                       unsigned id, const float dir[3], float t, float weight, float r2, vec3 normal,
                       const float color[3])
{
    vec3 wn = xform_normal(c->xf[id], normal_facing_eye(normal, v3(dir[0], dir[1], dir[2])));
    surface_hit h = {t, c->obj, args->primID, weight, r2, {color[0], color[1], color[2]},
                     {(float)wn.x, (float)wn.y, (float)wn.z}};
    kbuffer_insert(c->kb[id], &h);
    c->accepted[id]++;
    *lane_f(args->rayhit, args->N, F_TFAR, lane) = kbuffer_cutoff(c->kb[id]);
    *lane_u(args->rayhit, args->N, F_GEOM, lane) = args->geomID;
    *lane_u(args->rayhit, args->N, F_PRIM, lane) = args->primID;
}

/* The object-space ray of one lane, from Embree's SOA layout. */
static void load_lane(const struct RTCIntersectFunctionNArguments *args, unsigned lane, float org[3],
                      float dir[3], float *tnear, float *tfar)
{
    for (unsigned k = 0; k < 3; k++) {
        org[k] = *lane_f(args->rayhit, args->N, F_ORG + k, lane);
        dir[k] = *lane_f(args->rayhit, args->N, F_DIR + k, lane);
    }
    *tnear = *lane_f(args->rayhit, args->N, F_TNEAR, lane);
    *tfar = *lane_f(args->rayhit, args->N, F_TFAR, lane);
}

void accel_splats_intersect(const struct RTCIntersectFunctionNArguments *args)
{
    trace_context *c = (trace_context *)args->context;
    const scene_object *o = args->geometryUserPtr;
    const splat_geom *g = &o->model.geom[args->primID];
    for (unsigned lane = 0, id; lane < args->N; lane++) {
        float org[3], dir[3], tnear, tfar, t, r2;
        if (!live_lane(c, args, lane, &id))
            continue;
        load_lane(args, lane, org, dir, &tnear, &tfar);
        if (!splat_intersect(g, org, dir, tnear, tfar, &t, &r2))
            continue;
        const float *n = pointmodel_normal(&o->model, args->primID);
        /* weight -1: computed after the traversal, if the hit is still in the buffer */
        accept_hit(c, args, lane, id, dir, t, -1.0f, r2, v3(n[0], n[1], n[2]), pointmodel_color(&o->model, args->primID));
    }
}

/* The visible crossing of an opaque sphere: the nearer root in [tnear, tfar]. */
static void sphere_intersect_lane(trace_context *c, const struct RTCIntersectFunctionNArguments *args, unsigned lane,
                                  unsigned id)
{
    const scene_object *o = args->geometryUserPtr;
    float fo[3], fd[3], tnear, tfar;
    load_lane(args, lane, fo, fd, &tnear, &tfar);
    vec3 org = v3(fo[0], fo[1], fo[2]), dir = v3(fd[0], fd[1], fd[2]);
    sphere_crossing sc = sphere_cross(org, dir, o->sphere_center, o->sphere_radius);
    if (sc.disc < 0)
        return;
    double depth[2] = {(float)sc.root[0], (float)sc.root[1]}; /* compared as the float ray's t */
    int k = sphere_visible_root(depth, tnear, tfar);
    if (k < 0)
        return;
    vec3 p = v3_add(v3_sub(org, o->sphere_center), v3_scale(dir, sc.root[k]));
    const float col[3] = {(float)o->sphere_color.x, (float)o->sphere_color.y, (float)o->sphere_color.z};
    accept_hit(c, args, lane, id, fd, (float)depth[k], (float)hit_weight(1, 0.0, 0.0), 0.0f,
               v3_scale(p, 1.0 / o->sphere_radius), col);
}

void accel_sphere_intersect(const struct RTCIntersectFunctionNArguments *args)
{
    trace_context *c = (trace_context *)args->context;
    for (unsigned lane = 0, id; lane < args->N; lane++)
        if (live_lane(c, args, lane, &id))
            sphere_intersect_lane(c, args, lane, id);
}

/* b rounded outward into Embree's float box, so the box holds b. */
static void embree_bounds(aabb b, struct RTCBounds *r)
{
    float lo[3], hi[3];
    aabb_round_out(b, lo, hi);
    r->lower_x = lo[0], r->lower_y = lo[1], r->lower_z = lo[2];
    r->upper_x = hi[0], r->upper_y = hi[1], r->upper_z = hi[2];
}

void accel_splat_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const scene_object *o = args->geometryUserPtr;
    const float *c = o->model.geom[args->primID].center;
    const float *e = &o->model.extent[3 * args->primID];
    /* the splat's box with room for float traversal, rounded outward
     * (core/interval.h), so float rounding never clips a splat */
    aabb b;
    double lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        interval box = interval_widen(interval_around(c[k], e[k]), interval_float_room(e[k], c[k]));
        lo[k] = box.lo, hi[k] = box.hi;
    }
    b.lo = v3(lo[0], lo[1], lo[2]), b.hi = v3(hi[0], hi[1], hi[2]);
    embree_bounds(b, args->bounds_o);
}

void accel_sphere_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const scene_object *o = args->geometryUserPtr;
    /* rounded outward as every other box (a cast to the nearest float put
     * a 1 mm sphere's box at x = 1000 23 um inside it) */
    embree_bounds(scene_object_bounds(o), args->bounds_o);
}

/* We never call rtcOccluded; the callback exists so the geometry is complete. */
void accel_no_occluded(const struct RTCOccludedFunctionNArguments *args) { (void)args; }

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

int accel_ray_meets_swept_sphere(const accel *a, unsigned obj, vec3 org, vec3 dir)
{
    return ray_meets_sphere(org, dir, &a->swept_sphere[obj]);
}

/* Rigid motion keeps every point within the rest radius of the moving center
 * (the object's rest sphere: its kind's row), so the sphere about the
 * center's swept box bounds the object at all times. */
sphere_bound accel_swept_sphere(const scene_object *o, double t0, double t1)
{
    vec3 c;
    double r;
    scene_object_row(o)->rest_sphere(o, &c, &r);
    return accel_swept_sphere_about(&o->anim, c, r, t0, t1);
}

sphere_bound accel_swept_sphere_about(const animation *anim, vec3 c, double r, double t0, double t1)
{
    r *= animation_max_scale(anim, t0, t1);
    aabb path = animation_swept_bounds(anim, (aabb){c, c}, t0, t1);
    vec3 half = v3_scale(v3_sub(path.hi, path.lo), 0.5);
    sphere_bound b;
    b.center = v3_add(path.lo, half);
    r = (r + sqrt(v3_dot(half, half))) * (1 + 1e-4) + 1e-4 * sqrt(v3_dot(b.center, b.center)) + 1e-6;
    b.radius2 = r * r;
    return b;
}

/* Only ever traversed with rtcIntersect1, so N = 1. */
void accel_object_intersect(const struct RTCIntersectFunctionNArguments *args)
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
    xform xf = accel_object_at(a, obj, c->time);
    c->xf[0] = &xf;
    c->obj = obj;
    /* from the double world ray, as trace_object_times does: the
     * object-space rays of both paths are the same to the bit */
    vec3 org = xform_inverse_point(&xf, c->world_org);
    vec3 dir = xform_inverse_vector(&xf, c->world_dir);
    rh->ray.org_x = (float)org.x, rh->ray.org_y = (float)org.y, rh->ray.org_z = (float)org.z;
    rh->ray.dir_x = (float)dir.x, rh->ray.dir_y = (float)dir.y, rh->ray.dir_z = (float)dir.z;
    c->rtc.instID[0] = obj;
    rtcIntersect1(c->acc->object_scenes[obj], &c->rtc, rh);
    c->rtc.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rh->ray.org_x = saved[0], rh->ray.org_y = saved[1], rh->ray.org_z = saved[2];
    rh->ray.dir_x = saved[3], rh->ray.dir_y = saved[4], rh->ray.dir_z = saved[5];
}

void accel_object_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const top_level *top = args->geometryUserPtr;
    aabb b = top->acc->swept[top->ids[args->primID]];
    struct RTCBounds *r = args->bounds_o;
    embree_bounds(b, r);
}

/* The kernel weights of the hits that stayed in the buffer (deferred: most
 * hits offered during a traversal are later pushed out by closer ones). */
static void finish_weights(const accel *a, kbuffer *kb)
{
    for (int k = 0; k < kb->count; k++)
        if (kb->hits[k].weight < 0)
            kb->hits[k].weight = (float)hit_weight(0, kb->hits[k].r2, a->sigma); /* splats: spheres have 1 */
}

/* A ray from 0 to tfar (no hit yet), as Embree takes it. */
static void init_rayhit1(struct RTCRayHit *rh, vec3 o, vec3 d, float tfar)
{
    rh->ray.org_x = (float)o.x, rh->ray.org_y = (float)o.y, rh->ray.org_z = (float)o.z;
    rh->ray.dir_x = (float)d.x, rh->ray.dir_y = (float)d.y, rh->ray.dir_z = (float)d.z;
    rh->ray.tnear = 0.0f;
    rh->ray.tfar = tfar;
    rh->ray.time = 0.0f;
    rh->ray.mask = 0xFFFFFFFFu;
    rh->ray.id = 0;
    rh->ray.flags = 0;
    rh->hit.geomID = rh->hit.primID = rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

static float start_tfar(const kbuffer *kb)
{
    return kb->count ? kbuffer_cutoff(kb) : INFINITY;
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
    c.world_org = org, c.world_dir = dir;
    c.obj = 0;
    c.lanes = 1;
    c.kb[0] = kb;
    c.accepted[0] = 0;
    struct RTCRayHit rh;
    init_rayhit1(&rh, org, dir, start_tfar(kb));
    rtcIntersect1(a->top[which].scene, &c.rtc, &rh);
    finish_weights(a, kb);
    return c.accepted[0];
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
        interval slab = interval_widen_rel(interval_make(lo[k], hi[k]), 1e-4, 1e-6);
        double l = slab.lo, h = slab.hi;
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

/* Does the world ray meet the object's swept box and swept sphere? */
static int ray_meets_swept(const accel *a, unsigned obj, vec3 org, vec3 dir)
{
    return ray_meets_box(org, dir, a->swept[obj]) && ray_meets_sphere(org, dir, &a->swept_sphere[obj]);
}

static int may_hit_moving(const accel *a, vec3 org, vec3 dir)
{
    const top_level *top = &a->top[TOP_MOVING];
    if (top->count > TOP_LEVEL_OWN_BVH)
        return 1; /* many objects: testing them all per ray would cost more than it saves */
    for (unsigned i = 0; i < top->count; i++) {
        if (ray_meets_swept(a, top->ids[i], org, dir))
            return 1;
    }
    return 0;
}

static void trace_static(const accel *a, vec3 org, vec3 dir, kbuffer *kb)
{
    kbuffer_reset(kb, a->epsilon);
    trace_top(a, TOP_STATIC, org, dir, 0.0, kb);
}

static void copy_kbuffer(kbuffer *dst, const kbuffer *src)
{
    dst->count = src->count;
    dst->dropped_t = src->dropped_t;
    dst->closest = src->closest;
    dst->epsilon = src->epsilon;
    memcpy(dst->hits, src->hits, (size_t)src->count * sizeof *dst->hits);
}

static int trace_moving(const accel *a, vec3 org, vec3 dir, double time, const kbuffer *static_hits, kbuffer *kb)
{
    copy_kbuffer(kb, static_hits);
    return trace_top(a, TOP_MOVING, org, dir, time, kb);
}

/* One time's ray in an object's space. */
typedef struct {
    xform xf;
    vec3 org, dir;
} lane_ray;

/* Lanes [0, m) of c against object obj in one packet traversal of the
 * smallest width that holds them: every node and splat fetched serves all
 * the lanes. */
static void trace_packet(const accel *a, unsigned obj, const lane_ray *rays, int m, trace_context *c)
{
    unsigned width = m <= 4 ? 4 : m <= 8 ? 8 : 16;
    float soa[F_COUNT * 16] __attribute__((aligned(64)));
    int valid[16] __attribute__((aligned(64)));
    for (unsigned i = 0; i < width; i++) {
        int on = (int)i < m;
        valid[i] = on ? -1 : 0;
        vec3 o = on ? rays[i].org : v3(0, 0, 0), d = on ? rays[i].dir : v3(0, 0, 1);
        const float ray[F_FLAGS + 1] = {(float)o.x, (float)o.y, (float)o.z, 0.0f, (float)d.x, (float)d.y, (float)d.z,
                                        0.0f, on ? start_tfar(c->kb[i]) : 0.0f};
        for (unsigned f = 0; f < F_MASK; f++)
            *lane_f(soa, width, f, i) = ray[f];
        *lane_u(soa, width, F_MASK, i) = 0xFFFFFFFFu;
        *lane_u(soa, width, F_ID, i) = i;
        *lane_u(soa, width, F_FLAGS, i) = 0;
        for (unsigned f = F_PRIM; f <= F_INST; f++)
            *lane_u(soa, width, f, i) = RTC_INVALID_GEOMETRY_ID;
    }
    RTCScene scene = a->object_scenes[obj];
    if (width == 4)
        rtcIntersect4(valid, scene, &c->rtc, (struct RTCRayHit4 *)soa);
    else if (width == 8)
        rtcIntersect8(valid, scene, &c->rtc, (struct RTCRayHit8 *)soa);
    else
        rtcIntersect16(valid, scene, &c->rtc, (struct RTCRayHit16 *)soa);
}

static void trace_single(const accel *a, unsigned obj, const lane_ray *ray, trace_context *c)
{
    struct RTCRayHit rh;
    init_rayhit1(&rh, ray->org, ray->dir, start_tfar(c->kb[0]));
    rtcIntersect1(a->object_scenes[obj], &c->rtc, &rh);
}

/* Packets of 2 or 3 coherent rays measured slower than tracing them alone
 * (make bench, rotation-speed series). */
enum { MIN_PACKET = 4 };

/* Lanes rays[0..m) (one traced alone, more as a packet), adding to kbs. */
static void trace_lanes(const accel *a, unsigned obj, const lane_ray *rays, int m, kbuffer **kbs, int *accepted,
                        trace_context *c)
{
    c->lanes = (unsigned)m;
    for (int k = 0; k < m; k++) {
        c->xf[k] = &rays[k].xf;
        c->kb[k] = kbs[k];
        c->accepted[k] = 0;
    }
    if (m > 1)
        trace_packet(a, obj, rays, m, c);
    else
        trace_single(a, obj, rays, c);
    for (int k = 0; k < m; k++)
        accepted[k] += c->accepted[k];
}

/* How far apart lanes a and b are over the stretch [tmin, tmax] of the
 * world ray that can meet the object (|do + t dd| is convex in t: its
 * maximum is at an end). */
static double lane_spread(const lane_ray *a, const lane_ray *b, double tmin, double tmax)
{
    vec3 dorg = v3_sub(a->org, b->org), ddir = v3_sub(a->dir, b->dir);
    return fmax(v3_len(v3_add(dorg, v3_scale(ddir, tmin))), v3_len(v3_add(dorg, v3_scale(ddir, tmax))));
}

/* One moving object against all n times: lanes are grouped into packets of
 * nearby object-space rays (which share BVH nodes and splats); a lane far
 * from its neighbours (fast motion) is traced alone, as packets of
 * divergent rays cost more than single rays. */
static void trace_object_times(const accel *a, unsigned obj, vec3 org, vec3 dir, const double *times, int n,
                               kbuffer **kbs, int *accepted)
{
    const animation *anim = &a->sc->objects[obj].anim;
    lane_ray rays[ACCEL_PACKET];
    for (int i = 0; i < n; i++) {
        rays[i].xf = animation_at(anim, times[i]);
        rays[i].org = xform_inverse_point(&rays[i].xf, org);
        rays[i].dir = xform_inverse_vector(&rays[i].xf, dir);
    }
    const sphere_bound *b = &a->swept_sphere[obj];
    double dist = v3_len(v3_sub(b->center, org)), radius = sqrt(b->radius2);
    double tmin = fmax(dist - radius, 0.0), tmax = dist + radius;
    trace_context c;
    rtcInitIntersectContext(&c.rtc);
    c.acc = a;
    c.obj = obj;
    for (int first = 0, end; first < n; first = end) {
        for (end = first + 1; end < n; end++)
            if (lane_spread(&rays[first], &rays[end], tmin, tmax) > a->coherent_spread[obj])
                break;
        if (end - first >= MIN_PACKET)
            trace_lanes(a, obj, &rays[first], end - first, kbs + first, accepted + first, &c);
        else
            for (int k = first; k < end; k++)
                trace_lanes(a, obj, &rays[k], 1, kbs + k, accepted + k, &c);
    }
}

static void trace_moving_times(const accel *a, vec3 org, vec3 dir, const double *times, int n,
                               const kbuffer *static_hits, kbuffer *kbs, int *hit_moving)
{
    const top_level *top = &a->top[TOP_MOVING];
    /* every time on its own (--no-static-reuse), or many moving objects,
     * which the top-level BVH picks better: one ray per time */
    if (!a->reuse_static || top->count > TOP_LEVEL_OWN_BVH) {
        for (int i = 0; i < n; i++)
            hit_moving[i] = trace_moving(a, org, dir, times[i], static_hits, &kbs[i]) > 0;
        return;
    }
    kbuffer *kb[ACCEL_PACKET];
    for (int i = 0; i < n; i++) {
        copy_kbuffer(&kbs[i], static_hits);
        kb[i] = &kbs[i];
        hit_moving[i] = 0;
    }
    for (unsigned k = 0; k < top->count; k++) {
        if (ray_meets_swept(a, top->ids[k], org, dir))
            trace_object_times(a, top->ids[k], org, dir, times, n, kb, hit_moving);
    }
    for (int i = 0; i < n; i++) {
        finish_weights(a, &kbs[i]);
        hit_moving[i] = hit_moving[i] > 0;
    }
}

void accel_trace(const accel *a, vec3 org, vec3 dir, double time, kbuffer *kb)
{
    kbuffer static_hits;
    trace_static(a, org, dir, &static_hits);
    trace_moving(a, org, dir, time, &static_hits, kb);
}

void accel_ray_begin(const accel *a, vec3 org, vec3 dir, accel_ray *r)
{
    r->org = org, r->dir = dir;
    trace_static(a, org, dir, &r->static_hits);
    r->may_hit_moving = may_hit_moving(a, org, dir);
}

void accel_ray_trace_times(const accel *a, const accel_ray *r, const double *times, int n, kbuffer *kbs,
                           const kbuffer **result)
{
    int hit_moving[ACCEL_PACKET] = {0};
    if (r->may_hit_moving)
        trace_moving_times(a, r->org, r->dir, times, n, &r->static_hits, kbs, hit_moving);
    for (int i = 0; i < n; i++)
        result[i] = hit_moving[i] ? &kbs[i] : &r->static_hits;
}

/* ---- Gaussian objects ------------------------------------------------ */

/* Per-traversal state of a candidate query: RTCIntersectContext first
 * (Embree hands this pointer to the callbacks). */
typedef struct {
    struct RTCIntersectContext rtc;
    accel_candidate_fn *found;
    void *user;
} candidate_context;

/* What a Gaussian's bounds hold of the camera, the farthest it gets from
 * the Gaussian being `distance` (world): in object units, the focal length
 * shrunk by the scale's spread. */
static gaussian_view_bound footprint_view(const gaussian_footprint *f, double distance)
{
    gaussian_view_bound view = {distance / f->min_scale, f->focal * f->min_scale / f->max_scale, f->stretch,
                                gaussian_filter_near(f->min_scale, f->max_scale), f->view_axis, f->view_cone};
    return view;
}

static void write_gaussian_bounds(aabb b, struct RTCBounds *r)
{
    embree_bounds(b, r);
}

void accel_gaussian_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const gaussian_footprint *f = args->geometryUserPtr;
    const gaussian_model *m = f->acc->models[f->obj];
    const float *mu = &m->mean[3 * args->primID];
    /* the farthest the camera gets from the Gaussian (world) */
    vec3 at_open = xform_point(&f->at_open, v3(mu[0], mu[1], mu[2]));
    double distance = v3_len(v3_sub(at_open, f->camera_center)) + f->camera_radius + f->travel;
    gaussian_view_bound view = footprint_view(f, distance);
    write_gaussian_bounds(gaussian_view_bounds(m, args->primID, &view), args->bounds_o);
}

/* A Gaussian that moves (gaussian_dynamic.h), over every time of the
 * shutter the BVH is built for (accel_build.c gives each line of a rolling
 * shutter its time within it): its mean stays in the box of its path and
 * its opacity below the bound (gaussian_dynamic_bounds: proved, not
 * sampled), so every instant's reach, kernel and screen footprint, lies in
 * that box grown by the reach of a Gaussian of its largest scale in every
 * direction at the largest opacity (gaussian_dynamic_reach_bounds: the
 * rotation turns, and a turned scale reaches no farther than the largest).
 * The camera's distance is the farthest corner's: the box placed by the
 * object's transform at the open is a parallelepiped, and the distance
 * from a point, convex, is largest at a corner; the object's own motion
 * and the camera's are added as for a static Gaussian (f->travel holds the
 * paths' box). A fast mover is listed wherever it is at any time. */
void accel_dynamic_gaussian_bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const gaussian_footprint *f = args->geometryUserPtr;
    const gaussian_model *m = f->acc->models[f->obj];
    const double *path = &f->paths[PATH_DOUBLES * args->primID];
    double farthest = 0;
    for (int c = 0; c < 8; c++) {
        vec3 corner = v3(path[c & 1 ? 3 : 0], path[c & 2 ? 4 : 1], path[c & 4 ? 5 : 2]);
        farthest = fmax(farthest, v3_len(v3_sub(xform_point(&f->at_open, corner), f->camera_center)));
    }
    gaussian_view_bound view = footprint_view(f, farthest + f->camera_radius + f->travel);
    write_gaussian_bounds(gaussian_dynamic_reach_bounds(m, args->primID, path, path + 3, path[6], &view),
                          args->bounds_o);
}

/* Every Gaussian whose box the ray passes is handed on: the ray is never
 * shortened, so the traversal finds them all. */
void accel_gaussian_gather(const struct RTCIntersectFunctionNArguments *args)
{
    if (!args->valid[0])
        return;
    candidate_context *c = (candidate_context *)args->context;
    c->found(c->user, args->primID);
}

void accel_gaussian_candidates(const accel *a, unsigned obj, vec3 org, vec3 dir, double t0, double t1,
                               accel_candidate_fn *found, void *user)
{
    candidate_context c;
    rtcInitIntersectContext(&c.rtc);
    c.found = found, c.user = user;
    struct RTCRayHit rh;
    /* Embree's float ray holds all of [t0, t1] */
    init_rayhit1(&rh, org, dir, rr_float_above(t1));
    rh.ray.tnear = fmaxf(0.0f, rr_float_below(t0));
    rtcIntersect1(a->object_scenes[obj], &c.rtc, &rh);
}

int accel_has_gaussians(const accel *a) { return a->ngaussian > 0; }

const unsigned *accel_gaussian_objects(const accel *a, unsigned *count)
{
    *count = a->ngaussian;
    return a->gaussian_ids;
}

const gaussian_model *const *accel_gaussian_models(const accel *a) { return a->models; }

double accel_gaussian_largest_scale(const accel *a, unsigned obj) { return a->footprint[obj].largest; }

int accel_ray_meets_object(const accel *a, unsigned obj, vec3 org, vec3 dir)
{
    return ray_meets_swept(a, obj, org, dir);
}

xform accel_object_at(const accel *a, unsigned obj, double time)
{
    return a->is_static[obj] ? a->rest[obj] : animation_at(&a->sc->objects[obj].anim, time);
}
