/* What the Gaussian hit files share, and no one else reads (gaussian_hit.c
 * split along its subjects: the rasterizers' rules gaussian_raster_rules.c,
 * 2DGS geometry and hit gaussian_hit_2d.c, the 3D rasterizers' and 3DGRT's
 * hits gaussian_hit_3d.c, the culls in scalar and AVX2 lanes gaussian_cull.c,
 * the bounds' reach gaussian_reach.c, the ray and the dispatch
 * gaussian_hit.c): the rules' table type and the kernels written once over
 * a lane type, so each file instantiates the same operations in the same
 * order (static inline: bit for bit the same wherever they are used). */
#ifndef RR_GAUSSIAN_HIT_INTERNAL_H
#define RR_GAUSSIAN_HIT_INTERNAL_H

#include "core/lanes.h"
#include "core/rotation.h"
#include "gaussians/gaussian_hit.h"

/* The 3D rasterizers' rules (a 3DGS model looks as the rasterizer it was
 * trained with draws it, and its PLY does not say which: the scene names
 * the formation), each read in its source:
 * graphdeco-inria/diff-gaussian-rasterization cuda_rasterizer/forward.cu
 * (59f5f77; the `antialiasing` flag of 9c5c202, dr_aa, the commit
 * gaussian-splatting pins) and nerfstudio gsplat v1.5.3 (937e299);
 * tests/gs3d_raster_reference.py names the file and line of each rule. */
typedef struct {
    double near, far;  /* a mean's view depth must be in (near, far] (in_frustum; gsplat: [0.01, 1e10]) */
    double dilation;   /* added to cov2D's diagonal, pixels^2 (0.3; gsplat's eps2d) */
    double alpha_max;  /* alpha = min(alpha_max, opacity G): 0.99; gsplat v1.5.3 0.999 */
    int antialiased;   /* opacity x sqrt(max(aa_floor, det cov2D / det(cov2D + dilation I))) */
    double aa_floor;   /* 2.5e-5 (forward.cu); 0 (gsplat) */
    int tiles_cut;     /* the tile rule can cut a tail: inria's 3-sigma radius; gsplat's box of
                        * sqrt(2 ln(255 o)) sigma per axis holds every alpha >= 1/255 */
    int clamp_at_edges; /* the Jacobian's clamp (jacobian_clamp): gsplat's, past each image edge */
    int fov_minus_one;  /* the Jacobian as the rasterizer handed FoV = -1 computes it (pinned_jacobian) */
} raster_rules;

/* The rules of formation f (a 2D formation: Inria's, never read). */
const raster_rules *raster_rules_of(gaussian_formation f);
/* The Jacobian's focal lengths and clamped x/z, y/z at camera-space p
 * (gaussian_raster_rules.c). */
void raster_jacobian_at(const raster_rules *rules, const gaussian_ray *r, vec3 p, double *fx, double *fy, double *tx,
                        double *ty);
/* Whether the ray's pixel lies in the rasterizer tiles that the square of
 * `radius` about (cx, cy) (pixel-index coordinates) touches. */
int in_rasterizer_tiles(const gaussian_ray *r, double cx, double cy, double radius);
/* gaussian_view_stretch under the pinned Jacobian of 3dgs-fov-minus-one. */
double raster_pinned_stretch(const camera_view *v);

/* The rotation of a unit quaternion (w, x, y, z), row-major. */
static inline void quaternion_matrix(const float *q, double R[3][3]) { quat_unit_matrix(q[0], q[1], q[2], q[3], R); }

/* The Gaussian kernels are written once over a lane type T (lanes.h) and
 * instantiated for one double and, where the CPU has AVX2, four in a v4d:
 * the culls of gaussian_cull_candidates and the 2D geometry of
 * gaussian_hits_after_cull4 run four Gaussians at a time, with the same
 * operations in the same order, so the same bits (the lane tests). */

/* Camera matrix row `row`'s linear part times (x, y, z), and the row
 * applied to the point (x, y, z). */
