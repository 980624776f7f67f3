/* gaussian_hit.c: what the windowed gathering relies on. Compositing does
 * not depend on the order hits are found in nor on how they are split into
 * windows; it stops before the hit that would bring transmittance below
 * 1e-4; and every 2DGS hit, the filter's included, lies in its Gaussian's
 * bounds near its own distance (the box a window's traversal must visit),
 * checked over random splats and pixels; its key trails its distance by
 * at most gaussian_key_lead. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "motion/animation.h"
#include "gaussians/gaussian_hit.h"
#include "core/lanes.h"
#include "harness.h"

/* Why a lane test is skipped: without the vector path it would compare the
 * scalar code with itself. */
#define NO_LANES "no AVX2 lanes on this CPU (or RR_NO_LANES is set)"

static double uniform(unsigned *state) { return (double)rand_r(state) / RAND_MAX; }

/* One Gaussian of degree 0 per call slot; count n. */
static void model_of(gaussian_model *m, size_t n, gaussian_kind kind)
{
    gaussian_model_init(m);
    m->kind = kind, m->sh_degree = 0, m->sh_coeffs = 1;
    CHECK(gaussian_model_alloc(m, n) == 0);
    m->count = n;
}

static void random_gaussian(gaussian_model *m, size_t i, unsigned *st, double size)
{
    double q[4], len = 0;
    for (int k = 0; k < 4; k++)
        q[k] = uniform(st) - 0.5, len += q[k] * q[k];
    for (int k = 0; k < 4; k++)
        m->rotation[4 * i + k] = (float)(q[k] / sqrt(len));
    for (int k = 0; k < 3; k++) {
        m->mean[3 * i + k] = (float)(uniform(st) - 0.5);
        m->scale[3 * i + k] = k < 2 || m->kind == GAUSSIAN_3D ? (float)(size * (0.2 + uniform(st))) : 0.0f;
        m->sh[3 * i + k] = (float)uniform(st);
    }
    m->opacity[i] = (float)(0.05 + 0.95 * uniform(st));
}

static void blend_all(gaussian_hits *h, const gaussian_hit *hits, size_t n, const size_t *order, double split,
                      const gaussian_model *const *models, gaussian_blend *b)
{
    gaussian_blend_init(b);
    h->count = 0;
    for (size_t k = 0; k < n; k++) { /* two windows: keys below `split` are final after the first */
        if (k == n / 2)
            gaussian_blend_hits(b, h, models, split);
        gaussian_hits_add(h, &hits[order[k]]);
    }
    gaussian_blend_hits(b, h, models, INFINITY);
}

TEST(gaussian_blend_does_not_depend_on_the_order_hits_come_in)
{
    gaussian_model m;
    model_of(&m, 64, GAUSSIAN_2D);
    unsigned st = 7;
    for (size_t i = 0; i < 64; i++)
        random_gaussian(&m, i, &st, 0.1);
    const gaussian_model *models[2] = {&m, &m};
    gaussian_hit hits[64];
    size_t fwd[64], shuffled[64], keyed[64];
    for (size_t k = 0; k < 64; k++) { /* ties in key, broken by object then Gaussian */
        hits[k] = (gaussian_hit){(float)(k / 4), 1.0f, (float)(0.02 + 0.1 * uniform(&st)), {0, 0, 1},
                                 (unsigned)(k % 2), (unsigned)(63 - k)};
        fwd[k] = shuffled[k] = k;
    }
    for (size_t k = 63; k > 0; k--) {
        size_t j = (size_t)rand_r(&st) % (k + 1), t = shuffled[k];
        shuffled[k] = shuffled[j], shuffled[j] = t;
    }
    /* the first half found holds every key below 4 (found first by key) */
    for (size_t k = 0; k < 64; k++)
        keyed[k] = k;
    rr_arena hits_arena; /* the heap's memory */
    rr_arena_init(&hits_arena, 0);
    gaussian_hits h;
    gaussian_hits_init(&h, &hits_arena);
    gaussian_blend a, b, c;
    blend_all(&h, hits, 64, fwd, -1.0, models, &a);
    blend_all(&h, hits, 64, shuffled, -1.0, models, &b);
    blend_all(&h, hits, 64, keyed, 4.0, models, &c);
    CHECK(a.composited > 10 && a.T == b.T && a.T == c.T);
    CHECK(a.sum.x == b.sum.x && a.sum.y == c.sum.y && a.sum.z == c.sum.z && a.composited == c.composited);
    rr_arena_free(&hits_arena);
    gaussian_model_free(&m);
}

/* The hits' heap grows in its arena (a worker's: core/arena.h) and holds
 * what the arena can: an arena of one 4096-byte chunk holds at most
 * 4096 / sizeof(gaussian_hit) hits (rr_arena_grow's doubling from 64 may
 * stop short of that), each hit beyond is dropped and counted, and those
 * kept composite, all of them (alpha 0.001: T stays far above 1e-4).
 * Begun anew after the arena's reset, the heap reuses its chunk (no malloc)
 * and holds as many again; an arena that can hold nothing drops every hit. */
TEST(gaussian_hits_grow_in_their_arena_and_drop_what_it_cannot_hold)
{
    enum { N = 1000 };
    gaussian_model m;
    model_of(&m, N, GAUSSIAN_2D);
    const gaussian_model *models[1] = {&m};
    rr_arena arena, none;
    rr_arena_init(&arena, 4096), rr_arena_init(&none, 0);
    arena.limit = 4096, none.limit = 1;
    gaussian_hits h, starved;
    gaussian_hits_init(&h, &arena), gaussian_hits_init(&starved, &none);
    size_t kept[2];
    for (int batch = 0; batch < 2; batch++) {
        rr_arena_reset(&arena);
        gaussian_hits_begin(&h);
        h.dropped = 0;
        for (unsigned k = 0; k < N; k++) {
            gaussian_hit g = {(float)k, (float)k, 0.001f, {0, 0, 1}, 0, N - 1 - k};
            gaussian_hits_add(&h, &g), gaussian_hits_add(&starved, &g);
        }
        kept[batch] = h.count;
        CHECK(h.count >= 64 && h.count <= 4096 / sizeof(gaussian_hit) && h.count + h.dropped == N);
        gaussian_blend b;
        gaussian_blend_init(&b);
        gaussian_blend_hits(&b, &h, models, INFINITY);
        CHECK(b.composited == kept[batch] && h.count == 0);
    }
    printf("    hits kept in 4096 bytes: %zu of %d (%zu bytes a hit)\n", kept[0], N, sizeof(gaussian_hit));
    CHECK(kept[1] == kept[0] && arena.mallocs == 1);
    CHECK(starved.count == 0 && starved.dropped == 2 * N && none.bytes == 0);
    rr_arena_free(&arena), rr_arena_free(&none);
    gaussian_model_free(&m);
}

