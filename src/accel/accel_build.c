/* Building accel: one Embree user-geometry BVH per object (object space)
 * and the two top levels over the objects' swept bounds (accel.h). */
#include "accel/accel_internal.h"
#include "gaussians/gaussian_dynamic.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

RTCScene accel_user_scene(RTCDevice dev, unsigned nprims, void *user, RTCBoundsFunction bounds,
                           RTCIntersectFunctionN intersect, int compact)
{
    RTCScene scene = rtcNewScene(dev);
    if (compact) { /* a lower-quality, compact BVH: 110 -> 58 peak bytes per Gaussian, 0.94x the speed (make bench) */
        rtcSetSceneFlags(scene, RTC_SCENE_FLAG_COMPACT);
        rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_LOW);
    }
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, nprims);
    rtcSetGeometryUserData(g, user);
    rtcSetGeometryBoundsFunction(g, bounds, user);
    rtcSetGeometryIntersectFunction(g, intersect);
    rtcSetGeometryOccludedFunction(g, accel_no_occluded);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    return scene;
}

/* Packet traversal pays off while the lanes' rays stay within a few splat
 * sizes of each other: 8 mean splat extents (measured with make bench, the
 * rotation-speed series: wider groups win at slow motion but lose at fast
 * motion, see src/bench/BENCH.md). */
static double points_spread(const scene_object *o)
{
    double sum = 0;
    for (size_t i = 0; i < o->model.count; i++) {
        const float *e = &o->model.extent[3 * i];
        sum += fmax(e[0], fmax(e[1], e[2]));
    }
    return o->model.count ? 8.0 * sum / (double)o->model.count : 0.0;
}

/* A sphere is one primitive: its radius. */
static double sphere_spread(const scene_object *o) { return o->sphere_radius; }

/* How Embree holds each object kind as user geometry, by object_kind (what
 * the kind is: scene_object_row). A Gaussian model's row is empty: its
 * BVH is built with each shutter (build_gaussian_object). Every kind has
 * its row, empty or not (asserted): a kind added last without one does
 * not build (scene.h, object_kind). */
typedef struct {
    RTCBoundsFunction bounds;
    RTCIntersectFunctionN intersect;
    double (*coherent_spread)(const scene_object *o);
} accel_object_ops;

static const accel_object_ops accel_rows[] = {
    [OBJECT_POINTS] = {accel_splat_bounds_cb, accel_splats_intersect, points_spread},
    [OBJECT_SPHERE] = {accel_sphere_bounds_cb, accel_sphere_intersect, sphere_spread},
    [OBJECT_GAUSSIANS] = {NULL, NULL, NULL},
};
_Static_assert(sizeof accel_rows / sizeof *accel_rows == OBJECT_KIND_COUNT, "an object kind without its Embree row");

/* Embree reports each allocation before it happens and each release after
 * (negative bytes), from its build threads. */
static bool embree_memory(void *user, ssize_t bytes, bool post)
{
    (void)post;
    accel *a = user;
    long long now = __atomic_add_fetch(&a->embree_bytes, (long long)bytes, __ATOMIC_RELAXED);
    long long peak = __atomic_load_n(&a->embree_peak, __ATOMIC_RELAXED);
    while (now > peak && !__atomic_compare_exchange_n(&a->embree_peak, &peak, now, 1, __ATOMIC_RELAXED,
                                                      __ATOMIC_RELAXED))
        ;
    return true;
}

size_t accel_embree_peak_bytes(const accel *a)
{
    return (size_t)__atomic_load_n(&a->embree_peak, __ATOMIC_RELAXED);
}

static void embree_error(void *user, enum RTCError code, const char *str)
{
    accel *a = user;
    rr_error *e = &a->build_error;
    if (!a->building || e->msg[0])
        return;
    int obj = a->building_object;
    if (obj < 0) {
        snprintf(e->msg, sizeof e->msg, "Embree error %d: %s", (int)code, str ? str : "");
        return;
    }
    /* name what was being built: an out-of-memory message on a 10M-Gaussian
     * model must say which object and model ran out */
    const scene_object *o = &a->sc->objects[obj];
    size_t count = scene_object_row(o)->count(o);
    snprintf(e->msg, sizeof e->msg, "Embree error %d: %s (building the BVH of object '%s', %zu primitives%s%.200s)",
             (int)code, str ? str : "", o->name, count, o->model_file[0] ? ", from " : "", o->model_file);
}

