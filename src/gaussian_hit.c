#include "gaussian_hit.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

void gaussian_hits_add(gaussian_hits *h, const gaussian_hit *hit)
{
    if (h->count == h->cap) {
        size_t cap = h->cap ? 2 * h->cap : 256;
        gaussian_hit *grown = realloc(h->hits, cap * sizeof *grown);
        if (!grown) {
            h->dropped++;
            return;
        }
        h->hits = grown, h->cap = cap;
    }
    h->hits[h->count++] = *hit;
    h->added++;
}

void gaussian_hits_free(gaussian_hits *h)
{
    free(h->hits);
    free(h->order);
    free(h->rays);
    memset(h, 0, sizeof *h);
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
    r->scale = sqrt(fmax(col2[0], fmax(col2[1], col2[2]))) * (1 + 1e-9);
}

/* The rotation of a unit quaternion (w, x, y, z), row-major. */
static void quaternion_matrix(const float *q, double R[3][3])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0][0] = 1 - 2 * (y * y + z * z), R[0][1] = 2 * (x * y - w * z), R[0][2] = 2 * (x * z + w * y);
    R[1][0] = 2 * (x * y + w * z), R[1][1] = 1 - 2 * (x * x + z * z), R[1][2] = 2 * (y * z - w * x);
    R[2][0] = 2 * (x * z - w * y), R[2][1] = 2 * (y * z + w * x), R[2][2] = 1 - 2 * (x * x + y * y);
}

/* m's linear part times v, and m applied to the point p. */
static vec3 cam_vector(const double m[3][4], vec3 v)
{
    return v3(m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
              m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z);
}

static vec3 cam_point(const double m[3][4], vec3 p)
{
    return v3_add(cam_vector(m, p), v3(m[0][3], m[1][3], m[2][3]));
}

/* Rows of the 2DGS homogeneous map T = K [t_u t_v p] (u, v, 1 -> pixel x w,
 * pixel y w, w): row[2] is the view depth row. */
static void splat_rows(const gaussian_ray *r, vec3 tu, vec3 tv, vec3 p, vec3 row[3])
{
    row[2] = v3(tu.z, tv.z, p.z);
    row[0] = v3_add(v3_scale(v3(tu.x, tv.x, p.x), r->fx), v3_scale(row[2], r->cx));
    row[1] = v3_add(v3_scale(v3(tu.y, tv.y, p.y), r->fy), v3_scale(row[2], r->cy));
}

/* The low-pass filter's rho2d: 2 |pixel - centre|^2, the centre of the
 * image of the unit circle from the dual conic T diag(1, 1, -1) T^T
 * (the rasterizer's computeCenter). When the circle reaches behind the
 * camera's plane its image is no ellipse and has no centre to filter
 * about: no filter then (the rasterizer would use the hyperbola's centre,
 * anywhere on screen). */
static double filter_rho2d(const gaussian_ray *r, const vec3 row[3])
{
    vec3 flip = v3(1, 1, -1);
    double d22 = v3_dot(row[2], v3(row[2].x * flip.x, row[2].y * flip.y, row[2].z * flip.z));
    if (!(d22 < 0))
        return INFINITY;
    double d02 = row[0].x * row[2].x + row[0].y * row[2].y - row[0].z * row[2].z;
    double d12 = row[1].x * row[2].x + row[1].y * row[2].y - row[1].z * row[2].z;
    double dx = d02 / d22 - r->x, dy = d12 / d22 - r->y;
    return GAUSSIAN_FILTER_INV_SQUARE * (dx * dx + dy * dy);
}

static double clamp_alpha(double opacity, double g) { return fmin(GAUSSIAN_ALPHA_MAX, opacity * g); }

/* Can the splat (centre p in camera space, larger scale s) give the ray's
 * pixel anything? Its kernel's reach (3.33 scales at opacity 1) projects
 * within f k s / (z - k s) pixels of the projected mean, and the filter
 * acts within 2.36 pixels of the image of a point of its unit disc, which
 * lies within f s / (z - s) of it. A cheap test that the boxes of most
 * candidates fail (they hold a ball; the pixel's ray is a line). */