TEST(gaussian_blend_stops_before_transmittance_would_fall_below_1e_4)
{
    gaussian_model m;
    model_of(&m, 3, GAUSSIAN_2D);
    const gaussian_model *models[1] = {&m};
    rr_arena hits_arena; /* the heap's memory */
    rr_arena_init(&hits_arena, 0);
    gaussian_hits h;
    gaussian_hits_init(&h, &hits_arena);
    for (unsigned k = 0; k < 3; k++) {
        gaussian_hit g = {(float)k, (float)k, k ? 0.99f : 0.9f, {0, 0, 1}, 0, k};
        gaussian_hits_add(&h, &g);
    }
    gaussian_blend b;
    gaussian_blend_init(&b);
    gaussian_blend_hits(&b, &h, models, INFINITY);
    /* 1 -> 0.1 -> 1e-3 -> 1e-5 (below: stops before it) */
    CHECK(b.done && b.composited == 2);
    CHECK_NEAR(b.T, 1e-3, 1e-8);
    rr_arena_free(&hits_arena);
    gaussian_model_free(&m);
}

static int inside(aabb b, vec3 p)
{
    return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z;
}

/* Does the segment of the ray from the origin along dir with distances
 * in [t - lead, t + lead] meet the box? (slabs: exact, however thin the
 * box along the ray) */
static int ray_in_box_near(aabb box, vec3 dir, double t, double lead)
{
    double lo = t - lead, hi = t + lead, d[3] = {dir.x, dir.y, dir.z};
    double b0[3] = {box.lo.x, box.lo.y, box.lo.z}, b1[3] = {box.hi.x, box.hi.y, box.hi.z};
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0) {
            if (!(b0[a] <= 0 && 0 <= b1[a]))
                return 0;
            continue;
        }
        double ta = b0[a] / d[a], tb = b1[a] / d[a];
        lo = fmax(lo, fmin(ta, tb)), hi = fmin(hi, fmax(ta, tb));
    }
    return lo <= hi;
}

/* Does the 2D hit h of the ray from the origin along dir lie in its
 * Gaussian's bounds, the camera at the origin and no farther (focal 100,
 * the filter's pole bounded by GAUSSIAN_NEAR)? A point of the ray within
 * the lead of the hit's distance must be in the box. */
static int hit_in_its_box(const gaussian_model *m, vec3 dir, const gaussian_hit *h, double lead)
{
    gaussian_view_bound vb = {v3_len(v3(m->mean[0], m->mean[1], m->mean[2])), 100, 1, gaussian_filter_near(1, 1),
                              v3(0, 0, 1), 0};
    return ray_in_box_near(gaussian_view_bounds(m, 0, &vb), dir, h->t, lead);
}

/* Random splats of every size from far below a pixel to many pixels, seen
 * from a camera at the origin looking down +z with focal length 100
 * pixels, through random pixels near their centres' images. */
TEST(gaussian_2d_hits_lie_in_their_bounds_within_the_lead_of_their_distance)
{
    gaussian_model m;
    model_of(&m, 1, GAUSSIAN_2D);
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 100, 100, 50, 50, 100, 100};
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    unsigned st = 11;
    int hits = 0, filtered = 0, outside = 0, late = 0;
    for (int trial = 0; trial < 20000; trial++) {
        random_gaussian(&m, 0, &st, pow(10.0, -4 + 3.5 * uniform(&st)));
        m.mean[2] += 2.0f; /* in front: depth 1.5 to 2.5 */
        double depth = m.mean[2], cx = 100 * m.mean[0] / depth + 50, cy = 100 * m.mean[1] / depth + 50;
        double x = cx + 8 * (uniform(&st) - 0.5), y = cy + 8 * (uniform(&st) - 0.5);
        vec3 dir = v3_normalize(v3((x - 50) / 100, (y - 50) / 100, 1));
        gaussian_ray r;
        gaussian_ray_init(&r, &v, &id, x, y, v3(0, 0, 0), dir);
        gaussian_hit h;
        if (!gaussian_hit_2d(&m, 0, GAUSSIAN_ORDER_CENTER_DEPTH, &r, &h))
            continue;
        hits++;
        double s = fmax(m.scale[0], m.scale[1]), lead = gaussian_key_lead(&m, GAUSSIAN_ORDER_CENTER_DEPTH, s, dir.z);
        filtered += s < 1e-3; /* sub-pixel: seen through the filter */
        /* the camera's distance bounds the view depth the footprint is taken at */
        outside += !hit_in_its_box(&m, dir, &h, lead);
        late += h.key < h.t - lead * (1 + 1e-5) - 1e-6;
    }
    CHECK(hits > 2000 && filtered > 500);
    CHECK(outside == 0);
    CHECK(late == 0);
    gaussian_model_free(&m);
}

/* The 3D rasterizers' hits: random ellipsoids from far below a pixel to
 * many pixels, means from the axis to beyond the Jacobian's clamp (x/z up
 * to 1.6 where 1.3 tan(fov/2) = 0.65), through random pixels near their
 * images, under every rasterizer semantics: the point of the ray at the
 * hit's distance lies in the Gaussian's bounds (the traversal's pad is 0). */
TEST(gaussian_3d_raster_hits_lie_in_their_bounds_at_their_distance)
{
    gaussian_model m;
    model_of(&m, 1, GAUSSIAN_3D);
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 100, 80, 50, 50, 100, 100};
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    const gaussian_formation kinds[] = {GAUSSIAN_FORMATION_3DGS, GAUSSIAN_FORMATION_3DGS_ANTIALIASED,
                                        GAUSSIAN_FORMATION_GSPLAT, GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED};
    unsigned st = 23;
    int hits = 0, beyond_clamp = 0, outside = 0;
    for (int trial = 0; trial < 40000; trial++) {
        m.formation = kinds[trial % 4];
        random_gaussian(&m, 0, &st, pow(10.0, -4 + 3.5 * uniform(&st)));
        double depth = 0.5 + 3 * uniform(&st);
        m.mean[0] = (float)((uniform(&st) - 0.5) * 3.2 * depth), m.mean[1] = (float)((uniform(&st) - 0.5) * 2 * depth);
        m.mean[2] = (float)depth;
        double cx = 100 * m.mean[0] / depth + 50, cy = 80 * m.mean[1] / depth + 50;
        double x = cx + 40 * (uniform(&st) - 0.5), y = cy + 40 * (uniform(&st) - 0.5);
        vec3 dir = v3_normalize(v3((x - 50) / 100, (y - 50) / 80, 1));
        gaussian_ray r;
        gaussian_ray_init(&r, &v, &id, x, y, v3(0, 0, 0), dir);
        gaussian_hit h;
        if (!gaussian_hit_any(&m, 0, GAUSSIAN_ORDER_CENTER_DEPTH, &r, &h))
            continue;
        hits++;
        beyond_clamp += fabs(m.mean[0] / depth) > 0.65;
        gaussian_view_bound vb = {v3_len(v3(m.mean[0], m.mean[1], depth)), 80, gaussian_view_stretch(&v), 0, v3(0, 0, 1), 0};
        aabb box = gaussian_view_bounds(&m, 0, &vb);
        outside += !inside(box, v3_scale(dir, h.t));
        CHECK(h.key == h.t && gaussian_traversal_pad(&m, 1.0, dir.z) == 0.0);
    }
    CHECK(hits > 4000 && beyond_clamp > 500);
    CHECK(outside == 0);
    gaussian_model_free(&m);
}