/* The camera's view axis at mid-shutter in the space of a static,
 * uniformly scaled object (view depth there is a multiple of the world's),
 * and the most it turns from it over [open, close] (the camera motion's
 * turn rate over half the shutter); other objects, and cameras whose
 * keyframed rotation can jump (a step key, a cycle): no axis. */
static void gaussian_view_axis(const scene *s, const gaussian_footprint *f, const scene_object *o, double open,
                               double close, vec3 *axis, double *cone)
{
    *axis = v3(0, 0, 0), *cone = M_PI;
    int moves = scene_camera_moves(s);
    if (!animation_is_static(&o->anim) || f->min_scale != f->max_scale ||
        (moves && !animation_turns_continuously(&s->camera_motion)))
        return;
    camera_view v;
    scene_camera_view(s, 0.5 * (open + close), &v);
    /* view depth a . (r x) = (r^T a) . x, and r^T is r^-1 up to the uniform scale */
    *axis = v3_normalize(xform_inverse_vector(&f->at_open, v.axis[2]));
    double turn = moves ? animation_motion_bound(&s->camera_motion, open, close).turn : 0.0;
    *cone = turn * 0.5 * (close - open) * (1 + 1e-9) + 1e-9;
}

/* How far any point of a Gaussian object moves with the object over
 * [open, close] (world): every point stays in the swept sphere, so it
 * moves at most its diameter. The sphere of a dynamic model's is about the
 * box of its Gaussians' paths (paths_box): a mean can leave the model's
 * box at rest. */
static double object_travel(const scene_object *o, const aabb *paths_box, double open, double close)
{
    if (animation_is_static(&o->anim))
        return 0.0;
    if (!paths_box)
        return 2.0 * sqrt(accel_swept_sphere(o, open, close).radius2);
    vec3 c = v3_scale(v3_add(paths_box->lo, paths_box->hi), 0.5);
    double r = 0.5 * v3_len(v3_sub(paths_box->hi, paths_box->lo));
    return 2.0 * sqrt(accel_swept_sphere_about(&o->anim, c, r, open, close).radius2);
}

/* A Gaussian object's footprint parameters for the shutter [open, close]
 * (paths_box: a dynamic model's, object_travel). */
static void gaussian_footprint_for(accel *a, unsigned obj, double open, double close, const aabb *paths_box)
{
    const scene *s = a->sc;
    const scene_object *o = &s->objects[obj];
    gaussian_footprint *f = &a->footprint[obj];
    f->acc = a, f->obj = obj;
    f->at_open = animation_at(&o->anim, open);
    aabb cam = animation_swept_bounds(&s->camera_motion, (aabb){s->cam.position, s->cam.position}, open, close);
    f->camera_center = v3_scale(v3_add(cam.lo, cam.hi), 0.5);
    f->camera_radius = 0.5 * v3_len(v3_sub(cam.hi, cam.lo)) * (1 + 1e-6);
    f->travel = object_travel(o, paths_box, open, close);
    f->min_scale = animation_min_scale(&o->anim, open, close);
    f->max_scale = animation_max_scale(&o->anim, open, close);
    camera_view v;
    camera_view_rest(&s->cam, &v);
    f->focal = fmin(v.fx, v.fy);
    f->stretch = gaussian_view_stretch_of(gaussian_formation_of(&o->gaussians), &v);
    double largest = 0;
    for (size_t i = 0; i < 3 * o->gaussians.count; i++)
        largest = fmax(largest, o->gaussians.scale[i]);
    f->largest = largest * f->max_scale;
    gaussian_view_axis(s, f, o, open, close, &f->view_axis, &f->view_cone);
}

