#include "gaussian_hit.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rotation.h"

/* The 3D rasterizers' rules (issue 29), each read in its source:
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
} raster_rules;

static const raster_rules inria_rules = {0.2, INFINITY, 0.3, 0.99, 0, 0.0, 1, 0};
static const raster_rules inria_aa_rules = {0.2, INFINITY, 0.3, 0.99, 1, 2.5e-5, 1, 0};
static const raster_rules gsplat_rules = {0.01, 1e10, 0.3, 0.999, 0, 0.0, 0, 1};
static const raster_rules gsplat_aa_rules = {0.01, 1e10, 0.3, 0.999, 1, 0.0, 0, 1};

static const raster_rules *raster_rules_of(gaussian_formation f)
{
    switch (f) {
    case GAUSSIAN_FORMATION_3DGS_ANTIALIASED: return &inria_aa_rules;
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
}

/* The rotation of a unit quaternion (w, x, y, z), row-major. */
static void quaternion_matrix(const float *q, double R[3][3]) { quat_unit_matrix(q[0], q[1], q[2], q[3], R); }

/* m's linear part times v, and m applied to the point p. */
static inline vec3 cam_vector(const double m[3][4], vec3 v)
{
    return v3(m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
              m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z);
}

static inline vec3 cam_point(const double m[3][4], vec3 p)
{
    return v3_add(cam_vector(m, p), v3(m[0][3], m[1][3], m[2][3]));
}

/* Gaussian i's mean in camera space. */
static inline vec3 camera_mean(const gaussian_model *m, size_t i, const gaussian_ray *r)
{
    const float *mu = &m->mean[3 * i];
    return cam_point(r->m, v3(mu[0], mu[1], mu[2]));
}

/* Rows of the 2DGS homogeneous map T = K [t_u t_v p] (u, v, 1 -> pixel x w,
 * pixel y w, w): row[2] is the view depth row. */
static void splat_rows(const gaussian_ray *r, vec3 tu, vec3 tv, vec3 p, vec3 row[3])
{
    row[2] = v3(tu.z, tv.z, p.z);
    row[0] = v3_add(v3_scale(v3(tu.x, tv.x, p.x), r->fx), v3_scale(row[2], r->cx));
    row[1] = v3_add(v3_scale(v3(tu.y, tv.y, p.y), r->fy), v3_scale(row[2], r->cy));
}

