#include "gaussians/gaussian_hit.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/interval.h"
#include "core/lanes.h"
#include "core/rotation.h"

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

static const raster_rules inria_rules = {0.2, INFINITY, 0.3, 0.99, 0, 0.0, 1, 0, 0};
static const raster_rules inria_aa_rules = {0.2, INFINITY, 0.3, 0.99, 1, 2.5e-5, 1, 0, 0};
static const raster_rules inria_fov_minus_one_rules = {0.2, INFINITY, 0.3, 0.99, 0, 0.0, 1, 0, 1};
static const raster_rules gsplat_rules = {0.01, 1e10, 0.3, 0.999, 0, 0.0, 0, 1, 0};
static const raster_rules gsplat_aa_rules = {0.01, 1e10, 0.3, 0.999, 1, 0.0, 0, 1, 0};

static const raster_rules *raster_rules_of(gaussian_formation f)
{
    switch (f) {
    case GAUSSIAN_FORMATION_3DGS_ANTIALIASED: return &inria_aa_rules;
    case GAUSSIAN_FORMATION_3DGS_FOV_MINUS_ONE: return &inria_fov_minus_one_rules;
    case GAUSSIAN_FORMATION_GSPLAT: return &gsplat_rules;
    case GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED: return &gsplat_aa_rules;
    default: return &inria_rules;
    }
}

/* The rasterizers evaluate the Jacobian of the projection at the mean's
 * x/z and y/z clamped to [-neg, pos], tan(fov/2) = size / (2 f) (x: the
 * image's width, fx, cx; y: height, fy, cy). Inria's computeCov2D has no
 * principal point: limx = 1.3 tan_fovx either side of the optical axis,
 * tan_fovx = tan(focal2fov(fx, W) / 2); a principal point off the centre
 * (a transforms.json camera's) keeps that clamp, as an Inria rasterizer
 * given a shifted projection matrix does (it reads only tan_fovx). gsplat
 * v1.5.3's persp_proj (937e299 gsplat/cuda/include/Utils.cuh:514-519,
 * given K's cx, cy) reaches 0.3 tan(fov/2) past each image edge: pos = (W -
 * cx)/fx + 0.3 tan, neg = cx/fx + 0.3 tan. Written as 1.3 tan -+ the
 * principal point's offset, so that a centred one gives 1.3 tan bit for
 * bit under both. */
#define RASTER_CLAMP 1.3

static void jacobian_clamp(const raster_rules *rules, double size, double f, double c, double *neg, double *pos)
{
    double half = 0.5 * size, shift = rules->clamp_at_edges ? c - half : 0.0;
    *neg = (RASTER_CLAMP * half + shift) / f, *pos = (RASTER_CLAMP * half - shift) / f;
}

/* The wider of the two clamps' largest |x/z| (or |y/z|): gsplat's, as
 * max(W - cx, cx) >= W / 2 (its limits themselves, so never below
 * either rasterizer's). */
static double widest_clamp(double size, double f, double c)
{
    double neg, pos;
    jacobian_clamp(&gsplat_rules, size, f, c, &neg, &pos);
    return rr_fmax(neg, pos);
}

double gaussian_view_stretch(const camera_view *v)
{
    double lx = widest_clamp(v->width, v->fx, v->cx), ly = widest_clamp(v->height, v->fy, v->cy);
    return sqrt(1.0 + lx * lx + ly * ly) * rr_fmax(v->fx, v->fy) / rr_fmin(v->fx, v->fy);
}

/* fudan-zvg/4d-gaussian-splatting (63725f21) gives a transforms.json camera
 * with fl_x, fl_y, cx, cy FovX = FovY = -1 (scene/dataset_readers.py:
 * 275-293), which its rasterizer gets as tanfovx = tanfovy = tan(-0.5)
 * (gaussian_renderer/__init__.py:34-35): focal_x = W / (2 tanfovx),
 * focal_y = H / (2 tanfovy) (diff-gaussian-rasterization/cuda_rasterizer/
 * rasterizer_impl.cu:235-236), and computeCov2D's min(limx, max(-limx,
 * t.x/t.z)) with limx = 1.3 tanfovx < 0 is limx whatever t.x/t.z
 * (forward.cu:206-211). Nothing else reads them: the mean is projected by
 * the true projection matrix (forward.cu:446-448), in_frustum tests only
 * the view depth (auxiliary.h:153), the SH direction is camera -> mean
 * (forward.cu:480-482); the tile radius follows from this cov2D
 * (forward.cu:464-467). tan(-0.5), written out: */
#define FOV_MINUS_ONE_TAN (-0.54630248984379051326)

/* The pinned Jacobian's focal lengths (negative, as the CUDA's: cov2D
 * only sees their squares) and its clamped t.x/t.z = t.y/t.z. */
static void pinned_jacobian(int width, int height, double *fx, double *fy, double *t)
{
    *fx = width / (2.0 * FOV_MINUS_ONE_TAN), *fy = height / (2.0 * FOV_MINUS_ONE_TAN);
    *t = RASTER_CLAMP * FOV_MINUS_ONE_TAN;
}

/* The pinned Jacobian J = diag(fx, fy) / z [[1, 0, -t], [0, 1, -t]] has
 * |J|^2 <= max(fx, fy)^2 (1 + 2 t^2) / z^2 (the largest eigenvalue of I +
 * (t, t)(t, t)^T is 1 + 2 t^2): gaussian_view_stretch's bound with these
 * focal lengths and clamps, over the true camera's smaller focal length,
 * which turns pixels about the mean's (truly projected) image into
 * lengths at its depth. */
