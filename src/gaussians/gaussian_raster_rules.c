/* The 3D rasterizers' rules as tables (gaussian_hit_internal.h's
 * raster_rules), the Jacobian's clamps, the view stretch the bounds use and
 * the CUDA's 16x16 tile rule: what differs between Inria's and gsplat's
 * rasterizers, read in their sources. */
#include "gaussians/gaussian_hit_internal.h"

static const raster_rules inria_rules = {0.2, INFINITY, 0.3, 0.99, 0, 0.0, 1, 0, 0};
static const raster_rules inria_aa_rules = {0.2, INFINITY, 0.3, 0.99, 1, 2.5e-5, 1, 0, 0};
static const raster_rules inria_fov_minus_one_rules = {0.2, INFINITY, 0.3, 0.99, 0, 0.0, 1, 0, 1};
static const raster_rules gsplat_rules = {0.01, 1e10, 0.3, 0.999, 0, 0.0, 0, 1, 0};
static const raster_rules gsplat_aa_rules = {0.01, 1e10, 0.3, 0.999, 1, 0.0, 0, 1, 0};

const raster_rules *raster_rules_of(gaussian_formation f)
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
double raster_pinned_stretch(const camera_view *v)
{
    double fx, fy, t;
    pinned_jacobian(v->width, v->height, &fx, &fy, &t);
    return sqrt(1.0 + 2.0 * t * t) * rr_fmax(fabs(fx), fabs(fy)) / rr_fmin(v->fx, v->fy);
}

double gaussian_view_stretch_of(gaussian_formation f, const camera_view *v)
{
    return f == GAUSSIAN_FORMATION_3DGS_FOV_MINUS_ONE ? raster_pinned_stretch(v) : gaussian_view_stretch(v);
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

int in_rasterizer_tiles(const gaussian_ray *r, double cx, double cy, double radius)
{
    const int side = RASTER_TILE;
    int gx = (r->width + side - 1) / side, gy = (r->height + side - 1) / side;
    double px = floor(r->x), py = floor(r->y);
    int x0 = tile_index((cx - radius) / side, gx), x1 = tile_index((cx + radius + side - 1) / side, gx);
    int y0 = tile_index((cy - radius) / side, gy), y1 = tile_index((cy + radius + side - 1) / side, gy);
    return px >= (double)x0 * side && px < (double)x1 * side && py >= (double)y0 * side && py < (double)y1 * side;
}

/* The focal lengths and the clamped x/z, y/z of the EWA Jacobian at
 * camera-space p: the camera's, clamped (jacobian_clamp), or the pinned
 * ones of a rasterizer handed FoV = -1 (pinned_jacobian). */
void raster_jacobian_at(const raster_rules *rules, const gaussian_ray *r, vec3 p, double *fx, double *fy, double *tx,
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