#define DEFINE_CAMERA_MAP(T)                                                                              \
    LANES_TARGET_##T static inline T camera_linear_##T(const double row[4], T x, T y, T z)                \
    {                                                                                                     \
        return row[0] * x + row[1] * y + row[2] * z;                                                      \
    }                                                                                                     \
    LANES_TARGET_##T static inline void camera_point_##T(const double m[3][4], const T x[3], T p[3])      \
    {                                                                                                     \
        for (int a = 0; a < 3; a++)                                                                       \
            p[a] = camera_linear_##T(m[a], x[0], x[1], x[2]) + m[a][3];                                   \
    }
DEFINE_CAMERA_MAP(double)
#if RR_LANES
DEFINE_CAMERA_MAP(v4d)
#endif

/* m's linear part times v. */
static inline vec3 cam_vector(const double m[3][4], vec3 v)
{
    return v3(camera_linear_double(m[0], v.x, v.y, v.z), camera_linear_double(m[1], v.x, v.y, v.z),
              camera_linear_double(m[2], v.x, v.y, v.z));
}

/* Gaussian i's mean in camera space. */
static inline vec3 camera_mean(const gaussian_model *m, size_t i, const gaussian_ray *r)
{
    const float *mu = &m->mean[3 * i];
    double x[3] = {mu[0], mu[1], mu[2]}, p[3];
    camera_point_double(r->m, x, p);
    return v3(p[0], p[1], p[2]);
}

/* Rows of the 2DGS homogeneous map T = K [t_u t_v p] (u, v, 1 -> pixel x w,
 * pixel y w, w), row[k][column], from the splat's scaled axes u and v
 * (object space) and its mean p (camera space): row[2] is the view depth
 * row. */
#define DEFINE_SPLAT_ROWS(T)                                                                               \
    LANES_TARGET_##T static inline void splat_rows_##T(const gaussian_ray *r, const T u[3], const T v[3],  \
                                                       const T p[3], T row[3][3])                          \
    {                                                                                                      \
        T tu[3], tv[3];                                                                                    \
        for (int a = 0; a < 3; a++)                                                                        \
            tu[a] = camera_linear_##T(r->m[a], u[0], u[1], u[2]),                                          \
            tv[a] = camera_linear_##T(r->m[a], v[0], v[1], v[2]);                                          \
        row[2][0] = tu[2], row[2][1] = tv[2], row[2][2] = p[2];                                            \
        T first[3] = {tu[0], tv[0], p[0]}, second[3] = {tu[1], tv[1], p[1]};                               \
        for (int a = 0; a < 3; a++)                                                                        \
            row[0][a] = first[a] * r->fx + row[2][a] * r->cx, row[1][a] = second[a] * r->fy + row[2][a] * r->cy; \
    }
DEFINE_SPLAT_ROWS(double)
#if RR_LANES
DEFINE_SPLAT_ROWS(v4d)
#endif

/* The radius, in scales, of the circle whose image's centre the 2DGS
 * low-pass filter is centred on: e0ed020's compute_aabb takes the dual
 * conic of the circle of radius cutoff = 3 (TIGHTBBOX 0; since 909dd85,
 * 2024-06-28), the older computeCenter the unit circle's. */
static inline double filter_circle(const gaussian_model *m)
{
    return gaussian_formation_of(m) == GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? 1.0 : 3.0;
}

/* Entry (a, b) of the dual conic T diag(c^2, c^2, -1) T^T of the splat's
 * circle of radius c (scales), from rows a and b of T and cc = c^2 (either
 * lane type). */
#define DUAL_CONIC(a, b, cc) ((cc) * ((a)[0] * (b)[0] + (a)[1] * (b)[1]) - (a)[2] * (b)[2])

static inline double clamp_alpha(double alpha_max, double opacity, double g) { return rr_fmin(alpha_max, opacity * g); }