static double pinned_stretch(const camera_view *v)
{
    double fx, fy, t;
    pinned_jacobian(v->width, v->height, &fx, &fy, &t);
    return sqrt(1.0 + 2.0 * t * t) * rr_fmax(fabs(fx), fabs(fy)) / rr_fmin(v->fx, v->fy);
}

double gaussian_view_stretch_of(gaussian_formation f, const camera_view *v)
{
    return f == GAUSSIAN_FORMATION_3DGS_FOV_MINUS_ONE ? pinned_stretch(v) : gaussian_view_stretch(v);
}

void gaussian_ray_init(gaussian_ray *r, const camera_view *view, const xform *xf, double x, double y, vec3 org,
                       vec3 dir)
{
    for (int k = 0; k < 3; k++) {
        const vec3 a = view->axis[k];
        for (int j = 0; j < 3; j++) /* axis_k . (column j of the object's linear part) */
            r->m[k][j] = a.x * xf->r[0][j] + a.y * xf->r[1][j] + a.z * xf->r[2][j];
        r->m[k][3] = v3_dot(a, v3_sub(xf->t, view->position));
    }
    r->fx = view->fx, r->fy = view->fy, r->cx = view->cx, r->cy = view->cy;
    r->width = view->width, r->height = view->height;
    r->x = x, r->y = y;
    r->eye = xform_inverse_point(xf, view->position);
    r->org = xform_inverse_point(xf, org);
    r->dir = xform_inverse_vector(xf, dir);
    r->depth_per_t = v3_dot(dir, view->axis[2]);
    r->tmin = 0.0, r->tmax = INFINITY;
    double col2[3] = {0, 0, 0};
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 3; k++)
            col2[j] += xf->r[k][j] * xf->r[k][j];
    r->scale = sqrt(rr_fmax(col2[0], rr_fmax(col2[1], col2[2]))) * (1 + 1e-9);
    r->stretch = gaussian_view_stretch(view);
    r->stretch_fov_minus_one = pinned_stretch(view);
}

/* The rotation of a unit quaternion (w, x, y, z), row-major. */
static void quaternion_matrix(const float *q, double R[3][3]) { quat_unit_matrix(q[0], q[1], q[2], q[3], R); }

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

/* Gaussian i's first two axes times their scales (object space). */
static void splat_axes(const gaussian_model *m, size_t i, double u[3], double v[3])
{
    const float *s = &m->scale[3 * i];
    double R[3][3];
    quaternion_matrix(&m->rotation[4 * i], R);
    for (int a = 0; a < 3; a++)
        u[a] = R[a][0] * s[0], v[a] = R[a][1] * s[1];
}

/* Gaussian i's rows of T (splat_rows), its mean at camera-space p. */
static void gaussian_splat_rows(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p, double row[3][3])
{
    double u[3], v[3], pc[3] = {p.x, p.y, p.z};
    splat_axes(m, i, u, v);
    splat_rows_double(r, u, v, pc, row);
}

/* The radius, in scales, of the circle whose image's centre the 2DGS
 * low-pass filter is centred on: e0ed020's compute_aabb takes the dual
 * conic of the circle of radius cutoff = 3 (TIGHTBBOX 0; since 909dd85,
 * 2024-06-28), the older computeCenter the unit circle's. */
static double filter_circle(const gaussian_model *m)
{
    return gaussian_formation_of(m) == GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? 1.0 : 3.0;
}

/* Entry (a, b) of the dual conic T diag(c^2, c^2, -1) T^T of the splat's
 * circle of radius c (scales), from rows a and b of T and cc = c^2 (either
 * lane type). */
#define DUAL_CONIC(a, b, cc) ((cc) * ((a)[0] * (b)[0] + (a)[1] * (b)[1]) - (a)[2] * (b)[2])

static double clamp_alpha(double alpha_max, double opacity, double g) { return rr_fmin(alpha_max, opacity * g); }

/* The image of camera-space point p minus the ray's raster position. */
static void image_offset(const gaussian_ray *r, vec3 p, double *dx, double *dy)
{
    *dx = r->fx * p.x / p.z + r->cx - r->x, *dy = r->fy * p.y / p.z + r->cy - r->y;
}

/* The rasterizers' tile rule (getRect, auxiliary.h): a Gaussian is only
 * evaluated at the pixels of the 16x16 tiles that the square of the given
 * radius about `centre` (pixel-index coordinates) touches. (Not the
 * renderer's tiles of work, render.c's TILE: these are the CUDA's.) */
enum { RASTER_TILE = 16 };

/* getRect's min(grid, max(0, (int)v)): the CUDA's (int) cast truncates
 * toward 0; the clamps keep it defined for any v. */
static int tile_index(double v, int grid)
{
    return (int)rr_fmin((double)grid, rr_fmax(0.0, trunc(rr_fmax(-1.0, rr_fmin(1e9, v)))));
}

static int in_rasterizer_tiles(const gaussian_ray *r, double cx, double cy, double radius)
{
    const int side = RASTER_TILE;
    int gx = (r->width + side - 1) / side, gy = (r->height + side - 1) / side;
    double px = floor(r->x), py = floor(r->y);
    int x0 = tile_index((cx - radius) / side, gx), x1 = tile_index((cx + radius + side - 1) / side, gx);
    int y0 = tile_index((cy - radius) / side, gy), y1 = tile_index((cy + radius + side - 1) / side, gy);
    return px >= (double)x0 * side && px < (double)x1 * side && py >= (double)y0 * side && py < (double)y1 * side;
}