static int splat_near_pixel(const gaussian_ray *r, vec3 p, double s)
{
    const double k = 3.3302, filter_px = 2.3537; /* sqrt(2 ln 255), sqrt(ln 255) */
    double f = fmax(r->fx, r->fy), dx = r->fx * p.x / p.z + r->cx - r->x, dy = r->fy * p.y / p.z + r->cy - r->y;
    if (p.z <= k * s)
        return 1; /* near the camera plane: no bound from the projection */
    double reach = fmax(f * k * s / (p.z - k * s), f * s / (p.z - s) + filter_px) * (1 + 1e-6) + 1e-6;
    return dx * dx + dy * dy <= reach * reach;
}

int gaussian_hit_2d(const gaussian_model *m, size_t i, gaussian_order order, const gaussian_ray *r,
                    gaussian_hit *h)
{
    const float *mu = &m->mean[3 * i], *s = &m->scale[3 * i];
    vec3 p = cam_point(r->m, v3(mu[0], mu[1], mu[2]));
    if (p.z <= GAUSSIAN_NEAR || !splat_near_pixel(r, p, fmax(s[0], s[1]) * r->scale)) /* frustum cull, as the rasterizer */
        return 0;
    double R[3][3];
    quaternion_matrix(&m->rotation[4 * i], R);
    vec3 tu = cam_vector(r->m, v3(R[0][0] * s[0], R[1][0] * s[0], R[2][0] * s[0]));
    vec3 tv = cam_vector(r->m, v3(R[0][1] * s[1], R[1][1] * s[1], R[2][1] * s[1]));
    vec3 row[3];
    splat_rows(r, tu, tv, p, row);
    /* the planes through the pixel's column and row, in (u, v, 1) */
    vec3 k = v3_sub(v3_scale(row[2], r->x), row[0]), l = v3_sub(v3_scale(row[2], r->y), row[1]);
    vec3 c = v3_cross(k, l);
    if (c.z == 0)
        return 0;
    double u = c.x / c.z, v = c.y / c.z, rho3d = u * u + v * v, rho2d = filter_rho2d(r, row);
    double plane_depth = u * row[2].x + v * row[2].y + row[2].z;
    /* the near skip takes the plane hit's depth even where the filter wins
     * (forward.cu since e0ed020, the commit 2DGS pins); where the filter
     * wins the hit is placed at the centre's depth (the depth of the
     * earlier code), the point its bounds and windows hold */
    double depth = rho3d <= rho2d ? plane_depth : row[2].z;
    if (plane_depth < GAUSSIAN_NEAR)
        return 0;
    double rho = fmin(rho3d, rho2d), t = depth / r->depth_per_t;
    if (!(rho <= 2.0 * log(m->opacity[i] / GAUSSIAN_ALPHA_MIN) + 1e-9) || !(t >= r->tmin && t < r->tmax))
        return 0; /* alpha below 1/255 for certain (exp is the costly part; the exact test follows) */
    double alpha = clamp_alpha(m->opacity[i], exp(-0.5 * rho));
    if (alpha < GAUSSIAN_ALPHA_MIN)
        return 0;
    vec3 dir = v3_sub(v3(mu[0], mu[1], mu[2]), r->eye);
    double key = order == GAUSSIAN_ORDER_CENTER_DEPTH ? p.z / r->depth_per_t : t;
    *h = (gaussian_hit){(float)key, (float)t, (float)alpha,
                        {(float)dir.x, (float)dir.y, (float)dir.z}, 0, (unsigned)i};
    return 1;
}

