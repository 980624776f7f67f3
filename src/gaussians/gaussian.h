/* Gaussian-splat models as trained by 3D Gaussian Splatting (Kerbl et al.
 * 2023) and 2D Gaussian Splatting (Huang et al. 2024), with the activations
 * the official code applies on loading (their PLY files: gaussian_ply.h),
 * and their colour from real spherical harmonics (utils/sh_utils.py). Pure
 * data and math: no Embree, no scene, no files. */
#ifndef RR_GAUSSIAN_H
#define RR_GAUSSIAN_H

#include <stdint.h>

#include "core/common.h"

typedef enum { GAUSSIAN_AUTO = 0, GAUSSIAN_2D = 2, GAUSSIAN_3D = 3 } gaussian_kind;

/* The order in which a ray composites a 2D model's hits: by the view depth
 * of each Gaussian's centre (the official rasterizer's sort; the default,
 * so a sharp render matches it) or by the depth of the ray's own hit (the
 * physically ordered variant). 3D models go by the distance to each
 * Gaussian's maximum response along the ray, as 3DGRT does. */
typedef enum { GAUSSIAN_ORDER_CENTER_DEPTH, GAUSSIAN_ORDER_HIT_DEPTH } gaussian_order;

/* How a model is imaged: the renderer it was trained with decides what it
 * looks like, and its PLY does not say which (src/GAUSSIANS.md).
 * DEFAULT is the kind's rasterizer: 2DGS at e0ed020 for 2D models, the
 * graphdeco-inria 3DGS rasterizer for 3D ones. */
typedef enum {
    GAUSSIAN_FORMATION_DEFAULT = 0,
    GAUSSIAN_FORMATION_2DGS,             /* diff-surfel-rasterization e0ed020: filter about the 3-sigma circle's centre */
    GAUSSIAN_FORMATION_2DGS_CENTER_NEAR, /* 909dd85 to 7bdbd51 (2DGS's pins 2024-06-28 to 11-10): the same,
                                          * and where the filter wins the near skip takes the centre's depth */
    GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE, /* before 909dd85 (2024-06-28): about the unit circle's centre, the
                                          * near skip as 2DGS_CENTER_NEAR's */
    GAUSSIAN_FORMATION_3DGS,             /* diff-gaussian-rasterization: EWA, +0.3 dilation */
    GAUSSIAN_FORMATION_3DGS_ANTIALIASED, /* the same with its `antialiasing` opacity compensation */
    GAUSSIAN_FORMATION_3DGS_FOV_MINUS_ONE, /* the same handed FoV = -1 (4DGS's N3V cameras): the Jacobian pinned */
    GAUSSIAN_FORMATION_GSPLAT,           /* nerfstudio gsplat, rasterize_mode classic */
    GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED,
    GAUSSIAN_FORMATION_3DGRT             /* ray traced (nv-tlabs/3dgrut, kernel degree 2) */
} gaussian_formation;

#define GAUSSIAN_MAX_SH_DEGREE 3
#define GAUSSIAN_MAX_SH_COEFFS 16 /* (3 + 1)^2 */

typedef struct {
    size_t count;
    gaussian_kind kind;  /* 2D: surfels (two scales), 3D: ellipsoids */
    int sh_degree;       /* 0 to 3 */
    int sh_coeffs;       /* (sh_degree + 1)^2; times (sh_degree_t + 1) for 4DGS (gaussian_fdgs.h) */
    float *mean;         /* 3 per Gaussian */
    float *scale;        /* 3 per Gaussian: exp(scale_i); a 2D Gaussian's third is 0 */
    float *rotation;     /* 4 per Gaussian: the unit quaternion (w, x, y, z) of rot_0..3 */
    float *opacity;      /* 1 per Gaussian: sigmoid(opacity) */
    float *sh;           /* 3 * sh_coeffs per Gaussian: coefficient k of channel c at [3 k + c] */
    /* how it is imaged, set by the scene (the file does not say; gaussian_hit.h) */
    gaussian_formation formation;
    int tile_rule;       /* 1: only in the 16x16 tiles the rasterizer would visit */
    /* Gaussians that move (gaussian_dynamic.h: its kind's row says how,
     * and what sh holds), owned; NULL for a static model */
    struct gaussian_dynamic *dynamic;
} gaussian_model;

/* ---- a moving kind's row (gaussian_dynamic.h says how the kinds use it):
 * here, so that the model frees its moving part through the row, knowing
 * no kind and reaching no file above its own */

/* One Gaussian at one time, as the official renderer draws it. */
typedef struct {
    double mean[3];
    double q[4];       /* (w x y z), as the kind's rasterizer builds its matrix from it (not always unit:
                        * gaussian_stg.h) */
    double scale[3];
    double opacity;
    double rgb[3];     /* the colour where it does not depend on the view, else 0 (the row's color) */
} gaussian_dynamic_state;

/* A dynamic kind: one row of operations, i the Gaussian's index in m,
 * m->dynamic of this kind. */