/* How far from the mean the point P lies whose image is the centre of the
 * image of the filter's circle (semi-axes at most `radius`), for a mean at
 * view depth `depth`: the image's centre is the pole of the image's line at
 * infinity, so P is the pole, with respect to the circle, of the line of
 * the splat's plane at view depth 0 (a projection keeps poles and polars).
 * That line lies at least `depth` from the mean (view depth changes by at
 * most 1 per unit length), and the pole of a line d from the centre lies
 * within radius^2 / d of it: at depth 2.5 a 3-scale circle's P is
 * 1/500 of the radius from the mean, where the bounds assumed all of it.
 * P is always in front of the camera: the filter acts only where the
 * circle's image is an ellipse (splat_2d_geometry's `filtered`), so the
 * circle, and the disc within it, lie beyond view depth 0, and the pole
 * of a line that misses the circle lies inside it. (Not so for the tile
 * rule's filter about a hyperbola's centre, hyperbola_filter: its P lies
 * behind the camera and nothing here bounds those filter pixels; its ray
 * hits are bounded as every hit is. GAUSSIANS.md says what was measured.) The bounds built on P
 * (the culls, filter_2d_reach) hold every pixel within the filter's reach
 * of P's image and never ask where the pixel's ray meets the splat's
 * plane: so they hold under either near rule (hit_2d_from_geometry), also
 * the older rule's filter pixels whose rays meet the plane behind the
 * camera. (filter_pole_T: DEFINE_CULLS, below.) */

/* Reaches, rounded up, that the culls, key floors and traversal pads
 * share: the kernel's 1/255 radius sqrt(2 ln 255) = 3.32901 scales (at
 * opacity 1), the 2DGS low-pass filter's sqrt(ln 255) = 2.35399 pixels
 * (FilterInvSquare), and the 3D rasterizers' k^2 = 2 ln 255 (opacities are
 * at most 1, gaussian.c) with its rounding room. */
#define KERNEL_REACH 3.3302
#define FILTER_REACH_PX 2.3540
#define RASTER_REACH2 gaussian_alpha_reach2(1.0)
#define RASTER_REACH2_SLACK (1 + 1e-5)
/* gaussian_traversal_pad's rounding room, and the key floor's room for
 * the subtraction's rounding where the pad is below it */
#define TRAVERSAL_PAD_SLACK (1 + 1e-6)
#define KEY_FLOOR_ROUNDING 1e-15
/* The 2DGS cull's rounding room: a centre within this factor of its
 * reach counts as near the camera plane, and the bound grows by this
 * fraction of itself and of the depth */
#define CULL_NEAR_SLACK (1 + 1e-9)
#define CULL_ROUNDING 1e-6

/* The culls and key floors, over a lane type T (from the camera-space
 * mean p and the larger scale s in object units; a lane computes its
 * whole test where one double's could stop early):
 *
 * filter_pole: see above. scaled_image_offset: p's image's offset from
 * the ray's raster position, times p.z (no division: the culls compare it
 * with bounds scaled by p.z alike).
 *
 * cull_2d: the centre in front of the near plane, as the rasterizer's
 * frustum test, and the splat near the pixel. A point p + delta, |delta|
 * <= D < p.z, projects within f |delta| |p| / (p.z (p.z - |delta|)) pixels
 * of p's image (the offset is f |delta_xy p.z - p_xy delta_z| / (p.z (p.z
 * + delta_z)), and by Lagrange's identity |delta_xy p.z - p_xy delta_z|
 * <= |delta| |p|). Hits lie within the kernel's reach (3.33 scales at
 * opacity 1); the filter acts within 2.36 pixels of the image of a point
 * of the filter's circle within filter_pole of the mean. A cheap test
 * that the boxes of most candidates fail (they hold a ball; the pixel's
 * ray is a line): the pole (a thousandth of a pixel for the bench's
 * splats, where the whole circle was assumed before) cut the candidates
 * it keeps from 1.7 to about 1.1 per hit. Both reaches are bounded over
 * the larger one's p.z - reach, and the test multiplied through by p.z
 * (p.z - reach): one division (the pole's) where there were four (the
 * divisions led the cull's time in a profile of 2DGS rendering), never
 * tighter than the bound itself; CULL_ROUNDING covers rounding.
 *
 * cull_3d: the 3D rasterizers' cull: the centre within the depths
 * in_frustum keeps, and the pixel within the footprint's reach, cheap and
 * sure: lambda_max(cov2D) <= (f_max / z)^2 (1 + lim^2) s_max^2 + dilation
 * (gaussian_view_stretch), alpha >= 1/255 within k^2 of it, k^2 = 2 ln(255
 * o) <= 2 ln 255; the offset times p.z^2, with room for rounding.
 *
 * traversal_pad: gaussian_traversal_pad's, of a larger scale s in camera
 * lengths. centre_key: the centre's distance along the ray (a rasterizer's
 * key, and its key floor). key_floor_2d: a 2D Gaussian's key floor
 * (gaussian_key_floor): its centre's distance less the pad, less room
 * for the subtraction's rounding. */