/* A build failure of object obj, named (the first one is kept). */
static void build_failed(accel *a, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void build_failed(accel *a, const char *fmt, ...)
{
    if (a->build_error.msg[0])
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(a->build_error.msg, sizeof a->build_error.msg, fmt, ap);
    va_end(ap);
}

/* A dynamic model's paths over [open, close] (gaussian_footprint.paths)
 * and their box; NULL (the error named) where a path's box is not finite
 * or passes RR_MAX_REACH, the reach of the static models' means
 * (beyond it Embree's float boxes and rays fail without a word), or
 * memory is short. */
static double *dynamic_paths(accel *a, const scene_object *o, double open, double close, aabb *box)
{
    const gaussian_model *m = &o->gaussians;
    double *paths = malloc(m->count * PATH_DOUBLES * sizeof *paths);
    if (!paths) {
        build_failed(a, "out of memory for the motion bounds of object '%s' (%zu Gaussians)", o->name, m->count);
        return NULL;
    }
    *box = aabb_empty();
    for (size_t i = 0; i < m->count; i++) {
        double *p = &paths[PATH_DOUBLES * i], reach = 0;
        int finite = !gaussian_dynamic_bounds(m, i, open, close, p, p + 3, p + 6);
        for (int k = 0; finite && k < 6; k++)
            reach = fmax(reach, fabs(p[k]));
        if (!finite || !(reach <= RR_MAX_REACH)) {
            char far[64] = "beyond double range";
            if (finite)
                snprintf(far, sizeof far, "%g", reach);
            build_failed(a, "%s: Gaussian %zu of object '%s' moves %s from the origin during the shutter [%g, %g]; "
                            "a Gaussian may only reach %g (RR_MAX_REACH)", o->model_file, i, o->name, far, open,
                         close, RR_MAX_REACH);
            free(paths);
            return NULL;
        }
        aabb_add_box(box, (aabb){v3(p[0], p[1], p[2]), v3(p[3], p[4], p[5])});
    }
    return paths;
}

/* A Gaussian object's BVH depends on the shutter (the filter's footprint
 * follows the camera's distance, a dynamic model's Gaussians their paths):
 * rebuilt for each one, and its swept bounds are those of its BVH's. */
static void build_gaussian_object(accel *a, unsigned obj, double open, double close)
{
    const scene_object *o = &a->sc->objects[obj];
    gaussian_footprint *f = &a->footprint[obj];
    if (a->object_scenes[obj])
        rtcReleaseScene(a->object_scenes[obj]);
    a->object_scenes[obj] = NULL;
    aabb paths_box;
    f->paths = o->gaussians.dynamic ? dynamic_paths(a, o, open, close, &paths_box) : NULL;
    if (o->gaussians.dynamic && !f->paths) { /* (named: accel_build or accel_retime fails) */
        a->swept[obj] = (aabb){v3(0, 0, 0), v3(0, 0, 0)};
        a->swept_sphere[obj] = (sphere_bound){v3(0, 0, 0), 0};
        return;
    }
    gaussian_footprint_for(a, obj, open, close, f->paths ? &paths_box : NULL);
    a->object_scenes[obj] = accel_user_scene(a->device, (unsigned)o->gaussians.count, f,
                                             f->paths ? accel_dynamic_gaussian_bounds_cb : accel_gaussian_bounds_cb,
                                             accel_gaussian_gather, 1);
    free(f->paths); /* (the bounds are taken while the BVH is built) */
    f->paths = NULL;
    struct RTCBounds rb;
    rtcGetSceneBounds(a->object_scenes[obj], &rb);
    aabb box = {v3(rb.lower_x, rb.lower_y, rb.lower_z), v3(rb.upper_x, rb.upper_y, rb.upper_z)};
    if (!o->gaussians.count || !(rb.lower_x <= rb.upper_x)) /* nothing can be seen: a point */
        box.lo = box.hi = v3(0, 0, 0);
    a->swept[obj] = animation_swept_bounds(&o->anim, box, open, close);
    vec3 c = v3_scale(v3_add(box.lo, box.hi), 0.5);
    a->swept_sphere[obj] = accel_swept_sphere_about(&o->anim, c, 0.5 * v3_len(v3_sub(box.hi, box.lo)), open, close);
    a->is_static[obj] = a->reuse_static && animation_is_static(&o->anim);
    a->rest[obj] = animation_at(&o->anim, open);
}

/* The top levels depend on the shutter interval (swept bounds, which
 * objects stand still): [open, close], the scene's exposure span; the
 * objects' own BVHs do not. */
static void build_top_levels(accel *a, double open, double close)
{
    const scene *s = a->sc;
    for (int k = 0; k < 2; k++) {
        if (a->top[k].scene)
            rtcReleaseScene(a->top[k].scene);
        a->top[k].scene = NULL;
        a->top[k].count = 0;
    }
    a->ngaussian = 0;
    for (int i = 0; i < s->nobjects && !a->build_error.msg[0]; i++) { /* (one failure is the error) */
        const scene_object *o = &s->objects[i];
        if (scene_object_row(o)->gaussians) {
            a->building_object = i;
            build_gaussian_object(a, (unsigned)i, open, close);
            a->building_object = -1;
            a->gaussian_ids[a->ngaussian++] = (unsigned)i;
            continue;
        }
        a->swept[i] = animation_swept_bounds(&o->anim, scene_object_bounds(o), open, close);
        a->swept_sphere[i] = accel_swept_sphere(o, open, close);
        a->is_static[i] = a->reuse_static && animation_is_static(&o->anim);
        a->rest[i] = animation_at(&o->anim, open);
        top_level *top = &a->top[a->is_static[i] ? TOP_STATIC : TOP_MOVING];
        top->ids[top->count++] = (unsigned)i;
    }
    for (int k = 0; k < 2 && !a->build_error.msg[0]; k++)
        if (a->top[k].count)
            a->top[k].scene = accel_user_scene(a->device, a->top[k].count, &a->top[k], accel_object_bounds_cb, accel_object_intersect, 0);
}

static double box_reach(aabb b)
{
    return fmax(fmax(fmax(fabs(b.lo.x), fabs(b.hi.x)), fmax(fabs(b.lo.y), fabs(b.hi.y))),
                fmax(fabs(b.lo.z), fabs(b.hi.z)));
}

/* Embree's float rays must stay valid (its ray.valid() asserts every origin
 * and direction component below about 1.8e18): a camera at 1e19, a velocity
 * of 1e19 or a shutter of +-1e300 once aborted the render inside Embree. The
 * object-space ray of object i starts at S^-1 R^-1 (camera - translation),
 * at most sqrt(3) (camera reach + object reach) / min_scale from its origin
 * in each component, and its direction is at most 1 / min_scale long. */
/* Swept bounds list every key time where a step may jump (animation.h):
 * past ANIMATION_MAX_KEY_TIMES they cannot be made conservative. */
static int check_key_times(const scene *s, const animation *anim, const char *who, double open, double close,
                           rr_error *err)
{
    double n = animation_key_times(anim, open, close);
    if (!(n <= ANIMATION_MAX_KEY_TIMES))
        return rr_fail(err, "%s: %s's keyframes give %g key times during the shutter [%g, %g] (cycling curves over "
                            "a long shutter), more than the %g its bounds can list: shorten the shutter",
                       s->path, who, n, open, close, ANIMATION_MAX_KEY_TIMES);
    return 0;
}

int accel_check_reach(const scene *s, const aabb *swept, double open, double close, rr_error *err)
{
    if (check_key_times(s, &s->camera_motion, "the camera", open, close, err) ||
        scene_check_trajectory_times(s, open, close, err))
        return -1;
    for (int i = 0; i < s->nobjects; i++) {
        char who[96];
        snprintf(who, sizeof who, "object '%s'", s->objects[i].name);
        if (check_key_times(s, &s->objects[i].anim, who, open, close, err))
            return -1;
    }
    aabb at_rest = {s->cam.position, s->cam.position};
    double camera = box_reach(animation_swept_bounds(&s->camera_motion, at_rest, open, close));
    if (!(camera <= RR_MAX_REACH))
        return rr_fail(err, "%s: the camera reaches %g world units from the origin during the shutter [%g, %g]; "
                            "rays can only be traced within %g", s->path, camera, open, close, RR_MAX_REACH);
    for (int i = 0; i < s->nobjects; i++) {
        const scene_object *o = &s->objects[i];
        double object = box_reach(swept[i]), min_scale = animation_min_scale(&o->anim, open, close);
        double ray = sqrt(3.0) * fmax(1.0, camera + object) / min_scale;
        if (!(object <= RR_MAX_REACH) || !(ray <= RR_MAX_REACH))
            return rr_fail(err, "%s: object '%s' reaches %g world units (smallest scale %g) during the shutter "
                                "[%g, %g]; rays can only be traced within %g",
                           s->path, o->name, object, min_scale, open, close, RR_MAX_REACH);
    }
    return 0;
}

/* The top levels (and Gaussian objects' BVHs) for the shutter of a->sc:
 * the span of every line's exposure (scene_exposure_span), its reach
 * checked. */
static int build_for_shutter(accel *a, rr_error *err)
{
    double open, close;
    scene_exposure_span(a->sc, &open, &close);
    a->building = 1;
    build_top_levels(a, open, close);
    a->building = 0;
    if (a->build_error.msg[0])
        return rr_fail(err, "%s", a->build_error.msg);
    return accel_check_reach(a->sc, a->swept, open, close, err);
}

int accel_retime(accel *a, const scene *fs, rr_error *err)
{
    RR_DCHECK(fs->objects == a->sc->objects && fs->nobjects == a->sc->nobjects); /* the BVHs are kept */
    a->sc = fs;
    return build_for_shutter(a, err);
}

const scene *accel_scene(const accel *a) { return a->sc; }

int accel_build(const scene *s, const accel_settings *set, accel **out, rr_error *err)
{
    accel *a = calloc(1, sizeof *a);
    if (!a)
        return rr_fail(err, "out of memory");
    a->sc = s;
    a->building_object = -1;
    a->epsilon = (float)set->epsilon;
    a->sigma = set->sigma;
    a->building = 1;
    a->device = rtcNewDevice(NULL);
    if (!a->device) {
        free(a);
        return rr_fail(err, "cannot create Embree device (error %d)", (int)rtcGetDeviceError(NULL));
    }
    rtcSetDeviceErrorFunction(a->device, embree_error, a);
    rtcSetDeviceMemoryMonitorFunction(a->device, embree_memory, a);
    size_t n = (size_t)s->nobjects;
    a->object_scenes = calloc(n, sizeof *a->object_scenes);
    a->swept = calloc(n, sizeof *a->swept);
    a->swept_sphere = calloc(n, sizeof *a->swept_sphere);
    a->coherent_spread = calloc(n, sizeof *a->coherent_spread);
    a->rest = calloc(n, sizeof *a->rest);
    a->is_static = calloc(n, sizeof *a->is_static);
    a->gaussian_ids = calloc(n, sizeof *a->gaussian_ids);
    a->footprint = calloc(n, sizeof *a->footprint);
    a->models = calloc(n, sizeof *a->models);
    for (int k = 0; k < 2; k++)
        a->top[k] = (top_level){NULL, calloc(n, sizeof(unsigned)), 0, a};
    if (!a->object_scenes || !a->swept || !a->swept_sphere || !a->coherent_spread || !a->rest || !a->is_static || !a->gaussian_ids ||
        !a->footprint || !a->models || !a->top[0].ids || !a->top[1].ids) {
        accel_free(a);
        return rr_fail(err, "out of memory");
    }
    for (int i = 0; i < s->nobjects && !a->build_error.msg[0]; i++) {
        scene_object *o = &s->objects[i];
        const scene_object_ops *kind = scene_object_row(o);
        if (kind->gaussians) { /* built with the shutter (build_gaussian_object) */
            a->models[i] = &o->gaussians;
            continue;
        }
        RR_DCHECK((unsigned)o->kind < OBJECT_KIND_COUNT);
        const accel_object_ops *row = &accel_rows[o->kind];
        RR_DCHECK(row->bounds);
        a->coherent_spread[i] = row->coherent_spread(o);
        a->building_object = i;
        a->object_scenes[i] = accel_user_scene(a->device, (unsigned)kind->count(o), o, row->bounds, row->intersect, 0);
        a->building_object = -1;
    }
    a->reuse_static = set->reuse_static;
    a->building = 0;
    if (a->build_error.msg[0] || build_for_shutter(a, err)) {
        if (a->build_error.msg[0])
            rr_fail(err, "%s", a->build_error.msg);
        accel_free(a);
        return -1;
    }
    *out = a;
    return 0;
}

/* Releases the Embree scenes and device, unless a build failed: Embree's
 * scene destructor after a commit that ran out of memory cancels the
 * commit's TBB task group, which allocates again, and the std::bad_alloc
 * (or TBB's missing_wait) it throws ends the process in std::terminate
 * (SIGABRT under ulimit -v 232-242 MB, issue 56.6). The failed build's
 * scenes are left to the process's exit, which follows such an error. */
static void release_embree(accel *a)
{
    if (a->build_error.msg[0])
        return;
    for (int i = 0; a->object_scenes && i < a->sc->nobjects; i++)
        if (a->object_scenes[i])
            rtcReleaseScene(a->object_scenes[i]);
    for (int k = 0; k < 2; k++)
        if (a->top[k].scene)
            rtcReleaseScene(a->top[k].scene);
    rtcReleaseDevice(a->device);
}

void accel_free(accel *a)
{
    if (!a)
        return;
    release_embree(a);
    for (int k = 0; k < 2; k++)
        free(a->top[k].ids);
    free(a->object_scenes);
    free(a->swept);
    free(a->swept_sphere);
    free(a->coherent_spread);
    free(a->rest);
    free(a->is_static);
    free(a->gaussian_ids);
    free(a->footprint);
    free(a->models);
    free(a);
}

double accel_epsilon(const accel *a) { return a->epsilon; }
double accel_sigma(const accel *a) { return a->sigma; }