/* x in the Gaussian's canonical frame: S^-1 R^T x. */
static vec3 canonical(const double R[3][3], const float *s, vec3 x)
{
    return v3((R[0][0] * x.x + R[1][0] * x.y + R[2][0] * x.z) / s[0],
              (R[0][1] * x.x + R[1][1] * x.y + R[2][1] * x.z) / s[1],
              (R[0][2] * x.x + R[1][2] * x.y + R[2][2] * x.z) / s[2]);
}

int gaussian_hit_3d(const gaussian_model *m, size_t i, const gaussian_ray *r, gaussian_hit *h)
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
    double alpha = clamp_alpha(m->opacity[i], response);
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
    if (m->kind == GAUSSIAN_3D)
        r2 = fmin(r2, -2.0 * log(GAUSSIAN_GRT_MIN_RESPONSE));
    return r2 > 0 ? sqrt(r2) : 0.0;
}

double gaussian_key_lead(const gaussian_model *m, gaussian_order order, double s, double depth_per_t)
{
    if (m->kind != GAUSSIAN_2D || order != GAUSSIAN_ORDER_CENTER_DEPTH)
        return 0.0;
    /* the hit lies in the splat's plane within 3.33 scales of the centre
     * (rho3d <= 2 ln 255), or has the centre's depth (the filter won) */
    return 3.3302 * s / depth_per_t * (1 + 1e-6);
}

double gaussian_filter_reach(const gaussian_model *m, size_t i, double distance, double focal)
{
    /* rho2d = 2 |d|^2 <= 2 ln(255 o): the ray's pixel lies within
     * sqrt(ln(255 o)) pixels of the centre of the image of the splat's unit
     * circle, which is the image of a point P of its unit disc; at P's view
     * depth (at most distance + the larger scale) a pixel spans depth / focal */
    double px2 = log(m->opacity[i] / GAUSSIAN_ALPHA_MIN);
    if (m->kind != GAUSSIAN_2D || !(px2 > 0))
        return 0.0;
    const float *s = &m->scale[3 * i];
    double radius = fmax(s[0], s[1]);
    return radius + sqrt(px2) * (distance + radius) / focal;
}

aabb gaussian_bounds(const gaussian_model *m, size_t i, double filter_reach)
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
        double e = fmax(k * sqrt(e2), filter_reach);
        double pad = e * 1e-5 + 1e-6 * fabs(c[a]) + 1e-30; /* float rounding never clips a Gaussian */
        lo[a] = c[a] - e - pad, hi[a] = c[a] + e + pad;
    }
    b.lo = v3(lo[0], lo[1], lo[2]), b.hi = v3(hi[0], hi[1], hi[2]);
    return b;
}

/* Compositing order: key, then object, then Gaussian (ties in key are
 * rare but must not depend on the order the traversal found them in). */
static int hit_before(const gaussian_hit *a, const gaussian_hit *b)
{
    if (a->key != b->key)
        return a->key < b->key;
    if (a->obj != b->obj)
        return a->obj < b->obj;
    return a->prim < b->prim;
}

/* A float's bits as an unsigned that sorts as the float does. */
static uint32_t sortable(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u & 0x80000000u ? ~u : u | 0x80000000u;
}

/* Bottom-up merge sort of 64-bit words (key bits above, hit index below):
 * rays gather tens to hundreds of hits, and sorting the hits themselves
 * through qsort's callback took a fifth of the render (make bench). */
static void merge_sort_u64(uint64_t *a, uint64_t *tmp, size_t n)
{
    for (size_t width = 1; width < n; width *= 2) {
        for (size_t lo = 0; lo < n; lo += 2 * width) {
            size_t mid = lo + width < n ? lo + width : n, hi = lo + 2 * width < n ? lo + 2 * width : n;
            size_t i = lo, j = mid, k = lo;
            while (i < mid && j < hi)
                tmp[k++] = a[j] < a[i] ? a[j++] : a[i++];
            while (i < mid)
                tmp[k++] = a[i++];
            while (j < hi)
                tmp[k++] = a[j++];
        }
        memcpy(a, tmp, n * sizeof *a);
    }
}