#define DEFINE_CULLS(T)                                                                                        \
    LANES_TARGET_##T static inline T filter_pole_##T(T radius, T depth) { return radius * radius / depth; }    \
    LANES_TARGET_##T static inline void scaled_image_offset_##T(const gaussian_ray *r, const T p[3], T *X, T *Y) \
    {                                                                                                          \
        *X = r->fx * p[0] + (r->cx - r->x) * p[2], *Y = r->fy * p[1] + (r->cy - r->y) * p[2];                  \
    }                                                                                                          \
    LANES_TARGET_##T static inline lanes_mask_##T cull_2d_##T(const gaussian_ray *r, double circle_scales,     \
                                                              const T p[3], T s)                               \
    {                                                                                                          \
        T scaled = s * r->scale, reach_k = KERNEL_REACH * scaled, circle = circle_scales * scaled;             \
        /* near the camera plane: no bound from the projection */                                             \
        lanes_mask_##T near = p[2] <= lanes_max(reach_k, circle) * CULL_NEAR_SLACK;                            \
        /* the pole: below circle where the centre is not near */                                             \
        T reach_c = filter_pole_##T(circle, p[2]), reach = lanes_max(reach_k, reach_c);                        \
        T gap = p[2] - reach, depth = p[2] * gap, X, Y;                                                        \
        T spread = rr_fmax(r->fx, r->fy) * lanes_sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);               \
        scaled_image_offset_##T(r, p, &X, &Y);                                                                 \
        T bound = lanes_max(spread * reach_k, spread * reach_c + FILTER_REACH_PX * depth) * (1 + CULL_ROUNDING) \
                  + CULL_ROUNDING * depth;                                                                     \
        lanes_mask_##T within = (X * X + Y * Y) * gap * gap <= bound * bound;                                  \
        return lanes_not(p[2] <= GAUSSIAN_NEAR) & (near | within);                                             \
    }                                                                                                          \
    LANES_TARGET_##T static inline lanes_mask_##T cull_3d_##T(const gaussian_ray *r, const raster_rules *rules, \
                                                              const T p[3], T s)                               \
    {                                                                                                          \
        double stretch = rules->fov_minus_one ? r->stretch_fov_minus_one : r->stretch;                         \
        T F = rr_fmax(r->fx, r->fy) * s * r->scale * stretch, X, Y;                                            \
        scaled_image_offset_##T(r, p, &X, &Y);                                                                 \
        lanes_mask_##T within =                                                                                \
            X * X + Y * Y <= RASTER_REACH2 * (F * F + rules->dilation * p[2] * p[2]) * RASTER_REACH2_SLACK;    \
        return (p[2] > rules->near) & (p[2] <= rules->far) & within;                                           \
    }                                                                                                          \
    LANES_TARGET_##T static inline T traversal_pad_##T(T s, double depth_per_t)                                \
    {                                                                                                          \
        return KERNEL_REACH * s / depth_per_t * TRAVERSAL_PAD_SLACK;                                           \
    }                                                                                                          \
    LANES_TARGET_##T static inline T centre_key_##T(const gaussian_ray *r, T z) { return z / r->depth_per_t; } \
    LANES_TARGET_##T static inline T key_floor_2d_##T(const gaussian_ray *r, T z, T s)                         \
    {                                                                                                          \
        T centre = centre_key_##T(r, z);                                                                       \
        return centre - traversal_pad_##T(s * r->scale, r->depth_per_t) - KEY_FLOOR_ROUNDING * lanes_abs(centre); \
    }
DEFINE_CULLS(double)
#if RR_LANES
DEFINE_CULLS(v4d)
#endif

/* Gaussian i's larger scale (2D) or largest (3D), object units. */
static inline double larger_scale(const gaussian_model *m, size_t i)
{
    const float *s = &m->scale[3 * i];
    return m->kind == GAUSSIAN_2D ? rr_fmax(s[0], s[1]) : rr_fmax(s[0], rr_fmax(s[1], s[2]));
}