/* Gaussian i's rows of T (splat_rows), its mean at camera-space p. */
static void gaussian_splat_rows(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p, vec3 row[3])
{
    const float *s = &m->scale[3 * i];
    double R[3][3];
    quaternion_matrix(&m->rotation[4 * i], R);
    vec3 tu = cam_vector(r->m, v3(R[0][0] * s[0], R[1][0] * s[0], R[2][0] * s[0]));
    vec3 tv = cam_vector(r->m, v3(R[0][1] * s[1], R[1][1] * s[1], R[2][1] * s[1]));
    splat_rows(r, tu, tv, p, row);
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
 * circle of radius c (scales), from rows a and b of T. */
static double dual_conic(vec3 a, vec3 b, double c)
{
    return c * c * (a.x * b.x + a.y * b.y) - a.z * b.z;
}

/* The centre of the image of the splat's circle of radius c (scales): the
 * last column of the dual conic T diag(c^2, c^2, -1) T^T over its last
 * entry (compute_aabb's point_image). 0 when the circle reaches behind the
 * camera's plane: its image is no ellipse and has no centre to filter
 * about (the rasterizer would filter about the hyperbola's, anywhere on
 * screen; GAUSSIANS.md). */
static int filter_centre(const vec3 *row, double c, double *px, double *py)
{
    double d22 = dual_conic(row[2], row[2], c);
    if (!(d22 < 0))
        return 0;
    *px = dual_conic(row[0], row[2], c) / d22, *py = dual_conic(row[1], row[2], c) / d22;
    return 1;
}

static double clamp_alpha(double alpha_max, double opacity, double g) { return rr_fmin(alpha_max, opacity * g); }

/* The image of camera-space point p minus the ray's raster position. */
static void image_offset(const gaussian_ray *r, vec3 p, double *dx, double *dy)
{
    *dx = r->fx * p.x / p.z + r->cx - r->x, *dy = r->fy * p.y / p.z + r->cy - r->y;
}

/* The rasterizers' tile rule (getRect, auxiliary.h): a Gaussian is only
 * evaluated at the pixels of the 16x16 tiles that the square of the given
 * radius about `centre` (pixel-index coordinates) touches. */
enum { TILE = 16 };

/* getRect's min(grid, max(0, (int)v)): the CUDA's (int) cast truncates
 * toward 0; the clamps keep it defined for any v. */
static int tile_index(double v, int grid)
{
    return (int)rr_fmin((double)grid, rr_fmax(0.0, trunc(rr_fmax(-1.0, rr_fmin(1e9, v)))));
}

static int in_rasterizer_tiles(const gaussian_ray *r, double cx, double cy, double radius)
{
    int gx = (r->width + TILE - 1) / TILE, gy = (r->height + TILE - 1) / TILE;
    double px = floor(r->x), py = floor(r->y);
    int x0 = tile_index((cx - radius) / TILE, gx), x1 = tile_index((cx + radius + TILE - 1) / TILE, gx);
    int y0 = tile_index((cy - radius) / TILE, gy), y1 = tile_index((cy + radius + TILE - 1) / TILE, gy);
    return px >= (double)x0 * TILE && px < (double)x1 * TILE && py >= (double)y0 * TILE && py < (double)y1 * TILE;
}

/* 2DGS's tile radius: at e0ed020 (preprocessCUDA) the 3-sigma circle's
 * image's half extent, at least 3 x FilterSize (0.707106), rounded up;
 * up to 3a9357f, 3 times the unit circle's image's half extent. */
static int in_2dgs_tiles(const gaussian_ray *r, const vec3 row[3], double c, double centre_x, double centre_y)
{
    double d22 = dual_conic(row[2], row[2], c);
    double hx = centre_x * centre_x - dual_conic(row[0], row[0], c) / d22;
    double hy = centre_y * centre_y - dual_conic(row[1], row[1], c) / d22;
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
 * circle's image is an ellipse (filter_centre), so the circle, and the
 * disc within it, lie beyond view depth 0, and the pole of a line that
 * misses the circle lies inside it. The bounds built on P (the culls,
 * filter_2d_reach) hold every pixel within the filter's reach of P's
 * image and never ask where the pixel's ray meets the splat's plane: so
 * they hold under either near rule (hit_2d_from_geometry), also the older
 * rule's filter pixels whose rays meet the plane behind the camera. */
static double filter_pole(double radius, double depth) { return radius * radius / depth; }

/* p's image's offset from the ray's raster position, times p.z (no
 * division: the culls compare it with bounds scaled by p.z alike). */
static void scaled_image_offset(const gaussian_ray *r, vec3 p, double *X, double *Y)
{
    *X = r->fx * p.x + (r->cx - r->x) * p.z, *Y = r->fy * p.y + (r->cy - r->y) * p.z;
}

/* Reaches, rounded up, that the culls, key floors and traversal pads
 * share: the kernel's 1/255 radius sqrt(2 ln 255) = 3.32901 scales (at
 * opacity 1), the 2DGS low-pass filter's sqrt(ln 255) = 2.35399 pixels
 * (FilterInvSquare), and the 3D rasterizers' k^2 = 2 ln 255 (opacities are
 * at most 1, gaussian.c) with its rounding room. */
#define KERNEL_REACH 3.3302
#define FILTER_REACH_PX 2.3540
#define RASTER_REACH2 (2.0 * log(255.0))
#define RASTER_REACH2_SLACK (1 + 1e-5)
/* gaussian_traversal_pad's rounding room, and the key floor's room for
 * the subtraction's rounding where the pad is below it */
#define TRAVERSAL_PAD_SLACK (1 + 1e-6)
#define KEY_FLOOR_ROUNDING 1e-15

/* Can the splat (centre p in camera space, larger scale s) give the ray's
 * pixel anything? A point p + delta, |delta| <= D < p.z, projects within
 * f |delta| |p| / (p.z (p.z - |delta|)) pixels of p's image (the offset is
 * f |delta_xy p.z - p_xy delta_z| / (p.z (p.z + delta_z)), and by
 * Lagrange's identity |delta_xy p.z - p_xy delta_z| <= |delta| |p|).
 * Hits lie within the kernel's reach (3.33 scales at opacity 1); the
 * filter acts within 2.36 pixels of the image of a point of the filter's
 * circle within filter_pole of the mean. A cheap test that the boxes of
 * most candidates fail (they hold a ball; the pixel's ray is a line): the
 * pole (a thousandth of a pixel for the bench's splats, where the whole
 * circle was assumed before) cut the candidates it keeps from 1.7 to about
 * 1.1 per hit. Both reaches are bounded over the larger one's p.z - reach,
 * and the test multiplied through by p.z (p.z - reach): one division (the
 * pole's) where there were four (issue 31's profile: they led the cull),
 * never tighter than the bound itself; the 1e-6 slack covers rounding. */
static int splat_near_pixel(const gaussian_ray *r, vec3 p, double s, double c)
{
    double reach_k = KERNEL_REACH * s, circle = c * s;
    if (p.z <= rr_fmax(reach_k, circle) * (1 + 1e-9))
        return 1; /* near the camera plane: no bound from the projection */
    double reach_c = filter_pole(circle, p.z), reach = rr_fmax(reach_k, reach_c); /* the pole: below circle here */
    double X, Y, depth = p.z * (p.z - reach), spread = rr_fmax(r->fx, r->fy) * v3_len(p);
    scaled_image_offset(r, p, &X, &Y);
    double bound = rr_fmax(spread * reach_k, spread * reach_c + FILTER_REACH_PX * depth) * (1 + 1e-6) + 1e-6 * depth;
    return (X * X + Y * Y) * (p.z - reach) * (p.z - reach) <= bound * bound;
}

/* The 2DGS cull from the mean and the scale: the centre in front of the
 * near plane, as the rasterizer's frustum test, and near the pixel. */
static int cull_2d(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    const float *s = &m->scale[3 * i];
    return !(p.z <= GAUSSIAN_NEAR) && splat_near_pixel(r, p, rr_fmax(s[0], s[1]) * r->scale, filter_circle(m));
}

/* cull_2d on blocks of four Gaussians in AVX2 registers, where the CPU has
 * them (the cull led issue 31's profile: a 2DGS ray culls about 190
 * candidates). The same operations in the same order as camera_mean and
 * cull_2d, lane by lane, so the same answers bit for bit: IEEE products,
 * sums, quotients and square roots are exact per lane, and no FMA is
 * enabled to contract them; rr_fmax's values by compare and blend. */
#if defined(__x86_64__) && defined(__GNUC__)
#define RR_AVX2_CULL 1
#include <immintrin.h>
enum { CULL_LANES = 4 };

__attribute__((target("avx2"))) static inline __m256d lanes_fmax(__m256d x, __m256d y)
{
    __m256d take_x = _mm256_or_pd(_mm256_cmp_pd(x, y, _CMP_GE_OQ), _mm256_cmp_pd(y, y, _CMP_UNORD_Q));
    return _mm256_blendv_pd(y, x, take_x);
}

/* Component a of four Gaussians' float triples, as doubles (exact). */
__attribute__((target("avx2"))) static inline __m256d lanes_of(const float *const v[4], int a)
{
    return _mm256_cvtps_pd(_mm_set_ps(v[3][a], v[2][a], v[1][a], v[0][a]));
}

/* The linear part of camera matrix row `row` times (x, y, z) (cam_vector). */
__attribute__((target("avx2"))) static inline __m256d lanes_linear(const double row[4], __m256d x, __m256d y, __m256d z)
{
    __m256d sum = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(row[0]), x), _mm256_mul_pd(_mm256_set1_pd(row[1]), y));
    return _mm256_add_pd(sum, _mm256_mul_pd(_mm256_set1_pd(row[2]), z));
}

