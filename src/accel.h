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

#include "scene.h"

#define KBUFFER_MAX 64

typedef struct {
    float t;
    unsigned obj, prim;
    float weight;    /* kernel weight (1 for analytic spheres) */
    float r2;        /* squared kernel radius; the weight is computed from it
                        only for the hits that stay in the buffer */
    float color[3];
    float normal[3]; /* world space, facing the ray origin */
} surface_hit;

typedef struct {
    int count;
    int dropped;     /* hits beyond KBUFFER_MAX within epsilon (farthest dropped) */
    float closest, epsilon;
    surface_hit hits[KBUFFER_MAX]; /* sorted by (t, obj, prim) */
} kbuffer;

void kbuffer_reset(kbuffer *kb, float epsilon);
/* Inserts a hit if it lies within epsilon of the closest so far. */
void kbuffer_insert(kbuffer *kb, const surface_hit *h);

typedef struct accel accel;

/* Builds the BVHs for the scene (which must outlive the accel). epsilon and
 * sigma are the blending distance and kernel sigma in use. With
 * reuse_static = 0 every object is treated as moving and every time is
 * traced on its own, one ray through the top level (no packets of a ray's
 * times): the same images, slower; for benchmarks and tests. */
int accel_build(const scene *s, double epsilon, double sigma, int reuse_static, accel **out, rr_error *err);
void accel_free(accel *a);

/* After the scene's shutter changed (the next frame): recomputes the swept
 * bounds and the top levels; the objects' BVHs are kept. */
int accel_set_shutter(accel *a, rr_error *err);

/* World ray org + t*dir (dir unit) at scene time `time`: fills kb with the
 * epsilon-blended hit set. */
void accel_trace(const accel *a, vec3 org, vec3 dir, double time, kbuffer *kb);

/* The same in two steps, for reuse over the times of one ray: the hits of
 * the objects that do not move during the shutter (the same at every time),
 * then, per time, those hits plus the moving objects' (the ray is bounded by
 * the static hits from the start). The k-buffer keeps exactly the hits
 * within epsilon of the closest whatever the insertion order, so the result
 * equals accel_trace's. Returns the number of moving hits offered: 0 means
 * kb equals static_hits. */
void accel_trace_static(const accel *a, vec3 org, vec3 dir, kbuffer *kb);
int accel_trace_moving(const accel *a, vec3 org, vec3 dir, double time, const kbuffer *static_hits, kbuffer *kb);
/* accel_trace_moving for up to ACCEL_PACKET times of the same world ray,
 * traced together as a packet: kbs[i] gets the hits at times[i] and
 * hit_moving[i] whether any moving object was hit. Same results. */
#define ACCEL_PACKET 16
void accel_trace_moving_times(const accel *a, vec3 org, vec3 dir, const double *times, int n,
                              const kbuffer *static_hits, kbuffer *kbs, int *hit_moving);
/* 0 when the ray misses every moving object's swept bounds: then
 * accel_trace_moving would return the static hits at every time. */
int accel_may_hit_moving(const accel *a, vec3 org, vec3 dir);
/* The most memory Embree held at once for the BVHs (build included). */
size_t accel_embree_peak_bytes(const accel *a);

#endif