/* A 3D rasterizer's Gaussian under a camera whose principal point is off
 * the image centre: a needle (scales s, s/100, s/100) along the direction
 * its Jacobian stretches most, opacity 1, at camera-space mean `mean`, and
 * the raster position `u` reaches (0 to 1.15) of the way along its
 * footprint's major axis toward 3.33 sigma (where alpha reaches 1/255).
 * The Jacobian's clamp as the sources state it (gsplat v1.5.3 persp_proj,
 * 937e299 gsplat/cuda/include/Utils.cuh:514-524: [-(cx/fx + 0.3 tan),
 * (W - cx)/fx + 0.3 tan], tan = W / (2 fx); Inria's computeCov2D: +-1.3
 * tan_fovx about the axis, GAUSSIANS.md's rule for a principal point off
 * the centre), so that the needle is the one whose footprint is widest. */
static double clamped_ratio(int gsplat, double ratio, double size, double f, double c)
{
    double t = 0.5 * size / f, neg = gsplat ? c / f + 0.3 * t : 1.3 * t, pos = gsplat ? (size - c) / f + 0.3 * t : 1.3 * t;
    return fmin(pos, fmax(-neg, ratio));
}

static void needle_at_its_reach(gaussian_model *m, const camera_view *v, unsigned *st, double *x, double *y)
{
    int gsplat = m->formation == GAUSSIAN_FORMATION_GSPLAT || m->formation == GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED;
    double z = 0.3 + 3.7 * uniform(st), rx = 5 * (uniform(st) - 0.5), ry = 5 * (uniform(st) - 0.5);
    double tx = clamped_ratio(gsplat, rx, v->width, v->fx, v->cx), ty = clamped_ratio(gsplat, ry, v->height, v->fy, v->cy);
    /* J = diag(fx, fy) / z [[1, 0, -tx], [0, 1, -ty]] stretches (tx, ty, -(tx^2 + ty^2)) the most */
    vec3 d = v3_normalize(v3(tx, ty, -(tx * tx + ty * ty)));
    if (!(tx * tx + ty * ty > 1e-6))
        d = v3(1, 0, 0);
    double q[4] = {1 + d.x, 0, -d.z, d.y}, len = sqrt(q[0] * q[0] + q[2] * q[2] + q[3] * q[3]); /* x axis -> d */
    double px = (1 + 14 * uniform(st)) * z / v->fx; /* major sigma 1 to 15 pixels at the axis */
    for (int k = 0; k < 4; k++)
        m->rotation[k] = (float)(q[k] / len);
    m->scale[0] = (float)px, m->scale[1] = m->scale[2] = (float)(px / 100);
    m->mean[0] = (float)(rx * z), m->mean[1] = (float)(ry * z), m->mean[2] = (float)z;
    m->opacity[0] = 1.0f;
    double ax = v->fx * (d.x - tx * d.z) / z * px, ay = v->fy * (d.y - ty * d.z) / z * px; /* the major sigma */
    double u = 1.15 * uniform(st) * 3.33;
    *x = v->fx * rx + v->cx + u * ax + (uniform(st) - 0.5), *y = v->fy * ry + v->cy + u * ay + (uniform(st) - 0.5);
}

/* The five rasterizer semantics (3DGRT has no screen footprint). */
enum { RASTER_FORMATIONS = 5 };
static const gaussian_formation raster_formations[RASTER_FORMATIONS] = {
    GAUSSIAN_FORMATION_3DGS, GAUSSIAN_FORMATION_3DGS_ANTIALIASED, GAUSSIAN_FORMATION_GSPLAT,
    GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED, GAUSSIAN_FORMATION_3DGS_FOV_MINUS_ONE};

/* A 100 x 80 camera at the origin with its principal point off the centre
 * (a transforms.json camera's): anywhere in the middle 90% of the image. */
static camera_view off_centre_view(unsigned *st)
{
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 50, 50 + 20 * uniform(st),
                     100 * (0.05 + 0.9 * uniform(st)), 80 * (0.05 + 0.9 * uniform(st)), 100, 80};
    return v;
}

/* What a ray through raster (x, y) of view v finds of Gaussian 0 of one:
 * whether it hits, whether the cull dropped that hit, and whether the hit
 * lies outside the Gaussian's bounds drawn with the given stretch. */
typedef struct {
    int hit, dropped, outside;
    vec3 mean;
} needle_probe;

static needle_probe probe_needle(const gaussian_model *one, const camera_view *v, double x, double y, double stretch)
{
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    vec3 p, dir = v3_normalize(v3((x - v->cx) / v->fx, (y - v->cy) / v->fy, 1));
    needle_probe out = {0, 0, 0, v3(one->mean[0], one->mean[1], one->mean[2])};
    gaussian_ray r;
    gaussian_ray_init(&r, v, &id, x, y, v3(0, 0, 0), dir);
    gaussian_hit h;
    int kept = gaussian_cull(one, 0, &r, &p);
    out.hit = gaussian_hit_after_cull(one, 0, GAUSSIAN_ORDER_CENTER_DEPTH, &r, p, &h);
    out.dropped = out.hit && !kept;
    if (out.hit) {
        gaussian_view_bound vb = {v3_len(out.mean), fmin(v->fx, v->fy), stretch, 0, v3(0, 0, 1), 0};
        out.outside = !inside(gaussian_view_bounds(one, 0, &vb), v3_scale(dir, h.t));
    }
    return out;
}

/* With the principal point off the centre, the cull's reach
 * (gaussian_view_stretch) and the bounds hold the wider clamp: the cull
 * never drops a hit and every hit lies in its bounds, for needles beyond
 * either clamp at the edge of their footprints under the five rasterizer
 * semantics. */
TEST(gaussian_3d_raster_culls_and_bounds_hold_an_off_centre_principal_point)
{
    unsigned st = 57;
    long hits = 0, dropped = 0, outside = 0, far_out = 0;
    for (int trial = 0; trial < 64; trial++) {
        camera_view v = off_centre_view(&st);
        gaussian_model one;
        model_of(&one, 1, GAUSSIAN_3D);
        one.formation = raster_formations[trial % RASTER_FORMATIONS];
        for (int k = 0; k < 400; k++) {
            double x, y;
            needle_at_its_reach(&one, &v, &st, &x, &y);
            needle_probe n = probe_needle(&one, &v, x, y, gaussian_view_stretch_of(one.formation, &v));
            hits += n.hit, dropped += n.dropped, outside += n.outside;
            far_out += n.hit && fmax(fabs(n.mean.x / n.mean.z) * v.fx / 50, fabs(n.mean.y / n.mean.z) * v.fy / 40) > 1.3;
        }
        gaussian_model_free(&one);
    }
    printf("    hits %ld (beyond 1.3 tan(fov/2) %ld): dropped by the cull %ld, outside their bounds %ld\n", hits,
           far_out, dropped, outside);
    CHECK(hits > 5000 && far_out > 1000);
    CHECK(dropped == 0 && outside == 0);
}