/* Camera matrix row `row` applied to the point (x, y, z) (cam_point). */
__attribute__((target("avx2"))) static inline __m256d lanes_row(const double row[4], __m256d x, __m256d y, __m256d z)
{
    return _mm256_add_pd(lanes_linear(row, x, y, z), _mm256_set1_pd(row[3]));
}

/* mean (mx, my, mz) and larger scale s of four Gaussians -> their camera
 * space means (px, py, pz) and a mask of those cull_2d keeps. */
__attribute__((target("avx2"))) static int cull_2d_lanes(const gaussian_ray *r, double circle_scales, __m256d X0,
                                                         __m256d Y0, __m256d Z0, __m256d s_in, double *px, double *py,
                                                         double *pz, float *floor)
{
    __m256d x = lanes_row(r->m[0], X0, Y0, Z0), y = lanes_row(r->m[1], X0, Y0, Z0), z = lanes_row(r->m[2], X0, Y0, Z0);
    __m256d s = _mm256_mul_pd(s_in, _mm256_set1_pd(r->scale));
    __m256d reach_k = _mm256_mul_pd(_mm256_set1_pd(KERNEL_REACH), s), circle = _mm256_mul_pd(_mm256_set1_pd(circle_scales), s);
    __m256d near = _mm256_cmp_pd(z, _mm256_mul_pd(lanes_fmax(reach_k, circle), _mm256_set1_pd(1 + 1e-9)), _CMP_LE_OQ);
    __m256d reach_c = _mm256_div_pd(_mm256_mul_pd(circle, circle), z), reach = lanes_fmax(reach_k, reach_c);
    __m256d gap = _mm256_sub_pd(z, reach), depth = _mm256_mul_pd(z, gap);
    __m256d len2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(x, x), _mm256_mul_pd(y, y)), _mm256_mul_pd(z, z));
    __m256d spread = _mm256_mul_pd(_mm256_set1_pd(rr_fmax(r->fx, r->fy)), _mm256_sqrt_pd(len2));
    __m256d X = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->fx), x), _mm256_mul_pd(_mm256_set1_pd(r->cx - r->x), z));
    __m256d Y = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->fy), y), _mm256_mul_pd(_mm256_set1_pd(r->cy - r->y), z));
    __m256d wide = lanes_fmax(_mm256_mul_pd(spread, reach_k),
                              _mm256_add_pd(_mm256_mul_pd(spread, reach_c), _mm256_mul_pd(_mm256_set1_pd(FILTER_REACH_PX), depth)));
    __m256d bound = _mm256_add_pd(_mm256_mul_pd(wide, _mm256_set1_pd(1 + 1e-6)), _mm256_mul_pd(_mm256_set1_pd(1e-6), depth));
    __m256d off2 = _mm256_mul_pd(_mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(X, X), _mm256_mul_pd(Y, Y)), gap), gap);
    __m256d within = _mm256_cmp_pd(off2, _mm256_mul_pd(bound, bound), _CMP_LE_OQ);
    __m256d in_front = _mm256_cmp_pd(z, _mm256_set1_pd(GAUSSIAN_NEAR), _CMP_NLE_UQ);
    _mm256_storeu_pd(px, x), _mm256_storeu_pd(py, y), _mm256_storeu_pd(pz, z);
    /* gaussian_key_floor: the centre's depth less gaussian_traversal_pad */
    __m256d depth_per_t = _mm256_set1_pd(r->depth_per_t), centre = _mm256_div_pd(z, depth_per_t);
    __m256d pad = _mm256_div_pd(_mm256_mul_pd(_mm256_set1_pd(KERNEL_REACH), s), depth_per_t);
    pad = _mm256_mul_pd(pad, _mm256_set1_pd(TRAVERSAL_PAD_SLACK));
    __m256d below = _mm256_sub_pd(centre, pad), magnitude = _mm256_andnot_pd(_mm256_set1_pd(-0.0), centre);
    below = _mm256_sub_pd(below, _mm256_mul_pd(_mm256_set1_pd(KEY_FLOOR_ROUNDING), magnitude));
    _mm_storeu_ps(floor, _mm256_cvtpd_ps(below));
    return _mm256_movemask_pd(_mm256_and_pd(in_front, _mm256_or_pd(near, within)));
}

