/* exact's private state, shared by exact.c (plan, candidates, pieces) and
 * exact_integrate.c (Gauss-Kronrod over the pieces). */
#ifndef RR_EXACT_INTERNAL_H
#define RR_EXACT_INTERNAL_H

#include "render/exact.h"
#include "surfels/hitrules.h"

/* A sample's pieces beyond this are not split further (pathological
 * motion): the rest of the shutter counts as unresolved. */
#define EXACT_MAX_PIECES 100000
/* Halving a shutter down to EXACT_TIME_TOL takes 30 levels; far from t = 0
 * a piece stops splitting sooner, when its midpoint rounds to an end. The
 * recursion never goes deeper than this (its scratch is sized for it). */
#define EXACT_MAX_DEPTH 64
/* The candidate boxes of one object cover the shutter in at least 16 time
 * slices, more for fast turns (reach_delta needs angular speed x slice / 2
 * below 1/2); beyond this many, every primitive of the object is a
 * candidate. */
#define EXACT_MIN_TIME_SLICES 16
#define EXACT_MAX_TIME_SLICES 1024
/* How often (in evaluations) a sample looks at the interrupt flag. */
#define EXACT_CANCEL_CHECK_EVERY 4096

typedef struct {
    vec3 swept_center;
    double swept_radius;      /* world sphere holding the object all shutter long */
    double min_scale;
    double depth_lo, depth_hi; /* depths along the ray where it can be */
    /* W: a ray point X (model coordinates) moves at most at
     * base + angular * |X - center| in the object's space; its direction
     * turns at most at dir_rate */
    double base, angular, dir_rate;
    vec3 center;
    int gathered;             /* candidates from rtcCollide (moves relative to the camera) */
    int time_slices;          /* of the candidate boxes; 0: every primitive is a candidate */
} object_plan;

struct exact_plan {
    const scene *sc;           /* accel_scene(acc) */
    const accel *acc;
    const shutter *shut;       /* &sc->shut */
    double tol;        /* EXACT_TIME_TOL of the shutter, in time units */
    double box_scale;
    int camera_moves;
    aabb camera_path;          /* the camera position over the shutter */
    motion_bound camera_speed; /* the camera's motion over the shutter */
    double *breaks;    /* open, a(t)'s kinks inside, close */
    int nbreaks;
    object_plan *obj;
    volatile sig_atomic_t *cancel; /* NULL: never interrupted */
};

typedef struct {
    int valid;
    double time;
    xform xf;
    vec3 org, dir;             /* object space */
    vec3 world_org, world_dir;
} object_ray;

/* What the certificates need of a candidate, computed once per sample. */
typedef struct {
    unsigned obj, prim;
    double center[3], normal[3], dual_u[3], dual_v[3]; /* splat (model space), for splat_depth_d */
    vec3 shading_normal;
    double dual_norm; /* splat: spectral norm of [du; dv] */
    double reach;     /* farthest point from the object's motion center */
} cand_info;

typedef struct {
    int hit, sure;   /* covered at the middle; state certain over the piece */
    double s, sigma; /* depth at the middle and how far it can move */
} cand_eval;

typedef struct {
    double a, b;
    size_t first; /* its blended set: sets[first .. first + count) */
    int count;
} piece;

/* A thread's scratch: its arrays live in `arena` (rr_arena_grow) for one
 * batch (exact_scratch_begin_batch) and are reused by its samples; prims
 * is accel_collide_boxes's, which grows it with malloc. */
struct exact_scratch {
    rr_arena *arena; /* the worker's, or own */
    rr_arena own;
    uint64_t *keys; /* candidates: object << 32 | primitive, sorted */
    size_t nkeys, keys_cap;
    cand_info *info; /* one per key */
    size_t info_cap;
    accel_prims prims;
    aabb *boxes;
    size_t boxes_cap;
    int *lists;
    size_t lists_cap;
    cand_eval *evals, *inherit, *sorted;
    size_t evals_cap, inherit_cap, sorted_cap;
    piece *leaves;
    size_t npieces, leaves_cap;
    size_t first_of_break; /* pieces from here on lie in the current stretch between kinks of a(t) */
    int *sets;
    size_t nsets, sets_cap;
    object_ray *ray_cache; /* one per object */
    size_t ray_cache_cap;
    uint64_t evaluations; /* this sample's certificates and shaded nodes */
    int status;           /* EXACT_OK until the sample must stop */
};


typedef struct {
    const exact_plan *p;
    exact_scratch *scr;
    double x, y;
    vec3 dir0; /* the ray direction at rest (a still camera's at every time) */
    exact_stats *st;
} sample_ctx;

/* A candidate's crossing at one time, for shading: depth s, squared
 * ellipse radius r2 (0 for a sphere), object-space normal and colour. */
typedef struct {
    double s, r2;
    vec3 normal, color;
} exact_crossing;

/* What exact time asks of each object kind, one row per kind
 * (exact_kinds.c, indexed by object_kind as accel_build.c's rows are). */
typedef struct {
    /* The candidate's constants (cand_info) past obj and prim: its reach
     * from the model-space point c and what its certificates read. */
    void (*describe)(const scene_object *o, unsigned prim, vec3 c, cand_info *info);
    /* Its state at the ray r of a piece's middle, and whether that state
     * holds over the piece: r's points move by at most delta, its
     * direction by at most eps_d. */
    cand_eval (*eval)(const scene_object *o, const cand_info *g, const object_ray *r, double delta, double eps_d);
    /* Its crossing of r for shading; 0: none (parallel to a splat). */
    int (*cross)(const scene_object *o, const cand_info *g, const object_ray *r, exact_crossing *x);
    int opaque; /* hit_weight's is_sphere: weight 1, no kernel */
} exact_kind_ops;

/* o's kind's row (not for a Gaussian model). */
const exact_kind_ops *exact_kind_row(const scene_object *o);

/* Counts n evaluations of the current sample; 0 while it may go on, else
 * the EXACT_ status that stops it (budget spent or interrupted). */
int exact_spend(const sample_ctx *c, uint64_t n);
int exact_context(const exact_plan *p, exact_scratch *scr, double x, double y, exact_stats *st, sample_ctx *c);
void exact_world_ray(const sample_ctx *c, double t, vec3 *org, vec3 *dir);
const object_ray *exact_object_ray(const sample_ctx *c, unsigned obj, double t);
int exact_gather(const sample_ctx *c);
int exact_partition(const sample_ctx *c);

#endif