/* 2DGS's tile radius: at e0ed020 (preprocessCUDA) the 3-sigma circle's
 * image's half extent, at least 3 x FilterSize (0.707106), rounded up;
 * up to 3a9357f, 3 times the unit circle's image's half extent. */
static int in_2dgs_tiles(const gaussian_ray *r, const double row[3][3], double c, double centre_x, double centre_y)
{
    double d22 = DUAL_CONIC(row[2], row[2], c * c);
    double hx = centre_x * centre_x - DUAL_CONIC(row[0], row[0], c * c) / d22;
    double hy = centre_y * centre_y - DUAL_CONIC(row[1], row[1], c * c) / d22;
    /* the extent does not depend on where the pixel grid's origin is; the
     * centre in pixel-index coordinates (ndc2pix's (W-1)/2) is 0.5 less */
    double extent = sqrt(rr_fmax(1e-4, rr_fmax(hx, hy)));
    double radius = c == 1.0 ? ceil(3.0 * extent) : ceil(rr_fmax(extent, c * 0.707106f));
    return in_rasterizer_tiles(r, centre_x - 0.5, centre_y - 0.5, radius);
}

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
static double larger_scale(const gaussian_model *m, size_t i)
{
    const float *s = &m->scale[3 * i];
    return m->kind == GAUSSIAN_2D ? rr_fmax(s[0], s[1]) : rr_fmax(s[0], rr_fmax(s[1], s[2]));
}