/* cull_3d_raster the same way (mx, my, mz, s: means and largest scales). */
__attribute__((target("avx2"))) static int cull_3d_lanes(const gaussian_ray *r, const raster_rules *rules,
                                                         __m256d X0, __m256d Y0, __m256d Z0, __m256d s_in, double *px,
                                                         double *py, double *pz, float *floor)
{
    __m256d x = lanes_row(r->m[0], X0, Y0, Z0), y = lanes_row(r->m[1], X0, Y0, Z0), z = lanes_row(r->m[2], X0, Y0, Z0);
    __m256d in_range = _mm256_and_pd(_mm256_cmp_pd(z, _mm256_set1_pd(rules->near), _CMP_GT_OQ),
                                     _mm256_cmp_pd(z, _mm256_set1_pd(rules->far), _CMP_LE_OQ));
    __m256d F = _mm256_mul_pd(_mm256_set1_pd(rr_fmax(r->fx, r->fy)), s_in);
    F = _mm256_mul_pd(_mm256_mul_pd(F, _mm256_set1_pd(r->scale)), _mm256_set1_pd(r->stretch));
    __m256d X = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->fx), x), _mm256_mul_pd(_mm256_set1_pd(r->cx - r->x), z));
    __m256d Y = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->fy), y), _mm256_mul_pd(_mm256_set1_pd(r->cy - r->y), z));
    __m256d dilated = _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(rules->dilation), z), z);
    __m256d bound = _mm256_mul_pd(_mm256_set1_pd(RASTER_REACH2), _mm256_add_pd(_mm256_mul_pd(F, F), dilated));
    bound = _mm256_mul_pd(bound, _mm256_set1_pd(RASTER_REACH2_SLACK));
    __m256d within = _mm256_cmp_pd(_mm256_add_pd(_mm256_mul_pd(X, X), _mm256_mul_pd(Y, Y)), bound, _CMP_LE_OQ);
    _mm256_storeu_pd(px, x), _mm256_storeu_pd(py, y), _mm256_storeu_pd(pz, z);
    _mm_storeu_ps(floor, _mm256_cvtpd_ps(_mm256_div_pd(z, _mm256_set1_pd(r->depth_per_t)))); /* gaussian_key_floor */
    return _mm256_movemask_pd(_mm256_and_pd(in_range, within));
}
#else
#define RR_AVX2_CULL 0
#endif

/* What a 2DGS hit's rules read of the splat's geometry at the ray's
 * pixel: computed one Gaussian at a time (splat_2d_geometry_of) or four in
 * lanes (splat_2d_geometry_lanes), the same operations in the same order. */
typedef struct {
    vec3 row[3];             /* T's rows (splat_rows) */
    double cz, u, v;         /* the pixel's planes' intersection (u, v, 1) cz; u, v once cz != 0 */
    double rho3d, rho2d;     /* the kernel's and the filter's squared distances (rho2d: inf unfiltered) */
    double centre_x, centre_y; /* the filter's centre (0 unfiltered) */
    double plane_depth;
    int filtered;
} splat_2d_geometry;