/* h->order holds, per hit: its sort word, the merge sort's scratch word,
 * and room for the hits kept for later (gaussian_blend_hits). */
enum { ORDER_WORDS = 2 + (sizeof(gaussian_hit) + sizeof(uint64_t) - 1) / sizeof(uint64_t) };

/* Puts h->order[] in compositing order (h->hits stay where they are). */
static int sort_hits(gaussian_hits *h)
{
    if (h->count > h->order_cap) {
        uint64_t *grown = realloc(h->order, ORDER_WORDS * h->count * sizeof *grown);
        if (!grown)
            return -1;
        h->order = grown, h->order_cap = h->count;
    }
    for (size_t k = 0; k < h->count; k++)
        h->order[k] = (uint64_t)sortable(h->hits[k].key) << 32 | (uint64_t)k;
    merge_sort_u64(h->order, h->order + h->count, h->count);
    for (size_t k = 1; k < h->count; k++) /* equal keys: by object and Gaussian */
        for (size_t j = k; j > 0 && h->order[j] >> 32 == h->order[j - 1] >> 32 &&
                           hit_before(&h->hits[(uint32_t)h->order[j]], &h->hits[(uint32_t)h->order[j - 1]]);
             j--) {
            uint64_t x = h->order[j];
            h->order[j] = h->order[j - 1], h->order[j - 1] = x;
        }
    return 0;
}

void gaussian_blend_init(gaussian_blend *b)
{
    b->T = 1.0, b->sum = v3(0, 0, 0), b->composited = 0, b->done = 0;
}

/* Each model's own stopping rule (gaussian_hit.h): a 2D hit that would
 * bring T below 1e-4 is not composited; a 3D hit is while T > 1e-3. */
static int blend_stops(const gaussian_blend *b, const gaussian_hit *g, const gaussian_model *m)
{
    if (m->kind == GAUSSIAN_3D)
        return !(b->T > GAUSSIAN_GRT_MIN_TRANSMITTANCE);
    return b->T * (1.0 - g->alpha) < GAUSSIAN_MIN_TRANSMITTANCE;
}

static void blend_one(gaussian_blend *b, const gaussian_hit *g, const gaussian_model *m)
{
    if (blend_stops(b, g, m)) {
        b->done = 1;
        return;
    }
    double next = b->T * (1.0 - g->alpha);
    vec3 c = gaussian_sh_color(&m->sh[(size_t)3 * m->sh_coeffs * g->prim], m->sh_degree,
                               v3(g->dir[0], g->dir[1], g->dir[2]));
    b->sum = v3_add(b->sum, v3_scale(c, g->alpha * b->T));
    b->T = next;
    b->composited++;
}

void gaussian_blend_hits(gaussian_blend *b, gaussian_hits *h, const gaussian_model *const *models,
                         double final_below)
{
    if (!h->count)
        return;
    if (sort_hits(h)) { /* no memory to order them: the hits are dropped, and counted */
        h->dropped += h->count;
        h->count = 0;
        return;
    }
    size_t k = 0;
    for (; k < h->count && !b->done; k++) {
        const gaussian_hit *g = &h->hits[(uint32_t)h->order[k]];
        if (!(g->key < final_below))
            break;
        blend_one(b, g, models[g->obj]);
    }
    if (b->done) {
        h->count = 0;
        return;
    }
    /* keep the rest, in order (gathered hits are appended after them) */
    size_t rest = h->count - k;
    gaussian_hit *kept = (gaussian_hit *)(h->order + 2 * h->count);
    for (size_t j = 0; j < rest; j++)
        kept[j] = h->hits[(uint32_t)h->order[k + j]];
    memcpy(h->hits, kept, rest * sizeof *kept);
    h->count = rest;
}

vec3 gaussian_blend_over(const gaussian_blend *b, vec3 behind) { return v3_add(b->sum, v3_scale(behind, b->T)); }
