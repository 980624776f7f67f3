/* accel's private state, shared by its two files: accel.c (Embree
 * callbacks and tracing) and accel_build.c (BVHs and top levels). */
#ifndef RR_ACCEL_INTERNAL_H
#define RR_ACCEL_INTERNAL_H

#include <embree3/rtcore.h>

#include "accel/accel.h"
#include "gaussians/gaussian_hit.h"

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

/* With more moving objects than this, testing each one's swept bounds per
 * ray costs more than the top-level BVH's own traversal, which then picks
 * them (and the times of a ray are traced one by one). */
enum { TOP_LEVEL_OWN_BVH = 64 };

typedef struct {
    vec3 center;
    double radius2;
} sphere_bound;

/* What the bounds of a Gaussian object's splats need to hold a footprint
 * drawn on the screen (the 2DGS low-pass filter's, a rasterizer's EWA
 * dilation) over the shutter (gaussian_view_reach, gaussian_view_bounds):
 * the farthest the camera can be from each Gaussian, the view axis. */
typedef struct {
    const struct accel *acc;
    unsigned obj;
    xform at_open;       /* the object's transform at the shutter's open */
    vec3 camera_center;  /* a world sphere holding the camera over the shutter */
    double camera_radius;
    double travel;       /* how far any point of the object moves during the shutter (world) */
    double min_scale, max_scale;
    double focal;        /* the smaller focal length, pixels */
    double stretch;      /* gaussian_view_stretch */
    double largest;      /* the largest scale of a Gaussian over the shutter, world units */
    vec3 view_axis;      /* the camera's view axis in object space at mid-shutter, and how far */
    double view_cone;    /* it can turn from it (gaussian_view_bound); a zero axis: not known */
    double *paths;       /* a dynamic model's, while its BVH is built: per Gaussian the box of its mean
                          * over the shutter (lo[3], hi[3]) and its largest opacity then
                          * (gaussian_dynamic_bounds), PATH_DOUBLES each; NULL otherwise */
} gaussian_footprint;

enum { PATH_DOUBLES = 7 };

struct accel {
    RTCDevice device;
    top_level top[2];
    RTCScene *object_scenes;
    aabb *swept;  /* world bounds of each object over the shutter */
    sphere_bound *swept_sphere; /* and a world sphere holding it at every time */
    double *coherent_spread; /* object-space rays closer than this share a packet */
    xform *rest;  /* transform of each static object (the same at every time) */
    int *is_static;
    int reuse_static;
    const scene *sc;         /* the scene traced, whose shutter the top levels are for (accel_scene) */
    unsigned *gaussian_ids;  /* the Gaussian objects: traced by gathering, not in the top levels */
    unsigned ngaussian;
    gaussian_footprint *footprint; /* per object (used for Gaussian ones) */
    const gaussian_model **models; /* per object: its Gaussian model, or NULL */
    float epsilon;
    double sigma;
    int building;       /* Embree's error callback records only while building (render threads
                           check rtcGetDeviceError themselves: accel is const to them) */
    int building_object;     /* the object whose BVH is being built (-1: the top levels), for errors */
    rr_error build_error; /* filled by Embree's error callback */
    long long embree_bytes, embree_peak; /* Embree's own allocations (BVHs) */
};

/* Per-traversal state: one ray (lane 0) or a packet of one world ray at up
 * to ACCEL_PACKET times (lane i at its own time). The RTCIntersectContext
 * must come first: Embree hands the same pointer to every callback, also
 * through the nested rtcIntersect1. */
typedef struct {
    struct RTCIntersectContext rtc;
    const accel *acc;
    double time;                  /* the single ray's time (top-level path) */
    vec3 world_org, world_dir;    /* and its world ray, unrounded */
    unsigned obj;
    unsigned lanes;                /* rays in play: ray IDs 0 .. lanes-1 */
    const xform *xf[ACCEL_PACKET]; /* each lane's object transform at its time */
    kbuffer *kb[ACCEL_PACKET];
    int accepted[ACCEL_PACKET];   /* hits offered to each lane's k-buffer */
} trace_context;

/* Embree passes rays to callbacks in SOA layout, N lanes per field
 * (rtcore_ray.h: RTCRayHitN); C has no accessors, so index it ourselves. */
enum { F_ORG = 0, F_TNEAR = 3, F_DIR = 4, F_TFAR = 8, F_MASK = 9, F_ID = 10, F_FLAGS = 11,
       F_PRIM = 17, F_GEOM = 18, F_INST = 19, F_COUNT = 20 };
/* the hand-written layout must be Embree's: 20 four-byte fields per lane */
_Static_assert(sizeof(struct RTCRayHit16) == F_COUNT * 16 * sizeof(float), "Embree's RTCRayHitN layout changed");

/* Embree callbacks (accel.c) that the builder installs. */
void accel_splats_intersect(const struct RTCIntersectFunctionNArguments *args);
void accel_sphere_intersect(const struct RTCIntersectFunctionNArguments *args);
void accel_splat_bounds_cb(const struct RTCBoundsFunctionArguments *args);
void accel_sphere_bounds_cb(const struct RTCBoundsFunctionArguments *args);
void accel_no_occluded(const struct RTCOccludedFunctionNArguments *args);
void accel_object_intersect(const struct RTCIntersectFunctionNArguments *args);
void accel_object_bounds_cb(const struct RTCBoundsFunctionArguments *args);
void accel_gaussian_bounds_cb(const struct RTCBoundsFunctionArguments *args);
void accel_dynamic_gaussian_bounds_cb(const struct RTCBoundsFunctionArguments *args);
void accel_gaussian_gather(const struct RTCIntersectFunctionNArguments *args);
/* A committed scene of one user geometry (accel_build.c); compact: a
 * smaller BVH built faster, at some cost in traversal. */
RTCScene accel_user_scene(RTCDevice dev, unsigned nprims, void *user, RTCBoundsFunction bounds,
                          RTCIntersectFunctionN intersect, int compact);
/* A world sphere that holds the object at every time in [t0, t1]; and one
 * holding the sphere (center, radius) of object space moved by anim. */
sphere_bound accel_swept_sphere(const scene_object *o, double t0, double t1);
sphere_bound accel_swept_sphere_about(const animation *anim, vec3 center, double radius, double t0, double t1);

#endif