static void splat_2d_geometry_of(const gaussian_ray *r, double circle, splat_2d_geometry *g)
{
    const vec3 *row = g->row;
    /* the planes through the pixel's column and row, in (u, v, 1) */
    vec3 k = v3_sub(v3_scale(row[2], r->x), row[0]), l = v3_sub(v3_scale(row[2], r->y), row[1]);
    vec3 c = v3_cross(k, l);
    g->cz = c.z;
    if (c.z == 0)
        return;
    g->u = c.x / c.z, g->v = c.y / c.z, g->rho3d = g->u * g->u + g->v * g->v;
    double centre_x = 0, centre_y = 0;
    g->filtered = filter_centre(g->row, circle, &centre_x, &centre_y);
    g->rho2d = INFINITY, g->centre_x = centre_x, g->centre_y = centre_y;
    if (g->filtered) /* FilterInvSquare |pixel - centre|^2 */
        g->rho2d = GAUSSIAN_FILTER_INV_SQUARE * ((g->centre_x - r->x) * (g->centre_x - r->x) +
                                                 (g->centre_y - r->y) * (g->centre_y - r->y));
    g->plane_depth = g->u * row[2].x + g->v * row[2].y + row[2].z;
}

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

/* Gaussian i's 2DGS hit from its geometry at the pixel (p: its
 * camera-space mean). */