typedef struct gaussian_dynamic_ops {
    const char *name; /* for `refrender export`'s "motion": "stg-lite", "4dgs" */
    /* Gaussian i at time t. */
    void (*at)(const gaussian_model *m, size_t i, double t, gaussian_dynamic_state *out);
    /* Its colour at time t seen along dir (a hit's gaussian_hit.dir, gaussian_hit.h). */
    vec3 (*color)(const gaussian_model *m, size_t i, double t, vec3 dir);
    /* The direction the colour is seen along from the camera centre eye
     * (object space), when it is not the instant's (the ray toward the
     * moved mean, which the hit holds); NULL: the instant's. */
    void (*view_dir)(const gaussian_model *m, size_t i, vec3 eye, float dir[3]);
    /* Over the times [t0, t1] (t0 <= t1) the mean stays in [lo, hi] (per
     * axis; both the exact path and what `at` and instant_cull compute),
     * and the opacity is at most *opacity_max. -1 (nothing written) if the
     * box is not finite. */
    int (*bounds)(const gaussian_model *m, size_t i, double t0, double t1, double lo[3], double hi[3],
                  double *opacity_max);
    /* The instant at t written into slot j of the scratch model out (see
     * "rendering" below): cull the mean and scale, rest the rotation and
     * opacity, in floats as the kind's rasterizer holds them. */
    void (*instant_cull)(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j);
    void (*instant_rest)(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j);
    /* Start loading what each part reads (no value changes). */
    void (*prefetch_cull)(const gaussian_model *m, size_t i);
    void (*prefetch_rest)(const gaussian_model *m, size_t i);
    /* Frees the kind's struct d and what it owns (gaussian_dynamic_free,
     * for a struct from gaussian_dynamic_alloc). */
    void (*free)(struct gaussian_dynamic *d);
} gaussian_dynamic_ops;

/* The first member of every kind's struct. */
typedef struct gaussian_dynamic {
    const gaussian_dynamic_ops *ops; /* the kind's row */
    float *block;                    /* owned: every array of the kind's struct (gaussian_dynamic_alloc) */
} gaussian_dynamic;


void gaussian_model_init(gaussian_model *m);
void gaussian_model_free(gaussian_model *m);
/* Storage for n Gaussians of m's kind and SH degree (count stays 0). */
int gaussian_model_alloc(gaussian_model *m, size_t n);

/* m's formation, DEFAULT resolved by its kind. */
gaussian_formation gaussian_formation_of(const gaussian_model *m);
/* "2dgs", "3dgs-antialiased", ...: the scene's names; NULL if unknown. */
const char *gaussian_formation_name(gaussian_formation f);
/* How m's hits are ordered under its formation and the scene's order
 * (which only a 2D model's takes): "center-depth", "hit-depth" or 3DGRT's
 * "max-response". */
const char *gaussian_order_name(const gaussian_model *m, gaussian_order order);

/* How a Gaussian object is imaged, as key/value pairs in this order
 * (semantics, tileRule, order): the one description that the render's
 * header (render_attrs.c, part of its identity) and `refrender export`
 * (export_cmd.c) both write, each in its own syntax. */
enum { GAUSSIAN_IMAGING_FIELDS = 3 };
void gaussian_imaging(const gaussian_model *m, gaussian_order order, const char *key[GAUSSIAN_IMAGING_FIELDS],
                      const char *value[GAUSSIAN_IMAGING_FIELDS]);
/* The formation of that name for a model of that kind; -1 for a name
 * that is none, or one for the other kind. */
int gaussian_formation_parse(const char *name, gaussian_kind kind, gaussian_formation *f);

/* Gaussians from surfels (surfel.h), for test scenes and 'refrender gen':
 * each at the surfel's center, its frame's third axis along the normal,
 * the two tangent scales half the radius (refrender's kernel sigma), a 3D
 * Gaussian 2% as thick, opacity 0.95, the colour as the DC coefficient and
 * small fixed view-dependent coefficients up to the SH degree. */
struct surfel_s;
int gaussian_from_surfels(const struct surfel_s *s, size_t n, gaussian_kind kind, int degree, gaussian_model *m,
                          rr_error *err);

/* The colour of SH coefficients sh (3 per coefficient, as stored above) of
 * the given degree seen along dir (need not be unit): the real SH series
 * plus 0.5, clamped below at 0 (not above), as the official renderers do. */
vec3 gaussian_sh_color(const float *sh, int degree, vec3 dir);
/* A 4DGS model's colour (gaussian_fdgs.h): sh holds degree_t + 1
 * blocks of (degree + 1)^2 coefficients (3 each, as above), block k
 * weighted by cos(2 pi k dir_t / duration) (k = 0: 1); the time blocks
 * count only at degree 3 (4DGS's rasterizer); + 0.5, clamped below at 0. */
vec3 gaussian_sh4d_color(const float *sh, int degree, int degree_t, double dir_t, double duration, vec3 dir);
#ifdef RR_DCHECKS
/* Test hook: whether the SH sums in AVX2 lanes differ in any bit from the
 * scalar sums (0 without the lanes). */
int gaussian_sh_lanes_differ(const float *sh, int degree, vec3 dir);
#endif

#endif
