/* Ray queries against the scene through Embree 3 (thesis sec. 4.5 step c).
 *
 * Each object is one Embree user geometry in its own scene (own BVH), in
 * object space. A top-level scene holds one user primitive per object whose
 * bounds are the object's bounds swept over the shutter; its intersect
 * callback transforms the ray by the exact inverse of the object's
 * transform at the ray's time (thesis B.2.3 TransformRay) and traverses the
 * object's BVH with the same context. Rigid transforms keep the ray
 * parameter equal to world distance.
 *
 * Epsilon-blending happens in the same single traversal: every accepted hit
 * goes into a small k-buffer kept in the per-ray context, and the ray's tfar
 * shrinks to closest + epsilon, so the final buffer holds exactly the hits
 * with t <= t_closest + epsilon, independent of traversal order. */
#ifndef RR_ACCEL_H
#define RR_ACCEL_H

#include "gaussians/gaussian.h"
#include "surfels/kbuffer.h"
#include "scene/scene.h"

typedef struct accel accel;

typedef struct {
    double epsilon;     /* blending distance (world units) */
    double sigma;       /* kernel sigma (splat radii) */
    int reuse_static;   /* 0: every object is treated as moving and every time
                           traced on its own, one ray through the top level (no
                           packets of a ray's times): the same images, slower;
                           for benchmarks and tests */
} accel_settings;

/* Builds the BVHs for the scene s, whose shutter s->shut (its one owner)
 * the swept bounds cover: every line's exposure, scene_exposure_span. s
 * must outlive the accel and not change under it: the accel is the way
 * a render is handed its scene (render_image), so no render can be for a
 * shutter its swept bounds were not built for. */
int accel_build(const scene *s, const accel_settings *set, accel **out, rr_error *err);
void accel_free(accel *a);

/* The scene accel was built (or last retimed) for: the one it traces and
 * a render of it renders. */
const scene *accel_scene(const accel *a);

/* For the next frame's scene fs (scene_for_shutter of the scene accel was
 * built for: the same objects, another shutter): recomputes the swept
 * bounds and the top levels for fs's shutter and traces fs from then on;
 * the objects' BVHs are kept. */
int accel_retime(accel *a, const scene *fs, rr_error *err);

/* World ray org + t*dir (dir unit) at scene time `time`: fills kb with the
 * epsilon-blended hit set. */
void accel_trace(const accel *a, vec3 org, vec3 dir, double time, kbuffer *kb);

/* One world ray traced at many times (a fixed camera's samples at one
 * raster position share it): the objects that do not move during the
 * shutter are traced once, in accel_ray_begin; accel_ray_trace_times adds
 * the moving ones at up to ACCEL_PACKET times, as packets where the
 * object-space rays are coherent. Each time's hits equal accel_trace's. */
typedef struct {
    vec3 org, dir;
    kbuffer static_hits; /* the same at every time */
    int may_hit_moving;  /* 0: the ray misses every moving object's swept bounds */
} accel_ray;

#define ACCEL_PACKET 16
void accel_ray_begin(const accel *a, vec3 org, vec3 dir, accel_ray *r);
/* result[i] is the hit set at times[i]: &r->static_hits when no moving
 * object is hit then (so callers can reuse what they derived from it),
 * else &kbs[i]. */
void accel_ray_trace_times(const accel *a, const accel_ray *r, const double *times, int n, kbuffer *kbs,
                           const kbuffer **result);

/* ---- Gaussian-splat objects (gaussian.h) ---- */

/* Whether the scene has Gaussian objects (they are not in the top levels:
 * their candidates are asked for object by object, and the Gaussian
 * integrator, render side, evaluates and composites them). */
int accel_has_gaussians(const accel *a);

/* The Gaussian objects, ascending; *count of them. */
const unsigned *accel_gaussian_objects(const accel *a, unsigned *count);

/* Calls found(user, prim) for every Gaussian prim of object obj whose box
 * the object-space ray org + t dir meets at some t in [t0, t1] (the
 * stretch rounded outward to Embree's floats), in the order of Embree's
 * traversal of obj's BVH: the same Gaussians in the same order for the
 * same ray. dir is the world's unit direction moved into object space, so
 * t is world distance. */
typedef void accel_candidate_fn(void *user, unsigned prim);
void accel_gaussian_candidates(const accel *a, unsigned obj, vec3 org, vec3 dir, double t0, double t1,
                               accel_candidate_fn *found, void *user);

/* models[obj]: object obj's Gaussian model, NULL for other objects. */
const gaussian_model *const *accel_gaussian_models(const accel *a);

/* The largest scale of Gaussian object obj's Gaussians over the current
 * shutter (world units): the one its boxes were built with. */
double accel_gaussian_largest_scale(const accel *a, unsigned obj);

/* Does the world ray org + t dir (t >= 0) pass within the object's swept
 * box and swept sphere (the tests the top levels make)? */
int accel_ray_meets_object(const accel *a, unsigned obj, vec3 org, vec3 dir);

/* The transform accel traces object obj with at scene time `time` (a
 * static object's: the one at the shutter's open, at every time). */
xform accel_object_at(const accel *a, unsigned obj, double time);

/* ---- for exact time integration (exact.h) ---- */

typedef struct {
    unsigned *ids;
    size_t count, cap;
} accel_prims;

/* Appends to out, sorted and unique, the primitives of object obj whose
 * BVH bounds overlap one of the object-space boxes (rtcCollide). Returns 0,
 * or one of: */
enum { ACCEL_COLLIDE_NO_MEMORY = -1, ACCEL_COLLIDE_TOO_MANY = -2 /* more than limit primitives */,
       ACCEL_COLLIDE_EMBREE = -3 /* Embree reported an error */ };
int accel_collide_boxes(const accel *a, unsigned obj, const aabb *boxes, unsigned nboxes, size_t limit,
                        accel_prims *out);

/* Does the world ray org + t dir (t >= 0) pass within the object's swept
 * sphere? The one test both integrators use to skip an object. */
int accel_ray_meets_swept_sphere(const accel *a, unsigned obj, vec3 org, vec3 dir);

/* The blending distance and kernel sigma accel was built with: their one
 * owner for both integrators (epsilon as the float the k-buffer holds). */
double accel_epsilon(const accel *a);
double accel_sigma(const accel *a);

/* Whether accel traces the object as moving over the current shutter (a
 * static object's hits are in accel_ray's static_hits). */
int accel_object_moves(const accel *a, unsigned obj);

/* A world sphere holding the object at every time of the current shutter. */
void accel_object_swept_sphere(const accel *a, unsigned obj, vec3 *center, double *radius);

/* RR_MAX_REACH over the shutter [open, close]: the camera's and each
 * object's swept reach (swept[i], object i's world box over the shutter),
 * and the object-space rays they imply, within it; the keyframes' key
 * times within what swept bounds can list. -1 with err naming the scene
 * and the object otherwise. accel_build and accel_retime apply it;
 * refrender splat too, so both refuse the same scenes and instants. */
int accel_check_reach(const scene *s, const aabb *swept, double open, double close, rr_error *err);

/* The most memory Embree held at once for the BVHs (build included). */
size_t accel_embree_peak_bytes(const accel *a);

#endif