/* 3dgs-fov-minus-one: the rasterizer handed FoV = -1 (4d-gaussian-splatting
 * 63725f21, GAUSSIANS.md) builds J = diag(a, b) / z [[1, 0, -t], [0, 1, -t]]
 * with a = W / (2 tan(-0.5)), b = H / (2 tan(-0.5)), t = 1.3 tan(-0.5)
 * (rasterizer_impl.cu:235-236, forward.cu:206-216), whatever the camera's
 * focal length and the mean's x/z. A needle (scales s, s/100, s/100) along
 * J's widest direction J^T u (u the top eigenvector of J J^T), opacity 1,
 * anywhere in a wide view (fx = 30 for W = 100: the pinned focal 91.5 is
 * three times the camera's, as N3V's is 1.7 times), reached by rays
 * toward its footprint's edge (up to 1.15 x 3.33 sigma): the cull never
 * drops a hit and every hit lies in the bounds of the pinned stretch; the
 * camera's own stretch (the other semantics') misses some. */
static void needle_along_the_pinned_jacobian(gaussian_model *m, const camera_view *v, unsigned *st, double *x,
                                             double *y)
{
    double tn = tan(-0.5), a = v->width / (2 * tn), b = v->height / (2 * tn), t = 1.3 * tn;
    /* J J^T z^2 = [[a^2 (1 + t^2), a b t^2], [a b t^2, b^2 (1 + t^2)]]: its top eigenvector u */
    double p = a * a * (1 + t * t), q = a * b * t * t, r = b * b * (1 + t * t);
    double lam = 0.5 * (p + r) + sqrt(0.25 * (p - r) * (p - r) + q * q), ux = q, uy = lam - p;
    double z = 0.3 + 3.7 * uniform(st), rx = 3 * (uniform(st) - 0.5), ry = 2.4 * (uniform(st) - 0.5);
    vec3 d = v3_normalize(v3(a * ux, b * uy, -t * (a * ux + b * uy))); /* J^T u */
    double q4[4] = {1 + d.x, 0, -d.z, d.y}, len = sqrt(q4[0] * q4[0] + q4[2] * q4[2] + q4[3] * q4[3]);
    double s = (0.3 + 5 * uniform(st)) * z / v->fx;
    for (int k = 0; k < 4; k++)
        m->rotation[k] = (float)(q4[k] / len);
    m->scale[0] = (float)s, m->scale[1] = m->scale[2] = (float)(s / 100);
    m->mean[0] = (float)(rx * z), m->mean[1] = (float)(ry * z), m->mean[2] = (float)z;
    m->opacity[0] = 1.0f;
    double ax = a * (d.x - t * d.z) / z * s, ay = b * (d.y - t * d.z) / z * s; /* the major sigma, pixels */
    double u = 1.15 * uniform(st) * 3.33;
    *x = v->fx * rx + v->cx + u * ax + (uniform(st) - 0.5), *y = v->fy * ry + v->cy + u * ay + (uniform(st) - 0.5);
}

TEST(gaussian_3d_fov_minus_one_culls_and_bounds_hold_the_pinned_footprint)
{
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 30, 30, 50, 40, 100, 80};
    gaussian_model one;
    model_of(&one, 1, GAUSSIAN_3D);
    one.formation = GAUSSIAN_FORMATION_3DGS_FOV_MINUS_ONE;
    unsigned st = 61;
    long hits = 0, dropped = 0, outside = 0, outside_camera_stretch = 0;
    for (int k = 0; k < 40000; k++) {
        double x, y;
        needle_along_the_pinned_jacobian(&one, &v, &st, &x, &y);
        needle_probe n = probe_needle(&one, &v, x, y, gaussian_view_stretch_of(one.formation, &v));
        hits += n.hit, dropped += n.dropped, outside += n.outside;
        outside_camera_stretch += probe_needle(&one, &v, x, y, gaussian_view_stretch(&v)).outside;
    }
    gaussian_model_free(&one);
    printf("    hits %ld: dropped by the cull %ld, outside their bounds %ld (%ld with the camera's stretch)\n", hits,
           dropped, outside, outside_camera_stretch);
    CHECK(hits > 10000 && outside_camera_stretch > 100);
    CHECK(dropped == 0 && outside == 0);
}

/* The same needles, N of them about one ray's pixel (their means moved by
 * their offsets), under an off-centre principal point (the stretch of the
 * wider clamp): the cull in lanes (gaussian_cull_candidates) keeps exactly
 * the Gaussians the scalar cull keeps, with the same means, bit for bit. */
TEST(gaussian_3d_cull_in_lanes_is_the_scalar_cull_under_an_off_centre_principal_point)
{
    SKIP_UNLESS(rr_lanes_available(), NO_LANES);
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    enum { N = 1027 };
    unsigned st = 58;
    long kept_total = 0, mismatched = 0;
    gaussian_candidate *cand = malloc(N * sizeof *cand);
    for (int trial = 0; trial < 64; trial++) {
        camera_view v = off_centre_view(&st);
        gaussian_model one, batch;
        model_of(&one, 1, GAUSSIAN_3D), model_of(&batch, N, GAUSSIAN_3D);
        one.formation = batch.formation = raster_formations[trial % RASTER_FORMATIONS];
        double x = 100 * uniform(&st), y = 80 * uniform(&st);
        gaussian_ray r;
        gaussian_ray_init(&r, &v, &id, x, y, v3(0, 0, 0), v3_normalize(v3((x - v.cx) / v.fx, (y - v.cy) / v.fy, 1)));
        for (size_t i = 0; i < N; i++) {
            double gx, gy;
            needle_at_its_reach(&one, &v, &st, &gx, &gy);
            memcpy(&batch.rotation[4 * i], one.rotation, sizeof(float[4])), memcpy(&batch.scale[3 * i], one.scale, sizeof(float[3]));
            batch.opacity[i] = one.opacity[0];
            batch.mean[3 * i] = (float)(one.mean[0] + (x - gx) * one.mean[2] / v.fx);
            batch.mean[3 * i + 1] = (float)(one.mean[1] + (y - gy) * one.mean[2] / v.fy), batch.mean[3 * i + 2] = one.mean[2];
            cand[i].prim = (unsigned)i;
        }
        size_t kept = gaussian_cull_candidates(&batch, &r, cand, N, 0), j = 0;
        for (size_t i = 0; i < N; i++) {
            vec3 p;
            if (gaussian_cull(&batch, i, &r, &p))
                mismatched += j >= kept || cand[j].prim != i || memcmp(&cand[j].p, &p, sizeof p), j++;
        }
        mismatched += j != kept;
        kept_total += (long)kept;
        gaussian_model_free(&one), gaussian_model_free(&batch);
    }
    free(cand);
    printf("    kept %ld of %d, differing from the scalar cull %ld\n", kept_total, 64 * N, mismatched);
    CHECK(kept_total > 64 * N / 2); /* (at their reach: most are kept, their means compared) */
    CHECK(mismatched == 0);
}