static int hit_2d_from_geometry(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                                const splat_2d_geometry *g, gaussian_hit *h)
{
    if (g->cz == 0)
        return 0;
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
    double depth = g->rho3d <= g->rho2d ? g->plane_depth : g->row[2].z;
    if (g->plane_depth < GAUSSIAN_NEAR) {
        if (!near_by_centre_where_filtered(m) || depth < GAUSSIAN_NEAR || splat_edge_on(m, i, r, p))
            return 0;
    }
    double rho = rr_fmin(g->rho3d, g->rho2d), t = depth / r->depth_per_t;
    /* alpha below 1/255 for certain (opacity <= 1): exp is the costly
     * part, and the exact test follows (a test with the opacity's own log
     * cost a log per candidate) */
    if (!(rho <= 2.0 * log(1.0 / GAUSSIAN_ALPHA_MIN) + 1e-9) || !(t >= r->tmin && t < r->tmax))
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

#if RR_AVX2_CULL
/* a * b - c * d, lane by lane */
__attribute__((target("avx2"))) static inline __m256d lanes_cross_term(__m256d a, __m256d b, __m256d c, __m256d d)
{
    return _mm256_sub_pd(_mm256_mul_pd(a, b), _mm256_mul_pd(c, d));
}

/* dual_conic(a, b, c) with cc = c * c */
__attribute__((target("avx2"))) static inline __m256d lanes_dual_conic(const __m256d a[3], const __m256d b[3], __m256d cc)
{
    __m256d across = _mm256_add_pd(_mm256_mul_pd(a[0], b[0]), _mm256_mul_pd(a[1], b[1]));
    return _mm256_sub_pd(_mm256_mul_pd(cc, across), _mm256_mul_pd(a[2], b[2]));
}

/* gaussian_splat_rows for four Gaussians: T's rows as row[k][component]. */
__attribute__((target("avx2"))) static void splat_rows_lanes(const gaussian_model *m, const unsigned prim[4],
                                                             const gaussian_ray *r, const vec3 p[4], __m256d row[3][3])
{
    const float *q[4], *sc[4];
    for (int j = 0; j < 4; j++)
        q[j] = &m->rotation[4 * prim[j]], sc[j] = &m->scale[3 * prim[j]];
    __m256d w = lanes_of(q, 0), x = lanes_of(q, 1), y = lanes_of(q, 2), z = lanes_of(q, 3);
    __m256d one = _mm256_set1_pd(1), two = _mm256_set1_pd(2), s0 = lanes_of(sc, 0), s1 = lanes_of(sc, 1);
    /* quaternion_matrix's first two columns, each times its scale */
    __m256d R00 = _mm256_sub_pd(one, _mm256_mul_pd(two, _mm256_add_pd(_mm256_mul_pd(y, y), _mm256_mul_pd(z, z))));
    __m256d R10 = _mm256_mul_pd(two, _mm256_add_pd(_mm256_mul_pd(x, y), _mm256_mul_pd(w, z)));
    __m256d R20 = _mm256_mul_pd(two, _mm256_sub_pd(_mm256_mul_pd(x, z), _mm256_mul_pd(w, y)));
    __m256d R01 = _mm256_mul_pd(two, _mm256_sub_pd(_mm256_mul_pd(x, y), _mm256_mul_pd(w, z)));
    __m256d R11 = _mm256_sub_pd(one, _mm256_mul_pd(two, _mm256_add_pd(_mm256_mul_pd(x, x), _mm256_mul_pd(z, z))));
    __m256d R21 = _mm256_mul_pd(two, _mm256_add_pd(_mm256_mul_pd(y, z), _mm256_mul_pd(w, x)));
    __m256d ux = _mm256_mul_pd(R00, s0), uy = _mm256_mul_pd(R10, s0), uz = _mm256_mul_pd(R20, s0);
    __m256d vx = _mm256_mul_pd(R01, s1), vy = _mm256_mul_pd(R11, s1), vz = _mm256_mul_pd(R21, s1);
    __m256d tu[3], tv[3];
    for (int a = 0; a < 3; a++)
        tu[a] = lanes_linear(r->m[a], ux, uy, uz), tv[a] = lanes_linear(r->m[a], vx, vy, vz);
    __m256d pc[3] = {_mm256_set_pd(p[3].x, p[2].x, p[1].x, p[0].x), _mm256_set_pd(p[3].y, p[2].y, p[1].y, p[0].y),
                     _mm256_set_pd(p[3].z, p[2].z, p[1].z, p[0].z)};
    __m256d third[3] = {tu[2], tv[2], pc[2]}, first[3] = {tu[0], tv[0], pc[0]}, second[3] = {tu[1], tv[1], pc[1]};
    __m256d fx = _mm256_set1_pd(r->fx), fy = _mm256_set1_pd(r->fy), cx = _mm256_set1_pd(r->cx), cy = _mm256_set1_pd(r->cy);
    for (int a = 0; a < 3; a++) { /* splat_rows */
        row[2][a] = third[a];
        row[0][a] = _mm256_add_pd(_mm256_mul_pd(first[a], fx), _mm256_mul_pd(third[a], cx));
        row[1][a] = _mm256_add_pd(_mm256_mul_pd(second[a], fy), _mm256_mul_pd(third[a], cy));
    }
}

/* splat_2d_geometry_of for four Gaussians (rows from splat_rows_lanes). */
__attribute__((target("avx2"))) static void splat_2d_geometry_lanes(const gaussian_ray *r, double circle,
                                                                    __m256d row[3][3], splat_2d_geometry g[4])
{
    __m256d rx = _mm256_set1_pd(r->x), ry = _mm256_set1_pd(r->y), k[3], l[3];
    for (int a = 0; a < 3; a++)
        k[a] = _mm256_sub_pd(_mm256_mul_pd(row[2][a], rx), row[0][a]),
        l[a] = _mm256_sub_pd(_mm256_mul_pd(row[2][a], ry), row[1][a]);
    __m256d cx = lanes_cross_term(k[1], l[2], k[2], l[1]), cy = lanes_cross_term(k[2], l[0], k[0], l[2]);
    __m256d cz = lanes_cross_term(k[0], l[1], k[1], l[0]);
    __m256d u = _mm256_div_pd(cx, cz), v = _mm256_div_pd(cy, cz);
    __m256d rho3d = _mm256_add_pd(_mm256_mul_pd(u, u), _mm256_mul_pd(v, v));
    __m256d cc = _mm256_mul_pd(_mm256_set1_pd(circle), _mm256_set1_pd(circle));
    __m256d d22 = lanes_dual_conic(row[2], row[2], cc), filtered = _mm256_cmp_pd(d22, _mm256_setzero_pd(), _CMP_LT_OQ);
    __m256d centre_x = _mm256_and_pd(filtered, _mm256_div_pd(lanes_dual_conic(row[0], row[2], cc), d22));
    __m256d centre_y = _mm256_and_pd(filtered, _mm256_div_pd(lanes_dual_conic(row[1], row[2], cc), d22));
    __m256d dx = _mm256_sub_pd(centre_x, rx), dy = _mm256_sub_pd(centre_y, ry);
    __m256d rho2d = _mm256_mul_pd(_mm256_set1_pd(GAUSSIAN_FILTER_INV_SQUARE),
                                  _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)));
    rho2d = _mm256_blendv_pd(_mm256_set1_pd(INFINITY), rho2d, filtered);
    __m256d plane_depth = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(u, row[2][0]), _mm256_mul_pd(v, row[2][1])), row[2][2]);
    double out[17][4];
    __m256d fields[17] = {row[0][0], row[0][1], row[0][2], row[1][0], row[1][1], row[1][2], row[2][0], row[2][1],
                          row[2][2], cz, u, v, rho3d, rho2d, centre_x, centre_y, plane_depth};
    for (int f = 0; f < 17; f++)
        _mm256_storeu_pd(out[f], fields[f]);
    int mask = _mm256_movemask_pd(filtered);
    for (int j = 0; j < 4; j++) {
        for (int a = 0; a < 3; a++)
            g[j].row[a] = v3(out[3 * a][j], out[3 * a + 1][j], out[3 * a + 2][j]);
        g[j].cz = out[9][j], g[j].u = out[10][j], g[j].v = out[11][j], g[j].rho3d = out[12][j];
        g[j].rho2d = out[13][j], g[j].centre_x = out[14][j], g[j].centre_y = out[15][j];
        g[j].plane_depth = out[16][j], g[j].filtered = mask >> j & 1;
    }
}
#endif