/* What a 2DGS hit's rules read of the splat's geometry at the ray's
 * pixel, over a lane type T: one Gaussian (splat_2d_geometry_double) or
 * four (splat_2d_geometry_in_lanes), from T's rows (splat_rows). The
 * filter's centre is the centre of the image of the splat's circle of
 * `circle` scales: the last column of the dual conic T diag(c^2, c^2, -1)
 * T^T over its last entry (compute_aabb's point_image); none when the
 * circle reaches behind the camera's plane: its image is no ellipse and
 * has no centre to filter about (the rasterizer filters about the
 * hyperbola's, anywhere on screen, which only tileRule follows:
 * hyperbola_filter; GAUSSIANS.md). A lane computes every
 * field; u, v and what follows mean something only where cz != 0. */
#define DEFINE_SPLAT_2D_GEOMETRY(T)                                                                           \
    typedef struct {                                                                                          \
        T row[3][3];          /* T's rows (splat_rows) */                                                     \
        T cz, u, v;           /* the pixel's planes' intersection (u, v, 1) cz */                             \
        T rho3d, rho2d;       /* the kernel's and the filter's squared distances (rho2d: inf unfiltered) */   \
        T centre_x, centre_y; /* the filter's centre (0 unfiltered) */                                        \
        T plane_depth;                                                                                        \
        lanes_mask_##T filtered;                                                                              \
    } splat_2d_geometry_##T;                                                                                  \
    LANES_TARGET_##T static inline void splat_2d_geometry_of_##T(const gaussian_ray *r, double circle,        \
                                                                 splat_2d_geometry_##T *g)                    \
    {                                                                                                         \
        T(*row)[3] = g->row, k[3], l[3], zero = {0};                                                          \
        for (int a = 0; a < 3; a++) /* the planes through the pixel's column and row, in (u, v, 1) */        \
            k[a] = row[2][a] * r->x - row[0][a], l[a] = row[2][a] * r->y - row[1][a];                         \
        g->cz = k[0] * l[1] - k[1] * l[0];                                                                    \
        g->u = (k[1] * l[2] - k[2] * l[1]) / g->cz, g->v = (k[2] * l[0] - k[0] * l[2]) / g->cz;               \
        g->rho3d = g->u * g->u + g->v * g->v;                                                                 \
        T d22 = DUAL_CONIC(row[2], row[2], circle * circle);                                                  \
        g->filtered = d22 < 0;                                                                                \
        g->centre_x = lanes_select(g->filtered, DUAL_CONIC(row[0], row[2], circle * circle) / d22, zero);     \
        g->centre_y = lanes_select(g->filtered, DUAL_CONIC(row[1], row[2], circle * circle) / d22, zero);     \
        T dx = g->centre_x - r->x, dy = g->centre_y - r->y; /* FilterInvSquare |pixel - centre|^2 */          \
        g->rho2d = lanes_select(g->filtered, GAUSSIAN_FILTER_INV_SQUARE * (dx * dx + dy * dy), zero + INFINITY); \
        g->plane_depth = g->u * row[2][0] + g->v * row[2][1] + row[2][2];                                     \
    }
DEFINE_SPLAT_2D_GEOMETRY(double)
#if RR_LANES
DEFINE_SPLAT_2D_GEOMETRY(v4d)
#endif

/* The culls of Gaussian i, its mean at camera-space p (gaussian_cull.c). */
int cull_2d(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p);
int cull_3d_raster(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p);
/* The hits once the cull passed Gaussian i (gaussian_hit_2d.c, gaussian_hit_3d.c). */
int hit_2d_after_cull(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                      gaussian_hit *h);
int hit_2d_from_geometry(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                         const splat_2d_geometry_double *g, gaussian_hit *h);
int hit_3d_raster_after_cull(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p, gaussian_hit *h);
/* Gaussian i's rows of T (splat_rows), its mean at camera-space p. */
void gaussian_splat_rows(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p, double row[3][3]);
#if RR_LANES
/* splat_2d_geometry_of_double of four culled Gaussians, in lanes (gaussian_hit_2d.c). */
RR_LANES_TARGET void splat_2d_geometry_in_lanes(const gaussian_model *m, const unsigned prim[4], const gaussian_ray *r,
                                                const vec3 p[4], splat_2d_geometry_double g[4]);
#endif

#endif