/* The 2DGS semantics (both circle rules, both near rules) and the four
 * rasterizer semantics (3DGRT has no cull and no screen footprint). */
enum { SPLATTING_FORMATIONS = 7 };
static const gaussian_formation splatting_formations[SPLATTING_FORMATIONS] = {
    GAUSSIAN_FORMATION_2DGS, GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE, GAUSSIAN_FORMATION_3DGS,
    GAUSSIAN_FORMATION_3DGS_ANTIALIASED, GAUSSIAN_FORMATION_GSPLAT, GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED,
    GAUSSIAN_FORMATION_2DGS_CENTER_NEAR};

/* The cull (gaussian_cull, from mean and scale) never drops a Gaussian
 * that the whole evaluation would hit, and every 2D hit lies in its box:
 * random Gaussians of the three 2DGS semantics and the four rasterizer
 * semantics, from far below a pixel to many pixels, tilted at random, at
 * view depths from just beyond GAUSSIAN_NEAR (where the filter's pole
 * bound is tightest) to 3, through pixels up to 20 pixels from their
 * means' images. */
TEST(gaussian_culls_never_drop_a_hit_and_2d_hits_near_the_camera_lie_in_their_bounds)
{
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 100, 100, 50, 50, 100, 100};
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    unsigned st = 31;
    int hits = 0, near_hits = 0, culled = 0, dropped = 0, outside = 0;
    for (int trial = 0; trial < 60000; trial++) {
        gaussian_model m;
        gaussian_formation f = splatting_formations[trial % SPLATTING_FORMATIONS];
        model_of(&m, 1, f <= GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? GAUSSIAN_2D : GAUSSIAN_3D);
        m.formation = f;
        double depth = GAUSSIAN_NEAR * (1 + 1e-3) + 2.8 * pow(uniform(&st), 2);
        random_gaussian(&m, 0, &st, depth * pow(10.0, -3.5 + 3 * uniform(&st)));
        m.mean[0] = (float)((uniform(&st) - 0.5) * depth), m.mean[1] = (float)((uniform(&st) - 0.5) * depth);
        m.mean[2] = (float)depth;
        double x = 100 * m.mean[0] / depth + 50 + 40 * (uniform(&st) - 0.5);
        double y = 100 * m.mean[1] / depth + 50 + 40 * (uniform(&st) - 0.5);
        vec3 dir = v3_normalize(v3((x - 50) / 100, (y - 50) / 100, 1)), p;
        gaussian_ray r;
        gaussian_ray_init(&r, &v, &id, x, y, v3(0, 0, 0), dir);
        gaussian_hit h;
        int kept = gaussian_cull(&m, 0, &r, &p);
        int hit = gaussian_hit_after_cull(&m, 0, GAUSSIAN_ORDER_CENTER_DEPTH, &r, p, &h);
        culled += !kept, dropped += hit && !kept, hits += hit;
        if (hit && m.kind == GAUSSIAN_2D) {
            double s = fmax(m.scale[0], m.scale[1]);
            near_hits += depth < 0.5;
            outside += !hit_in_its_box(&m, dir, &h, gaussian_key_lead(&m, GAUSSIAN_ORDER_CENTER_DEPTH, s, dir.z));
        }
        gaussian_model_free(&m);
    }
    printf("    hits %d (2D near the camera %d), culled %d: of them hits %d; 2D hits outside their box %d\n", hits, near_hits, culled, dropped, outside);
    CHECK(hits > 5000 && near_hits > 300 && culled > 20000);
    CHECK(dropped == 0);
    CHECK(outside == 0);
}

/* A random rotation by at most angle_max, as the rows of R. */
static void random_rotation(unsigned *st, double angle_max, vec3 R[3])
{
    vec3 axis = v3_normalize(v3(uniform(st) - 0.5, uniform(st) - 0.5, uniform(st) - 0.5));
    double m[3][3];
    rotation_matrix(axis, angle_max * uniform(st), m);
    for (int k = 0; k < 3; k++)
        R[k] = v3(m[k][0], m[k][1], m[k][2]);
}

static vec3 rotate(const vec3 R[3], vec3 p) { return v3(v3_dot(R[0], p), v3_dot(R[1], p), v3_dot(R[2], p)); }

/* gaussian_cull_candidates (the culls in vector lanes where the CPU has
 * AVX2) keeps exactly the Gaussians gaussian_cull keeps, in order, with
 * the same camera-space means and key floors, bit for bit: the three
 * 2DGS semantics and the four rasterizer semantics, means behind the camera, at the near plane and out to 4,
 * from far below a pixel to many pixels, scattered about the cull's edge
 * (the footprint's reach from the pixel's ray) and exactly at the near
 * plane, half of the trials through a turned, unevenly scaled object
 * (where regrouping a sum changes the means); candidate counts that are
 * no multiple of the lanes. */
enum { CULL_TRIAL_N = 4099 };

/* One trial of the lanes' tests: CULL_TRIAL_N Gaussians of
 * splatting_formations[trial % SPLATTING_FORMATIONS] about a random pixel's ray r. */