/* Gaussian i's 2DGS hit once cull_2d passed it (p: its camera-space mean). */
static int hit_2d_after_cull(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r, vec3 p,
                             gaussian_hit *h)
{
    splat_2d_geometry g;
    gaussian_splat_rows(m, i, r, p, g.row);
    splat_2d_geometry_of(r, filter_circle(m), &g);
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
    vec3 row[3];
    gaussian_splat_rows(m, i, r, camera_mean(m, i, r), row);
    return filter_centre(row, filter_circle(m), x, y);
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
    double R[3][3], negx, posx, negy, posy;
    jacobian_clamp(rules, r->width, r->fx, r->cx, &negx, &posx);
    jacobian_clamp(rules, r->height, r->fy, r->cy, &negy, &posy);
    quaternion_matrix(&m->rotation[4 * i], R);
    double tx = rr_fmin(posx, rr_fmax(-negx, p.x / p.z)), ty = rr_fmin(posy, rr_fmax(-negy, p.y / p.z));
    vec3 j0 = v3(r->fx / p.z, 0, -r->fx * tx / p.z), j1 = v3(0, r->fy / p.z, -r->fy * ty / p.z);
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

/* The 3D rasterizers' cull from the mean and the scale: the centre within
 * the depths in_frustum keeps, and the pixel within the footprint's reach,
 * cheap and sure: lambda_max(cov2D) <= (f_max / z)^2 (1 + lim^2) s_max^2 +
 * dilation (gaussian_view_stretch), alpha >= 1/255 within k^2 of it, k^2
 * = 2 ln(255 o) <= 2 ln 255. */
static int cull_3d_raster(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    const raster_rules *rules = raster_rules_of(gaussian_formation_of(m));
    const float *s = &m->scale[3 * i];
    if (!(p.z > rules->near && p.z <= rules->far))
        return 0;
    double X, Y, F = rr_fmax(r->fx, r->fy) * rr_fmax(s[0], rr_fmax(s[1], s[2])) * r->scale * r->stretch;
    scaled_image_offset(r, p, &X, &Y); /* times p.z^2 (no division), with room for rounding */
    return X * X + Y * Y <= RASTER_REACH2 * (F * F + rules->dilation * p.z * p.z) * RASTER_REACH2_SLACK;
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

int gaussian_hit_3d_raster(const gaussian_model *m, size_t i, const gaussian_ray *r, gaussian_hit *h)
{
    vec3 p = camera_mean(m, i, r);
    return cull_3d_raster(m, i, r, p) && hit_3d_raster_after_cull(m, i, r, p, h);
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

/* The kernel radius (in scales) beyond which opacity G < 1/255: G =
 * exp(-r^2 / 2) >= 1 / (255 o) needs r^2 <= 2 ln(255 o); 3DGRT also
 * drops responses at or below GAUSSIAN_GRT_MIN_RESPONSE. 0: never seen. */
static double kernel_reach(const gaussian_model *m, size_t i)
{
    double r2 = 2.0 * log(m->opacity[i] / GAUSSIAN_ALPHA_MIN);
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
    return KERNEL_REACH * s / depth_per_t * TRAVERSAL_PAD_SLACK;
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
    double px2 = log(m->opacity[i] / GAUSSIAN_ALPHA_MIN);
    *along_plane = *across_view = 0.0;
    if (!(px2 > 0))
        return;
    const float *s = &m->scale[3 * i];
    double radius = filter_circle(m) * rr_fmax(s[0], s[1]);
    double pole = v->near > 0 ? rr_fmin(radius, filter_pole(radius, v->near)) : radius;
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
    double k2 = 2.0 * log(m->opacity[i] / GAUSSIAN_ALPHA_MIN);
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
    double centre = p.z / r->depth_per_t, floor;
    if (m->kind == GAUSSIAN_2D) { /* within 3.33 scales of the centre's depth (gaussian_traversal_pad) */
        const float *s = &m->scale[3 * i];
        floor = centre - gaussian_traversal_pad(m, rr_fmax(s[0], s[1]) * r->scale, r->depth_per_t);
        floor -= KEY_FLOOR_ROUNDING * fabs(centre);
    } else if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT) {
        return -INFINITY; /* the closest approach: not tied to the centre's depth */
    } else {
        floor = centre; /* the rasterizers' key is the centre's depth, computed alike */
    }
    /* rounding is monotone: a hit's key (float)t >= (float)floor for t >=
     * floor, and compositing takes keys strictly below it */
    return (float)floor;
}

/* Keeps cand[k] (k < n) that the cull passes, at the front, with p and
 * key floor (gaussian_cull_candidates). */
static size_t keep_culled(gaussian_candidate *cand, size_t kept, unsigned prim, vec3 p, float key_floor, unsigned ray)
{
    cand[kept] = (gaussian_candidate){p, key_floor, prim, ray};
    return kept + 1;
}

enum { PREFETCH_AHEAD = 8 };
#if RR_AVX2_CULL
/* The candidates' culls four at a time in AVX2 lanes (cull_2d_lanes,
 * cull_3d_lanes); returns how many it took (a multiple of four), *kept
 * advanced as keep_culled does. */
__attribute__((target("avx2"))) static size_t cull_in_lanes(const gaussian_model *m, const gaussian_ray *r,
                                                            gaussian_candidate *cand, size_t n, unsigned ray,
                                                            size_t *kept)
{
    const raster_rules *rules = m->kind == GAUSSIAN_3D ? raster_rules_of(gaussian_formation_of(m)) : NULL;
    double circle = filter_circle(m);
    size_t k = 0;
    for (; k + CULL_LANES <= n; k += CULL_LANES) {
        double px[CULL_LANES], py[CULL_LANES], pz[CULL_LANES];
        float floor[CULL_LANES];
        unsigned prim[CULL_LANES];
        const float *mu[CULL_LANES], *sc[CULL_LANES];
        for (int j = 0; j < CULL_LANES; j++) {
            if (k + j + PREFETCH_AHEAD < n)
                gaussian_prefetch_cull(m, cand[k + j + PREFETCH_AHEAD].prim);
            prim[j] = cand[k + j].prim;
            mu[j] = &m->mean[3 * prim[j]], sc[j] = &m->scale[3 * prim[j]];
        }
        /* the lanes built in registers: doubles stored one by one and
         * loaded as a vector stalled on store forwarding (perf annotate) */
        __m256d X0 = lanes_of(mu, 0), Y0 = lanes_of(mu, 1), Z0 = lanes_of(mu, 2);
        __m256d S = rules ? lanes_fmax(lanes_of(sc, 0), lanes_fmax(lanes_of(sc, 1), lanes_of(sc, 2)))
                          : lanes_fmax(lanes_of(sc, 0), lanes_of(sc, 1));
        int keep = rules ? cull_3d_lanes(r, rules, X0, Y0, Z0, S, px, py, pz, floor)
                         : cull_2d_lanes(r, circle, X0, Y0, Z0, S, px, py, pz, floor);
        /* without a branch (whether a lane is kept is a coin toss): every
         * lane is written where the next kept one goes, at or below its own
         * slot, which the loop above has read */
        for (int j = 0; j < CULL_LANES; j++)
            *kept = keep_culled(cand, *kept, prim[j], v3(px[j], py[j], pz[j]), floor[j], ray) - !(keep >> j & 1);
    }
    return k;
}
#endif

size_t gaussian_cull_candidates(const gaussian_model *m, const gaussian_ray *r, gaussian_candidate *cand, size_t n,
                                unsigned ray)
{
    size_t kept = 0, k = 0;
#if RR_AVX2_CULL /* (3DGRT has no cull) */
    if (gaussian_formation_of(m) != GAUSSIAN_FORMATION_3DGRT && __builtin_cpu_supports("avx2"))
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
#if RR_AVX2_CULL
    if (m->kind == GAUSSIAN_2D && __builtin_cpu_supports("avx2")) {
        __m256d row[3][3];
        splat_2d_geometry g[4];
        splat_rows_lanes(m, prim, r, p, row);
        splat_2d_geometry_lanes(r, filter_circle(m), row, g);
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
/* The lanes whose splat_2d_geometry differs in any bit from the scalar
 * splat_2d_geometry_of's: the hits' floats hide a double's last bits. */
static int geometry_differs(const splat_2d_geometry *a, const splat_2d_geometry *b)
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
#if RR_AVX2_CULL
    if (m->kind != GAUSSIAN_2D || !__builtin_cpu_supports("avx2"))
        return 0;
    __m256d row[3][3];
    splat_2d_geometry four[4], one;
    splat_rows_lanes(m, prim, r, p, row);
    splat_2d_geometry_lanes(r, filter_circle(m), row, four);
    for (int j = 0; j < 4; j++) {
        gaussian_splat_rows(m, prim[j], r, p[j], one.row);
        splat_2d_geometry_of(r, filter_circle(m), &one);
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
        double pad = e * 1e-5 + 1e-6 * fabs(c[a]) + 1e-30; /* float rounding never clips a Gaussian */
        lo[a] = c[a] - e - pad, hi[a] = c[a] + e + pad;
    }
    b.lo = v3(lo[0], lo[1], lo[2]), b.hi = v3(hi[0], hi[1], hi[2]);
    return b;
}