/* The 2DGS cull of Gaussian i, its mean at camera-space p. */
static int cull_2d(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    double pc[3] = {p.x, p.y, p.z};
    return cull_2d_double(r, filter_circle(m), pc, larger_scale(m, i));
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

/* splat_2d_geometry_of_double of four culled Gaussians (prim; p: their
 * camera-space means), computed in lanes. Their axes come from the scalar
 * splat_axes (one rotation rule), gathered in registers: doubles stored
 * one by one and loaded as a vector stalled on store forwarding (perf
 * annotate). */
RR_LANES_TARGET static void splat_2d_geometry_in_lanes(const gaussian_model *m, const unsigned prim[4],
                                                       const gaussian_ray *r, const vec3 p[4],
                                                       splat_2d_geometry_double g[4])
{
    double u[4][3], v[4][3];
    for (int j = 0; j < 4; j++)
        splat_axes(m, prim[j], u[j], v[j]);
    v4d U[3], V[3], P[3] = {{p[0].x, p[1].x, p[2].x, p[3].x}, {p[0].y, p[1].y, p[2].y, p[3].y},
                            {p[0].z, p[1].z, p[2].z, p[3].z}};
    for (int a = 0; a < 3; a++)
        U[a] = (v4d){u[0][a], u[1][a], u[2][a], u[3][a]}, V[a] = (v4d){v[0][a], v[1][a], v[2][a], v[3][a]};
    splat_2d_geometry_v4d four;
    splat_rows_v4d(r, U, V, P, four.row);
    splat_2d_geometry_of_v4d(r, filter_circle(m), &four);
    for (int j = 0; j < 4; j++) {
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                g[j].row[a][b] = four.row[a][b][j];
        g[j].cz = four.cz[j], g[j].u = four.u[j], g[j].v = four.v[j], g[j].rho3d = four.rho3d[j];
        g[j].rho2d = four.rho2d[j], g[j].centre_x = four.centre_x[j], g[j].centre_y = four.centre_y[j];
        g[j].plane_depth = four.plane_depth[j], g[j].filtered = four.filtered[j] != 0;
    }
}
#endif

/* Whether the near skip takes the centre's view depth where the filter
 * wins: forward.cu renderCUDA's `depth = (rho3d <= rho2d) ? hit : Tw.z;
 * if (depth < near_n) continue;` from 661d224 (2024-05-06, the first
 * commit 2DGS pinned; fw:384-385) to 7bdbd51 (2024-08-28, fw:365-366);
 * e0ed020 ("fix near cull", fw:369-372) takes the plane hit's depth at
 * every pixel. */
static int near_by_centre_where_filtered(const gaussian_model *m)
{
    gaussian_formation f = gaussian_formation_of(m);
    return f == GAUSSIAN_FORMATION_2DGS_CENTER_NEAR || f == GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE;
}

/* Whether Gaussian i's plane holds the camera centre exactly (p: its
 * camera-space mean): forward.cu's DUAL_VISIABLE cull, -p_view . n == 0
 * (fw:209-214 at e0ed020 and 7bdbd51; since 3a9357f), with the normal as
 * t_u x t_v in camera space (so under an object's uneven scale too). */
static int splat_edge_on(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    double R[3][3];
    quaternion_matrix(&m->rotation[4 * i], R);
    vec3 tu = cam_vector(r->m, v3(R[0][0], R[1][0], R[2][0])), tv = cam_vector(r->m, v3(R[0][1], R[1][1], R[2][1]));
    return v3_dot(p, v3_cross(tu, tv)) == 0;
}

/* The tile rule's filter where the filter's circle reaches behind the
 * camera's plane (its image a hyperbola, not an ellipse): forward.cu at
 * e0ed020 goes on with the same formulas whatever the sign of the dual
 * conic's d = T_w . T_w (c^2, c^2, -1) (compute_aabb, fw:119-145, stops
 * only at d == 0; preprocessCUDA fw:226-236 takes the tiles of its
 * point_image and extent), and renderCUDA (fw:362-366) filters about that
 * point_image: the hyperbola's centre. So with tileRule the splat is drawn
 * in the hyperbola's tiles, filtered about its centre (GAUSSIANS.md says
 * which of those pixels the bounds can miss). 0 where d == 0: culled. */
static int hyperbola_filter(const gaussian_model *m, const gaussian_ray *r, const splat_2d_geometry_double *g,
                            splat_2d_geometry_double *out)
{
    double c = filter_circle(m), d22 = DUAL_CONIC(g->row[2], g->row[2], c * c);
    if (d22 == 0)
        return 0;
    *out = *g;
    out->centre_x = DUAL_CONIC(g->row[0], g->row[2], c * c) / d22;
    out->centre_y = DUAL_CONIC(g->row[1], g->row[2], c * c) / d22;
    double dx = out->centre_x - r->x, dy = out->centre_y - r->y;
    out->rho2d = GAUSSIAN_FILTER_INV_SQUARE * (dx * dx + dy * dy);
    out->filtered = 1;
    return 1;
}

/* Gaussian i's 2DGS hit from its geometry at the pixel (p: its
 * camera-space mean). */
static int hit_2d_from_geometry(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                                const splat_2d_geometry_double *g, gaussian_hit *h)
{
    splat_2d_geometry_double hyperbola;
    if (g->cz == 0)
        return 0;
    if (m->tile_rule && !g->filtered) {
        if (!hyperbola_filter(m, r, g, &hyperbola))
            return 0;
        g = &hyperbola;
    }
    /* where the filter wins the hit is placed at the centre's depth, the
     * point its bounds and windows hold. The near skip takes the plane
     * hit's depth even there (forward.cu since e0ed020, the commit 2DGS
     * pins), or that centre's depth (the older rule): then filter pixels
     * whose ray meets the plane nearer than 0.2, or behind the camera, are
     * drawn (the centre is beyond 0.2: cull_2d). A splat seen exactly
     * edge-on (its plane holds the camera centre), which forward.cu culls
     * (DUAL_VISIABLE), shows nothing: under e0ed020's rule every ray meets
     * its plane at the camera centre, at view depth 0; under the older
     * one its filter pixels are culled by name */
    double depth = g->rho3d <= g->rho2d ? g->plane_depth : g->row[2][2];
    if (g->plane_depth < GAUSSIAN_NEAR) {
        if (!near_by_centre_where_filtered(m) || depth < GAUSSIAN_NEAR || splat_edge_on(m, i, r, p))
            return 0;
    }
    double rho = rr_fmin(g->rho3d, g->rho2d), t = depth / r->depth_per_t;
    /* alpha below 1/255 for certain (opacity <= 1): exp is the costly
     * part, and the exact test follows (a test with the opacity's own log
     * cost a log per candidate) */
    if (!(rho <= gaussian_alpha_reach2(1.0) + 1e-9) || !(t >= r->tmin && t < r->tmax))
        return 0;
    double alpha = clamp_alpha(GAUSSIAN_ALPHA_MAX, m->opacity[i], exp(-0.5 * rho));
    if (alpha < GAUSSIAN_ALPHA_MIN)
        return 0;
    if (m->tile_rule && (!g->filtered || !in_2dgs_tiles(r, g->row, filter_circle(m), g->centre_x, g->centre_y)))
        return 0;
    const float *mu = &m->mean[3 * i];
    vec3 dir = v3_sub(v3(mu[0], mu[1], mu[2]), r->eye);
    double key = order == GAUSSIAN_ORDER_CENTER_DEPTH ? p.z / r->depth_per_t : t;
    *h = (gaussian_hit){(float)key, (float)t, (float)alpha,
                        {(float)dir.x, (float)dir.y, (float)dir.z}, 0, (unsigned)i};
    return 1;
}

/* Gaussian i's 2DGS hit once cull_2d passed it (p: its camera-space mean). */
static int hit_2d_after_cull(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                             gaussian_hit *h)
{
    splat_2d_geometry_double g;
    gaussian_splat_rows(m, i, r, p, g.row);
    splat_2d_geometry_of_double(r, filter_circle(m), &g);
    return hit_2d_from_geometry(m, i, order, r, p, &g, h);
}

int gaussian_hit_2d(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r,
                    gaussian_hit *h)
{
    vec3 p = camera_mean(m, i, r);
    return cull_2d(m, i, r, p) && hit_2d_after_cull(m, i, order, r, p, h);
}

int gaussian_filter_centre_2d(const gaussian_model *m, size_t i, const gaussian_ray *r, double *x, double *y)
{
    splat_2d_geometry_double g;
    gaussian_splat_rows(m, i, r, camera_mean(m, i, r), g.row);
    splat_2d_geometry_of_double(r, filter_circle(m), &g);
    if (g.filtered)
        *x = g.centre_x, *y = g.centre_y;
    return g.filtered;
}

/* The focal lengths and the clamped x/z, y/z of the EWA Jacobian at
 * camera-space p: the camera's, clamped (jacobian_clamp), or the pinned
 * ones of a rasterizer handed FoV = -1 (pinned_jacobian). */
static void jacobian_at(const raster_rules *rules, const gaussian_ray *r, vec3 p, double *fx, double *fy, double *tx,
                        double *ty)
{
    if (rules->fov_minus_one) {
        pinned_jacobian(r->width, r->height, fx, fy, tx);
        *ty = *tx;
        return;
    }
    double negx, posx, negy, posy;
    jacobian_clamp(rules, r->width, r->fx, r->cx, &negx, &posx);
    jacobian_clamp(rules, r->height, r->fy, r->cy, &negy, &posy);
    *fx = r->fx, *fy = r->fy;
    *tx = rr_fmin(posx, rr_fmax(-negx, p.x / p.z)), *ty = rr_fmin(posy, rr_fmax(-negy, p.y / p.z));
}

/* The 3D rasterizers' image of Gaussian i at the ray's pixel (forward.cu
 * preprocessCUDA, computeCov2D, renderCUDA): cov2D = J W Sigma W^T J^T
 * with J at the mean's clamped x/z, y/z; + dilation on the diagonal;
 * power = -d^T cov2D^-1 d / 2 of d = the mean's image - the pixel, skipped
 * above 0; alpha = min(alpha_max, opacity' exp(power)). Sigma in camera
 * space is L L^T with L = M R S (M: object -> camera). 1 and *alpha set,
 * or 0 (culled, or alpha below 1/255). */
static int raster_alpha(const gaussian_model *m, size_t i, const raster_rules *rules, const gaussian_ray *r,
                        vec3 p, double *alpha)
{
    const float *s = &m->scale[3 * i];
    double dx, dy;
    image_offset(r, p, &dx, &dy); /* (the cheap and sure reach test is cull_3d_raster's, run first) */
    double R[3][3], jx, jy, tx, ty;
    jacobian_at(rules, r, p, &jx, &jy, &tx, &ty);
    quaternion_matrix(&m->rotation[4 * i], R);
    vec3 j0 = v3(jx / p.z, 0, -jx * tx / p.z), j1 = v3(0, jy / p.z, -jy * ty / p.z);
    double c00 = 0, c01 = 0, c11 = 0;
    for (int a = 0; a < 3; a++) { /* column a of L = M R S, through J */
        vec3 col = v3_scale(cam_vector(r->m, v3(R[0][a], R[1][a], R[2][a])), s[a]);
        double ja = v3_dot(j0, col), jb = v3_dot(j1, col);
        c00 += ja * ja, c01 += ja * jb, c11 += jb * jb;
    }
    double det0 = c00 * c11 - c01 * c01;
    c00 += rules->dilation, c11 += rules->dilation;
    double det = c00 * c11 - c01 * c01;
    if (!(det > 0))
        return 0;
    double power = -0.5 * (c11 * dx * dx + c00 * dy * dy) / det + c01 * dx * dy / det;
    if (power > 0)
        return 0;
    double opacity = m->opacity[i];
    if (rules->antialiased)
        opacity *= sqrt(rr_fmax(rules->aa_floor, det0 / det));
    *alpha = clamp_alpha(rules->alpha_max, opacity, exp(power));
    if (*alpha < GAUSSIAN_ALPHA_MIN)
        return 0;
    if (m->tile_rule && rules->tiles_cut) { /* radius ceil(3 sqrt(lambda_max)), lambda from mid +- sqrt(max(0.1, mid^2 - det)) */
        double mid = 0.5 * (c00 + c11), radius = ceil(3.0 * sqrt(mid + sqrt(rr_fmax(0.1, mid * mid - det))));
        return in_rasterizer_tiles(r, dx + r->x - 0.5, dy + r->y - 0.5, radius);
    }
    return 1;
}

/* The 3D rasterizers' cull of Gaussian i (cull_3d), its mean at
 * camera-space p. */
static int cull_3d_raster(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    double pc[3] = {p.x, p.y, p.z};
    return cull_3d_double(r, raster_rules_of(gaussian_formation_of(m)), pc, larger_scale(m, i));
}

static int hit_3d_raster_after_cull(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p, gaussian_hit *h)
{
    const raster_rules *rules = raster_rules_of(gaussian_formation_of(m));
    const float *mu = &m->mean[3 * i];
    double alpha, t = p.z / r->depth_per_t; /* the centre's depth: the key and where the bounds hold the ray */
    if (!(p.z > rules->near && p.z <= rules->far) || !(t >= r->tmin && t < r->tmax) || !raster_alpha(m, i, rules, r, p, &alpha))
        return 0;
    vec3 dir = v3_sub(v3(mu[0], mu[1], mu[2]), r->eye);
    *h = (gaussian_hit){(float)t, (float)t, (float)alpha, {(float)dir.x, (float)dir.y, (float)dir.z}, 0, (unsigned)i};
    return 1;
}

/* x in the Gaussian's canonical frame: S^-1 R^T x. */
static vec3 canonical(const double R[3][3], const float *s, vec3 x)
{
    return v3((R[0][0] * x.x + R[1][0] * x.y + R[2][0] * x.z) / s[0],
              (R[0][1] * x.x + R[1][1] * x.y + R[2][1] * x.z) / s[1],
              (R[0][2] * x.x + R[1][2] * x.y + R[2][2] * x.z) / s[2]);
}

int gaussian_hit_3dgrt(const gaussian_model *m, size_t i, const gaussian_ray *r, gaussian_hit *h)
{
    const float *mu = &m->mean[3 * i];
    double R[3][3];
    quaternion_matrix(&m->rotation[4 * i], R);
    vec3 o = canonical(R, &m->scale[3 * i], v3_sub(r->org, v3(mu[0], mu[1], mu[2])));
    vec3 d = canonical(R, &m->scale[3 * i], r->dir);
    double dd = v3_dot(d, d);
    if (!(dd > 0))
        return 0;
    double t = -v3_dot(o, d) / dd; /* the closest approach: the maximum response along the ray */
    vec3 closest = v3_add(o, v3_scale(d, t));
    double response = exp(-0.5 * v3_dot(closest, closest));
    double alpha = clamp_alpha(GAUSSIAN_ALPHA_MAX, m->opacity[i], response);
    /* both strict, as gaussianParticles.slang's hit() accepts */
    if (!(response > GAUSSIAN_GRT_MIN_RESPONSE) || !(alpha > GAUSSIAN_ALPHA_MIN) || !(t >= r->tmin && t < r->tmax))
        return 0;
    *h = (gaussian_hit){(float)t, (float)t, (float)alpha, {(float)r->dir.x, (float)r->dir.y, (float)r->dir.z}, 0,
                        (unsigned)i};
    return 1;
}

/* The kernel radius (in scales) beyond which alpha < 1/255 (gaussian_alpha_reach2);
 * 3DGRT also drops responses at or below GAUSSIAN_GRT_MIN_RESPONSE. 0:
 * never seen. */
static double kernel_reach(const gaussian_model *m, size_t i)
{
    double r2 = gaussian_alpha_reach2(m->opacity[i]);
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        r2 = rr_fmin(r2, -2.0 * log(GAUSSIAN_GRT_MIN_RESPONSE));
    return r2 > 0 ? sqrt(r2) : 0.0;
}

/* Only 2D models' hits can lie off the centre's depth (gaussian_hit.h). */
double gaussian_traversal_pad(const gaussian_model *m, double s, double depth_per_t)
{
    if (m->kind != GAUSSIAN_2D)
        return 0.0;
    /* the hit lies in the splat's plane within 3.33 scales of the centre
     * (rho3d <= 2 ln 255), or has the centre's depth while the filter's
     * circle point lies within 3 scales (the filter won) */
    return traversal_pad_double(s, depth_per_t);
}

double gaussian_key_lead(const gaussian_model *m, gaussian_order order, double s, double depth_per_t)
{
    /* the same bound: a centre-depth key is the centre's, within 3.33
     * scales of its 2D hit (gaussian_traversal_pad) */
    return order == GAUSSIAN_ORDER_CENTER_DEPTH ? gaussian_traversal_pad(m, s, depth_per_t) : 0.0;
}

static aabb bounds_with_reach(const gaussian_model *m, size_t i, const double view_reach[3]);

double gaussian_filter_near(double min_scale, double max_scale)
{
    return GAUSSIAN_NEAR * min_scale / (max_scale * max_scale);
}

/* 2DGS: rho2d = 2 |d|^2 <= 2 ln(255 o): the ray's pixel lies within
 * sqrt(ln(255 o)) pixels of the centre of the image of the filter's circle
 * (c scales), which is the image of a point P of its disc (filter_pole,
 * *along_plane: in the splat's plane); at P's view depth (at most distance
 * + |P - mean|) a pixel spans depth / focal (*across_view: at P's view
 * depth, so across the view axis). */
static void filter_2d_reach(const gaussian_model *m, size_t i, const gaussian_view_bound *v, double *along_plane,
                            double *across_view)
{
    double px2 = 0.5 * gaussian_alpha_reach2(m->opacity[i]); /* exact: halving a double */
    *along_plane = *across_view = 0.0;
    if (!(px2 > 0))
        return;
    const float *s = &m->scale[3 * i];
    double radius = filter_circle(m) * rr_fmax(s[0], s[1]);
    double pole = v->near > 0 ? rr_fmin(radius, filter_pole_double(radius, v->near)) : radius;
    *along_plane = pole, *across_view = sqrt(px2) * (v->distance + pole) / v->focal;
}

/* The 3D rasterizers: the ray through a pixel d pixels from the mean's
 * image passes the mean's depth z within |d| z / f_min of it, and alpha >=
 * 1/255 needs |d|^2 <= 2 ln(255 o) lambda_max(cov2D), lambda_max <=
 * (f_max / z)^2 (1 + lim^2) s^2 + dilation: within k sqrt(stretch^2 s^2 +
 * dilation (z / f_min)^2), z at most the distance, across the view axis
 * (the hit is at the mean's view depth). */
static double footprint_3d_reach(const gaussian_model *m, size_t i, const gaussian_view_bound *v)
{
    double k2 = gaussian_alpha_reach2(m->opacity[i]);
    if (!(k2 > 0))
        return 0.0;
    const float *s = &m->scale[3 * i];
    double sigma = rr_fmax(s[0], rr_fmax(s[1], s[2])) * v->stretch, z = v->distance / v->focal;
    return sqrt(k2 * (sigma * sigma + raster_rules_of(gaussian_formation_of(m))->dilation * z * z));
}

/* The screen footprint's reach about the mean: a part that can point any
 * way, and a part across the view axis. */
static void view_reach_parts(const gaussian_model *m, size_t i, const gaussian_view_bound *v, double *any,
                             double *across)
{
    switch (gaussian_formation_of(m)) {
    case GAUSSIAN_FORMATION_2DGS:
    case GAUSSIAN_FORMATION_2DGS_CENTER_NEAR:
    case GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE: filter_2d_reach(m, i, v, any, across); return;
    case GAUSSIAN_FORMATION_3DGRT: *any = *across = 0.0; return;
    default: *any = 0.0, *across = footprint_3d_reach(m, i, v); return;
    }
}

double gaussian_view_reach(const gaussian_model *m, size_t i, const gaussian_view_bound *v)
{
    double any, across;
    view_reach_parts(m, i, v, &any, &across);
    return any + across;
}

/* How far along unit axis e (component n_e of the view axis n) a vector of
 * length 1 across a view axis within `cone` radians of n reaches: across
 * the axis a it reaches sqrt(1 - (a.e)^2), and the least |a.e| in the cone
 * is sin(max(0, asin|n_e| - cone)). 1 without a view axis. */
static double across_view_extent(const gaussian_view_bound *v, double n_e)
{
    if (!(v->cone < M_PI / 2) || v3_dot(v->axis, v->axis) == 0 || !(fabs(n_e) <= 1.0))
        return 1.0;
    /* 1e-6 more cone: asin near 1 magnifies n_e's rounding (1e-16 -> 1.5e-8 rad) */
    double tilt = asin(fabs(n_e)) - v->cone - 1e-6;
    return tilt > 0 ? cos(tilt) * (1 + 1e-9) + 1e-12 : 1.0;
}

aabb gaussian_view_bounds(const gaussian_model *m, size_t i, const gaussian_view_bound *v)
{
    double any, across, n[3] = {v->axis.x, v->axis.y, v->axis.z}, reach[3];
    view_reach_parts(m, i, v, &any, &across);
    for (int a = 0; a < 3; a++)
        reach[a] = any + across * across_view_extent(v, n[a]);
    return bounds_with_reach(m, i, reach);
}

void gaussian_prefetch_cull(const gaussian_model *m, size_t i)
{
    __builtin_prefetch(&m->mean[3 * i]);
    __builtin_prefetch(&m->scale[3 * i]);
}

void gaussian_prefetch_hit(const gaussian_model *m, size_t i)
{
    __builtin_prefetch(&m->rotation[4 * i]);
    __builtin_prefetch(&m->opacity[i]);
}

void gaussian_prefetch_sh(const gaussian_model *m, size_t i)
{
    const float *sh = &m->sh[(size_t)3 * m->sh_coeffs * i];
    uintptr_t last = (uintptr_t)(sh + 3 * (size_t)m->sh_coeffs) - 1;
    for (uintptr_t line = (uintptr_t)sh & ~(uintptr_t)63; line <= last; line += 64) /* each line once */
        __builtin_prefetch((const void *)line);
}

int gaussian_cull(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 *p)
{
    *p = camera_mean(m, i, r);
    if (m->kind == GAUSSIAN_2D)
        return cull_2d(m, i, r, *p);
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        return 1; /* its test is the ray's closest approach: nothing cheaper */
    return cull_3d_raster(m, i, r, *p);
}

float gaussian_key_floor(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    /* rounding is monotone: a hit's key (float)t >= (float)floor for t >=
     * floor, and compositing takes keys strictly below it */
    if (m->kind == GAUSSIAN_2D) /* within 3.33 scales of the centre's depth (gaussian_traversal_pad) */
        return (float)key_floor_2d_double(r, p.z, larger_scale(m, i));
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        return -INFINITY; /* the closest approach: not tied to the centre's depth */
    return (float)centre_key_double(r, p.z); /* the rasterizers' key is the centre's depth, computed alike */
}

/* Keeps cand[k] (k < n) that the cull passes, at the front, with p and
 * key floor (gaussian_cull_candidates). */
static size_t keep_culled(gaussian_candidate *cand, size_t kept, unsigned prim, vec3 p, float key_floor, unsigned ray)
{
    cand[kept] = (gaussian_candidate){p, key_floor, prim, ray};
    return kept + 1;
}

enum { PREFETCH_AHEAD = 8 };
#if RR_LANES
/* The candidates' culls and key floors four at a time in lanes (cull_2d_v4d,
 * cull_3d_v4d: the cull led the time of 2DGS rendering in a profile, a ray
 * culls about 190 candidates); returns how many it took (a multiple of
 * four), *kept advanced as keep_culled does. */
RR_LANES_TARGET static size_t cull_in_lanes(const gaussian_model *m, const gaussian_ray *r, gaussian_candidate *cand,
                                            size_t n, unsigned ray, size_t *kept)
{
    const raster_rules *rules = m->kind == GAUSSIAN_3D ? raster_rules_of(gaussian_formation_of(m)) : NULL;
    double circle = filter_circle(m);
    size_t k = 0;
    for (; k + 4 <= n; k += 4) {
        unsigned prim[4];
        const float *mu[4], *sc[4];
        for (int j = 0; j < 4; j++) {
            if (k + j + PREFETCH_AHEAD < n)
                gaussian_prefetch_cull(m, cand[k + j + PREFETCH_AHEAD].prim);
            prim[j] = cand[k + j].prim;
            mu[j] = &m->mean[3 * prim[j]], sc[j] = &m->scale[3 * prim[j]];
        }
        /* the lanes built in registers: doubles stored one by one and
         * loaded as a vector stalled on store forwarding (perf annotate) */
        v4d mean[3] = {v4d_gather(mu, 0), v4d_gather(mu, 1), v4d_gather(mu, 2)}, p[3], floor;
        v4d s = rules ? v4d_max(v4d_gather(sc, 0), v4d_max(v4d_gather(sc, 1), v4d_gather(sc, 2)))
                      : v4d_max(v4d_gather(sc, 0), v4d_gather(sc, 1)); /* larger_scale */
        camera_point_v4d(r->m, mean, p);
        int keep = v4l_bits(rules ? cull_3d_v4d(r, rules, p, s) : cull_2d_v4d(r, circle, p, s));
        floor = rules ? centre_key_v4d(r, p[2]) : key_floor_2d_v4d(r, p[2], s); /* gaussian_key_floor */
        v4f key_floor = __builtin_convertvector(floor, v4f);
        /* without a branch (whether a lane is kept is a coin toss): every
         * lane is written where the next kept one goes, at or below its own
         * slot, which the loop above has read */
        for (int j = 0; j < 4; j++)
            *kept = keep_culled(cand, *kept, prim[j], v3(p[0][j], p[1][j], p[2][j]), key_floor[j], ray) -
                    !(keep >> j & 1);
    }
    return k;
}
#endif

size_t gaussian_cull_candidates(const gaussian_model *m, const gaussian_ray *r, gaussian_candidate *cand, size_t n,
                                unsigned ray)
{
    size_t kept = 0, k = 0;
#if RR_LANES /* (3DGRT has no cull) */
    if (gaussian_formation_of(m) != GAUSSIAN_FORMATION_3DGRT && rr_lanes_available())
        k = cull_in_lanes(m, r, cand, n, ray, &kept);
#endif
    for (; k < n; k++) {
        if (k + PREFETCH_AHEAD < n)
            gaussian_prefetch_cull(m, cand[k + PREFETCH_AHEAD].prim);
        unsigned prim = cand[k].prim;
        vec3 p;
        if (gaussian_cull(m, prim, r, &p))
            kept = keep_culled(cand, kept, prim, p, gaussian_key_floor(m, prim, r, p), ray);
    }
    for (size_t j = 0; j < kept; j++) /* what their evaluation reads */
        gaussian_prefetch_hit(m, cand[j].prim);
    return kept;
}

int gaussian_hit_after_cull(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                            gaussian_hit *h)
{
    if (m->kind == GAUSSIAN_2D)
        return hit_2d_after_cull(m, i, order, r, p, h);
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        return gaussian_hit_3dgrt(m, i, r, h);
    return hit_3d_raster_after_cull(m, i, r, p, h);
}

int gaussian_hits_after_cull4(const gaussian_model *m, const unsigned prim[4], gaussian_order order,
                              const gaussian_ray *r, const vec3 p[4], gaussian_hit h[4])
{
    int found = 0;
#if RR_LANES
    if (m->kind == GAUSSIAN_2D && rr_lanes_available()) {
        splat_2d_geometry_double g[4];
        splat_2d_geometry_in_lanes(m, prim, r, p, g);
        for (int j = 0; j < 4; j++)
            found |= hit_2d_from_geometry(m, prim[j], order, r, p[j], &g[j], &h[j]) << j;
        return found;
    }
#endif
    for (int j = 0; j < 4; j++)
        found |= gaussian_hit_after_cull(m, prim[j], order, r, p[j], &h[j]) << j;
    return found;
}

#ifdef RR_DCHECKS
/* Whether a lane's splat_2d_geometry differs in any bit from one
 * Gaussian's: the hits' floats hide a double's last bits. */
static int geometry_differs(const splat_2d_geometry_double *a, const splat_2d_geometry_double *b)
{
    if (memcmp(a->row, b->row, sizeof a->row) || memcmp(&a->cz, &b->cz, sizeof a->cz))
        return 1;
    if (a->cz == 0)
        return 0;
    double x[] = {a->u, a->v, a->rho3d, a->rho2d, a->centre_x, a->centre_y, a->plane_depth};
    double y[] = {b->u, b->v, b->rho3d, b->rho2d, b->centre_x, b->centre_y, b->plane_depth};
    return memcmp(x, y, sizeof x) || a->filtered != b->filtered;
}

int gaussian_2d_geometry_lanes_differ(const gaussian_model *m, const unsigned prim[4], const gaussian_ray *r,
                                      const vec3 p[4])
{
    int differ = 0;
#if RR_LANES
    if (m->kind != GAUSSIAN_2D || !rr_lanes_available())
        return 0;
    splat_2d_geometry_double four[4], one;
    splat_2d_geometry_in_lanes(m, prim, r, p, four);
    for (int j = 0; j < 4; j++) {
        gaussian_splat_rows(m, prim[j], r, p[j], one.row);
        splat_2d_geometry_of_double(r, filter_circle(m), &one);
        differ |= geometry_differs(&one, &four[j]) << j;
    }
#else
    (void)m, (void)prim, (void)r, (void)p;
#endif
    return differ;
}
#endif

int gaussian_hit_any(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, gaussian_hit *h)
{
    vec3 p;
    return gaussian_cull(m, i, r, &p) && gaussian_hit_after_cull(m, i, order, r, p, h);
}

aabb gaussian_bounds(const gaussian_model *m, size_t i, double view_reach)
{
    double reach[3] = {view_reach, view_reach, view_reach};
    return bounds_with_reach(m, i, reach);
}

static aabb bounds_with_reach(const gaussian_model *m, size_t i, const double view_reach[3])
{
    const float *mu = &m->mean[3 * i], *s = &m->scale[3 * i];
    double R[3][3], k = kernel_reach(m, i);
    quaternion_matrix(&m->rotation[4 * i], R);
    aabb b;
    double c[3] = {mu[0], mu[1], mu[2]}, lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        double e2 = 0;
        for (int j = 0; j < 3; j++) /* a 2D Gaussian's third scale is 0 */
            e2 += (R[a][j] * s[j]) * (R[a][j] * s[j]);
        double e = rr_fmax(k * sqrt(e2), view_reach[a]);
        /* float rounding never clips a Gaussian (core/interval.h) */
        interval box = interval_widen(interval_around(c[a], e), interval_float_room(e, c[a]));
        lo[a] = box.lo, hi[a] = box.hi;
    }
    b.lo = v3(lo[0], lo[1], lo[2]), b.hi = v3(hi[0], hi[1], hi[2]);
    return b;
}