static void cull_trial(int trial, unsigned *st, gaussian_model *m, gaussian_ray *r)
{
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 100, 100, 50, 50, 100, 100};
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    enum { N = CULL_TRIAL_N };
    m->formation = splatting_formations[trial % SPLATTING_FORMATIONS];
    model_of(m, N, m->formation <= GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? GAUSSIAN_2D : GAUSSIAN_3D);
    m->formation = splatting_formations[trial % SPLATTING_FORMATIONS];
    double x = 100 * uniform(st), y = 100 * uniform(st);
    vec3 dir = v3_normalize(v3((x - 50) / 100, (y - 50) / 100, 1));
    for (size_t i = 0; i < N; i++) {
        double depth = -0.5 + 4.5 * uniform(st) * uniform(st) + (i % 7 == 0 ? GAUSSIAN_NEAR + 0.5 : 0);
        random_gaussian(m, i, st, fabs(depth) * pow(10.0, -4 + 3 * uniform(st)));
        double reach = 3.4 * fmax(m->scale[3 * i], m->scale[3 * i + 1]) + 2.4 * fabs(depth) / 100; /* the cull's scale */
        vec3 at = v3_scale(dir, depth / dir.z);
        for (int k = 0; k < 3; k++)
            m->mean[3 * i + k] = (float)((k == 0 ? at.x : k == 1 ? at.y : at.z) + 1.3 * reach * (2 * uniform(st) - 1));
    }
    for (size_t i = 0; i < N; i += 5) { /* exactly at the near plane of 2DGS and Inria (0.2): 0.5 - 0.3 */
        m->mean[3 * i] = (float)(0.5 * dir.x / dir.z), m->mean[3 * i + 1] = (float)(0.5 * dir.y / dir.z);
        m->mean[3 * i + 2] = 0.5f;
    }
    xform back = id;
    back.t = v3(0, 0, -0.3); /* the others 0.3 nearer */
    if (trial % 2) { /* a turned, unevenly scaled object: sums of unlike terms (their order shows) */
        double R[3][3], sc[3] = {0.7 + uniform(st), 0.7 + uniform(st), 0.7 + uniform(st)};
        rotation_matrix(v3_normalize(v3(uniform(st) - 0.5, uniform(st) - 0.5, uniform(st) - 0.5)), 3 * uniform(st), R);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                back.r[a][b] = R[a][b] * sc[b], back.ri[a][b] = R[b][a] / sc[a];
        back.scaled = 1, back.t = v3(0.01 * uniform(st), 0.01 * uniform(st), -0.3);
        for (size_t i = 0; i < N; i++) { /* the same world means as the identity's */
            vec3 w = xform_inverse_point(&back, v3(m->mean[3 * i], m->mean[3 * i + 1], m->mean[3 * i + 2] - 0.3));
            m->mean[3 * i] = (float)w.x, m->mean[3 * i + 1] = (float)w.y, m->mean[3 * i + 2] = (float)w.z;
        }
    }
    gaussian_ray_init(r, &v, &back, x, y, v3(0, 0, 0), dir);
}

TEST(gaussian_cull_candidates_keeps_what_gaussian_cull_keeps)
{
    SKIP_UNLESS(rr_lanes_available(), NO_LANES);
    unsigned st = 91;
    enum { N = CULL_TRIAL_N };
    gaussian_candidate *cand = malloc(N * sizeof *cand);
    long kept_total = 0, culled_total = 0, mismatched = 0;
    for (int trial = 0; trial < 60; trial++) {
        gaussian_model m;
        gaussian_ray r;
        cull_trial(trial, &st, &m, &r);
        size_t n = N - (size_t)trial % 4;
        for (size_t i = 0; i < n; i++)
            cand[i].prim = (unsigned)i;
        size_t kept = gaussian_cull_candidates(&m, &r, cand, n, 7), j = 0;
        for (size_t i = 0; i < n; i++) {
            vec3 p;
            if (!gaussian_cull(&m, i, &r, &p))
                continue;
            float floor = gaussian_key_floor(&m, i, &r, p);
            mismatched += j >= kept || cand[j].prim != i || memcmp(&cand[j].p, &p, sizeof p) || cand[j].ray != 7 ||
                          memcmp(&cand[j].key_floor, &floor, sizeof floor);
            j++;
        }
        mismatched += j != kept;
        kept_total += (long)kept, culled_total += (long)(n - kept);
        gaussian_model_free(&m);
    }
    free(cand);
    printf("    kept %ld, culled %ld, differing from gaussian_cull %ld\n", kept_total, culled_total, mismatched);
    CHECK(kept_total > 15000 && culled_total > 15000);
    CHECK(mismatched == 0);
}

/* gaussian_hits_after_cull4 (the 2D geometry in AVX2 lanes where the CPU
 * has them) finds exactly the hits gaussian_hit_after_cull finds one at a
 * time, bit for bit: the cull trials' Gaussians (the three 2DGS semantics,
 * and the rasterizers, which take the scalar path), both orders, the tile
 * rule on and off, in groups of four culled candidates. The hits' floats
 * hide a regrouped sum's last bit, so the DCHECKS build (make test)
 * compares every double of the geometry too. */
TEST(gaussian_hits_after_cull4_are_the_hits_one_at_a_time)
{
    SKIP_UNLESS(rr_lanes_available(), NO_LANES);
    unsigned st = 17;
    enum { N = CULL_TRIAL_N };
    gaussian_candidate *cand = malloc(N * sizeof *cand);
    long hits2d = 0, misses2d = 0, mismatched = 0, geometry_differs = 0;
    for (int trial = 0; trial < 96; trial++) {
        gaussian_model m;
        gaussian_ray r;
        cull_trial(trial, &st, &m, &r);
        m.tile_rule = trial / 6 % 2;
        gaussian_order order = trial / 12 % 2 ? GAUSSIAN_ORDER_HIT_DEPTH : GAUSSIAN_ORDER_CENTER_DEPTH;
        for (size_t i = 0; i < N; i++)
            cand[i].prim = (unsigned)i;
        size_t kept = gaussian_cull_candidates(&m, &r, cand, N, 0);
        for (size_t k = 0; k + 4 <= kept; k += 4) {
            unsigned prim[4];
            vec3 p[4];
            gaussian_hit four[4], one;
            for (int j = 0; j < 4; j++)
                prim[j] = cand[k + (size_t)j].prim, p[j] = cand[k + (size_t)j].p;
            int found = gaussian_hits_after_cull4(&m, prim, order, &r, p, four);
#ifdef RR_DCHECKS
            geometry_differs += __builtin_popcount((unsigned)gaussian_2d_geometry_lanes_differ(&m, prim, &r, p));
#endif
            for (int j = 0; j < 4; j++) {
                memset(&one, 0, sizeof one);
                int hit = gaussian_hit_after_cull(&m, prim[j], order, &r, p[j], &one);
                mismatched += hit != (found >> j & 1) || (hit && memcmp(&one, &four[j], sizeof one));
                if (m.kind == GAUSSIAN_2D)
                    hits2d += hit, misses2d += !hit;
            }
        }
        gaussian_model_free(&m);
    }
    free(cand);
    printf("    2D hits %ld, misses %ld, differing %ld, geometry differing in a bit %ld\n", hits2d, misses2d, mismatched,
           geometry_differs);
    CHECK(hits2d > 2000 && misses2d > 2000);
    CHECK(mismatched == 0 && geometry_differs == 0);
}

/* gaussian_key_floor lies at or below the key of every hit, in both
 * orders, under all eight formations, for objects placed by a rotation
 * and a uniform or non-uniform scale, with Gaussians from far below a
 * pixel to many pixels at depths from near the camera to 3; and it is
 * tight: some 2D hits' keys lie within a tenth of the pad above it (a pad
 * 0.9 as long fails), and a rasterizer's key is its floor. */
TEST(gaussian_key_floor_lies_below_every_hits_key)
{
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 100, 100, 50, 50, 100, 100};
    unsigned st = 77;
    int hits = 0, below = 0, tight_2d = 0, exact_3d = 0;
    for (int trial = 0; trial < 140000; trial++) {
        gaussian_model m;
        gaussian_formation f = trial % (SPLATTING_FORMATIONS + 1) == SPLATTING_FORMATIONS
                                   ? GAUSSIAN_FORMATION_3DGRT
                                   : splatting_formations[trial % (SPLATTING_FORMATIONS + 1)];
        model_of(&m, 1, f <= GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? GAUSSIAN_2D : GAUSSIAN_3D);
        m.formation = f;
        double R[3][3];
        rotation_matrix(v3_normalize(v3(uniform(&st) - 0.5, uniform(&st) - 0.5, uniform(&st) - 0.5)), M_PI * uniform(&st), R);
        double sc[3], depth = GAUSSIAN_NEAR * 1.5 + 2.8 * uniform(&st);
        for (int k = 0; k < 3; k++)
            sc[k] = trial % 2 ? 0.5 + 1.5 * uniform(&st) : 1.25;
        xform xf = {.scaled = trial % 2};
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                xf.r[i][j] = R[i][j] * sc[j], xf.ri[i][j] = R[j][i] / sc[i];
        random_gaussian(&m, 0, &st, depth * pow(10.0, -3.5 + 3 * uniform(&st)));
        vec3 mean = v3((uniform(&st) - 0.5) * depth, (uniform(&st) - 0.5) * depth, depth); /* camera = world */
        xf.t = v3_sub(mean, xform_vector(&xf, v3(m.mean[0], m.mean[1], m.mean[2])));
        double reach = 3 + 400 * fmax(m.scale[0], fmax(m.scale[1], m.scale[2])) * 2 / depth;
        double x = 100 * mean.x / depth + 50 + 2 * reach * (uniform(&st) - 0.5);
        double y = 100 * mean.y / depth + 50 + 2 * reach * (uniform(&st) - 0.5);
        vec3 dir = v3_normalize(v3((x - 50) / 100, (y - 50) / 100, 1)), p;
        gaussian_ray r;
        gaussian_ray_init(&r, &v, &xf, x, y, v3(0, 0, 0), dir);
        for (gaussian_order order = GAUSSIAN_ORDER_CENTER_DEPTH; order <= GAUSSIAN_ORDER_HIT_DEPTH; order++) {
            gaussian_hit h;
            if (!gaussian_cull(&m, 0, &r, &p) || !gaussian_hit_after_cull(&m, 0, order, &r, p, &h))
                continue;
            float floor = gaussian_key_floor(&m, 0, &r, p);
            double centre = p.z / r.depth_per_t;
            hits++, below += h.key < floor;
            tight_2d += m.kind == GAUSSIAN_2D && h.key < floor + 0.1 * (centre - floor);
            exact_3d += f != GAUSSIAN_FORMATION_3DGRT && m.kind == GAUSSIAN_3D && h.key == floor;
        }
        gaussian_model_free(&m);
    }
    printf("    hits %d, keys below their floor %d; 2D within a tenth of the pad %d, rasterizer keys at their floor %d\n",
           hits, below, tight_2d, exact_3d);
    CHECK(hits > 20000);
    CHECK(below == 0);
    CHECK(tight_2d > 0 && exact_3d > 5000);
}

/* Boxes flattened along the view axis (gaussian_view_bounds) hold every
 * hit: cameras of random orientation, turned up to 0.3 radians from the
 * axis the box is built for (the cone) or not at all, Gaussians of the
 * three 2DGS semantics and the four rasterizer semantics in front of them, pixels
 * across their footprints. A box 0.9 as flat across the axis fails. */
TEST(gaussian_boxes_flattened_along_the_view_axis_hold_every_hit)
{
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    unsigned st = 61;
    int hits = 0, turned = 0, outside = 0;
    for (int trial = 0; trial < 60000; trial++) {
        gaussian_model m;
        gaussian_formation f = splatting_formations[trial % SPLATTING_FORMATIONS];
        model_of(&m, 1, f <= GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? GAUSSIAN_2D : GAUSSIAN_3D);
        m.formation = f;
        vec3 ref[3], turn[3], cam[3];
        double cone = trial % 2 ? 0.3 : 0.0;
        random_rotation(&st, M_PI, ref);
        random_rotation(&st, cone, turn);
        for (int k = 0; k < 3; k++) /* the camera's axes: the reference's, turned */
            cam[k] = rotate(turn, ref[k]);
        camera_view v = {v3(0, 0, 0), {cam[0], cam[1], cam[2]}, 100, 80, 50, 50, 100, 100};
        double depth = 0.3 + 3 * uniform(&st);
        random_gaussian(&m, 0, &st, depth * pow(10.0, -4 + 3 * uniform(&st)));
        vec3 mean = v3_scale(v3_add(cam[2], v3_add(v3_scale(cam[0], 0.8 * (uniform(&st) - 0.5)),
                                                       v3_scale(cam[1], 0.6 * (uniform(&st) - 0.5)))), depth);
        m.mean[0] = (float)mean.x, m.mean[1] = (float)mean.y, m.mean[2] = (float)mean.z;
        vec3 p = v3(v3_dot(cam[0], mean), v3_dot(cam[1], mean), v3_dot(cam[2], mean));
        double reach = 3 + 350 * fmax(m.scale[0], fmax(m.scale[1], m.scale[2])) / p.z; /* pixels: the footprint's order */
        double x = 100 * p.x / p.z + 50 + 2 * reach * (uniform(&st) - 0.5), y = 80 * p.y / p.z + 50 + 2 * reach * (uniform(&st) - 0.5);
        vec3 dir = v3_normalize(v3_add(v3_add(v3_scale(cam[0], (x - 50) / 100), v3_scale(cam[1], (y - 50) / 80)), cam[2]));
        gaussian_ray r;
        gaussian_ray_init(&r, &v, &id, x, y, v3(0, 0, 0), dir);
        gaussian_hit h;
        if (gaussian_hit_any(&m, 0, GAUSSIAN_ORDER_CENTER_DEPTH, &r, &h)) {
            gaussian_view_bound vb = {v3_len(mean), 80, gaussian_view_stretch(&v), gaussian_filter_near(1, 1), ref[2], cone};
            double lead = m.kind == GAUSSIAN_2D ? gaussian_key_lead(&m, GAUSSIAN_ORDER_CENTER_DEPTH,
                                                                    fmax(m.scale[0], m.scale[1]), v3_dot(dir, cam[2])) : 0.0;
            hits++, turned += cone > 0;
            outside += !ray_in_box_near(gaussian_view_bounds(&m, 0, &vb), dir, h.t, lead);
        }
        gaussian_model_free(&m);
    }
    printf("    hits %d (%d by turned cameras), outside their boxes %d\n", hits, turned, outside);
    CHECK(hits > 8000 && turned > 3000);
    CHECK(outside == 0);
}

/* The cull keeps a 2DGS filter hit at the filter's very edge: sub-pixel
 * splats of opacity just below 1 (the filter reaches sqrt(ln 255) =
 * 2.35399 pixels) through pixels 2.35398 pixels from their filter centres
 * in every direction, under a non-uniformly scaled object, fx != fy (a
 * cull reach of 2.3537 pixels, as first written, drops them). */
TEST(gaussian_2d_cull_keeps_hits_at_the_filters_edge)
{
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 120, 90, 50, 50, 100, 100};
    xform xf = {{{1.7, 0, 0}, {0, 0.6, 0}, {0, 0, 1.1}}, {{1 / 1.7, 0, 0}, {0, 1 / 0.6, 0}, {0, 0, 1 / 1.1}}, {0, 0, 0}, 1};
    unsigned st = 53;
    int hits = 0, dropped = 0, trials = 4000;
    for (int trial = 0; trial < trials; trial++) {
        gaussian_model m;
        model_of(&m, 1, GAUSSIAN_2D);
        m.formation = trial % 2 ? GAUSSIAN_FORMATION_2DGS : GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE;
        double depth = 0.5 + 2.5 * uniform(&st);
        random_gaussian(&m, 0, &st, 1e-5 * depth);
        m.opacity[0] = 0.99999994f; /* the largest float below 1 */
        m.mean[0] = (float)((uniform(&st) - 0.5) * depth / 1.7), m.mean[1] = (float)((uniform(&st) - 0.5) * depth / 0.6);
        m.mean[2] = (float)(depth / 1.1);
        gaussian_ray r;
        double cx, cy, angle = 2 * M_PI * uniform(&st);
        gaussian_ray_init(&r, &v, &xf, 50, 50, v3(0, 0, 0), v3(0, 0, 1));
        CHECK(gaussian_filter_centre_2d(&m, 0, &r, &cx, &cy));
        double x = cx + 2.35398 * cos(angle), y = cy + 2.35398 * sin(angle);
        gaussian_ray_init(&r, &v, &xf, x, y, v3(0, 0, 0), v3_normalize(v3((x - 50) / 120, (y - 50) / 90, 1)));
        vec3 p;
        gaussian_hit h;
        int kept = gaussian_cull(&m, 0, &r, &p), hit = gaussian_hit_after_cull(&m, 0, GAUSSIAN_ORDER_CENTER_DEPTH, &r, p, &h);
        hits += hit, dropped += hit && !kept;
        gaussian_model_free(&m);
    }
    printf("    hits %d of %d, dropped by the cull %d\n", hits, trials, dropped);
    CHECK(hits > trials * 9 / 10);
    CHECK(dropped == 0);
}

/* The centre of the image of the 2DGS filter's circle (radius r) is the
 * image of a point within r^2 / z of the mean (z its view depth; the pole
 * of the plane's line at view depth 0): it lies within f |p| pole / (z (z -
 * pole)) pixels of the mean's image, the offset the cull allows. Random
 * tilted splats of both circle rules, from far below a pixel to as large
 * as their depth, means off axis; the bound is nearly reached (splats whose
 * plane holds the view axis), so a pole bound half as large fails. */
TEST(gaussian_2d_filter_centre_lies_within_the_pole_bound_of_the_mean)
{
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 100, 70, 50, 50, 100, 100};
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    unsigned st = 41;
    int checked = 0, beyond = 0;
    double closest = 0; /* the largest offset / bound */
    for (int trial = 0; trial < 40000; trial++) {
        gaussian_model m;
        model_of(&m, 1, GAUSSIAN_2D);
        m.formation = trial % 2 ? GAUSSIAN_FORMATION_2DGS : GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE;
        double depth = GAUSSIAN_NEAR + 3 * uniform(&st), c = trial % 2 ? 3.0 : 1.0;
        random_gaussian(&m, 0, &st, depth / c * pow(10.0, -4 + 4 * uniform(&st)));
        m.mean[0] = (float)((uniform(&st) - 0.5) * 1.6 * depth), m.mean[1] = (float)((uniform(&st) - 0.5) * 1.6 * depth);
        m.mean[2] = (float)depth;
        gaussian_ray r;
        gaussian_ray_init(&r, &v, &id, 50, 50, v3(0, 0, 0), v3(0, 0, 1));
        vec3 p = v3(m.mean[0], m.mean[1], m.mean[2]); /* the float mean the model holds */
        double radius = c * fmax(m.scale[0], m.scale[1]), pole = radius * radius / p.z, x, y;
        if (p.z > radius && gaussian_filter_centre_2d(&m, 0, &r, &x, &y)) {
            double dx = x - (100 * p.x / p.z + 50), dy = y - (70 * p.y / p.z + 50);
            double offset = sqrt(dx * dx + dy * dy), bound = 100 * v3_len(p) * pole / (p.z * (p.z - pole));
            checked++;
            beyond += offset > bound * (1 + 1e-6) + 1e-9;
            closest = fmax(closest, offset / bound);
        }
        gaussian_model_free(&m);
    }
    printf("    splats %d, beyond the bound %d, largest offset / bound %.3f\n", checked, beyond, closest);
    CHECK(checked > 30000);
    CHECK(beyond == 0);
    CHECK(closest > 0.5);
}

/* 400,000 hits of one key (a degenerate model: every Gaussian at one
 * depth) are composited in (object, Gaussian) order, in O(n log n): the
 * insertion sort this replaced took 17 s for 256k and about 40 s here;
 * an alarm ends the test after 20 s, 100 times what it takes. */
TEST(gaussian_equal_keys_sort_by_object_and_gaussian_in_n_log_n)
{
    enum { N = 400000 };
    gaussian_model m;
    model_of(&m, N, GAUSSIAN_2D);
    for (size_t i = 0; i < N; i++)
        m.sh[3 * i] = m.sh[3 * i + 1] = m.sh[3 * i + 2] = 0;
    rr_arena hits_arena; /* the heap's memory */
    rr_arena_init(&hits_arena, 0);
    gaussian_hits h;
    gaussian_hits_init(&h, &hits_arena);
    unsigned st = 5;
    for (size_t i = 0; i < N; i++) { /* prims in a scrambled order, two objects */
        unsigned prim = (unsigned)((i * 7919) % N), obj = (unsigned)(rand_r(&st) & 1);
        gaussian_hit g = {1.0f, 1.0f, 1e-6f, {0, 0, 1}, obj, prim};
        gaussian_hits_add(&h, &g);
    }
    const gaussian_model *models[2] = {&m, &m};
    gaussian_blend b;
    gaussian_blend_init(&b);
    alarm(20);
    gaussian_blend_hits(&b, &h, models, INFINITY);
    alarm(0);
    CHECK(b.composited == N && h.count == 0);
    rr_arena_free(&hits_arena);
    gaussian_model_free(&m);
}
