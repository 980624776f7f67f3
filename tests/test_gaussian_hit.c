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
#include "gaussian_hit_util.h"
#include "harness.h"

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
    hit_test_model(&m, 64, GAUSSIAN_2D);
    unsigned st = 7;
    for (size_t i = 0; i < 64; i++)
        random_splat(&m, i, &st, 0.1);
    const gaussian_model *models[2] = {&m, &m};
    gaussian_hit hits[64];
    size_t fwd[64], shuffled[64], keyed[64];
    for (size_t k = 0; k < 64; k++) { /* ties in key, broken by object then Gaussian */
        hits[k] = (gaussian_hit){(float)(k / 4), 1.0f, (float)(0.02 + 0.1 * rand_uniform(&st)), {0, 0, 1},
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
    hit_test_model(&m, N, GAUSSIAN_2D);
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
    hit_test_model(&m, 3, GAUSSIAN_2D);
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

/* Random splats of every size from far below a pixel to many pixels, seen
 * from a camera at the origin looking down +z with focal length 100
 * pixels, through random pixels near their centres' images. */
TEST(gaussian_2d_hits_lie_in_their_bounds_within_the_lead_of_their_distance)
{
    gaussian_model m;
    hit_test_model(&m, 1, GAUSSIAN_2D);
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 100, 100, 50, 50, 100, 100};
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    unsigned st = 11;
    int hits = 0, filtered = 0, outside = 0, late = 0;
    for (int trial = 0; trial < 20000; trial++) {
        random_splat(&m, 0, &st, pow(10.0, -4 + 3.5 * rand_uniform(&st)));
        m.mean[2] += 2.0f; /* in front: depth 1.5 to 2.5 */
        double depth = m.mean[2], cx = 100 * m.mean[0] / depth + 50, cy = 100 * m.mean[1] / depth + 50;
        double x = cx + 8 * (rand_uniform(&st) - 0.5), y = cy + 8 * (rand_uniform(&st) - 0.5);
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
    hit_test_model(&m, 1, GAUSSIAN_3D);
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 100, 80, 50, 50, 100, 100};
    xform id = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 0, 0}, 0};
    const gaussian_formation kinds[] = {GAUSSIAN_FORMATION_3DGS, GAUSSIAN_FORMATION_3DGS_ANTIALIASED,
                                        GAUSSIAN_FORMATION_GSPLAT, GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED};
    unsigned st = 23;
    int hits = 0, beyond_clamp = 0, outside = 0;
    for (int trial = 0; trial < 40000; trial++) {
        m.formation = kinds[trial % 4];
        random_splat(&m, 0, &st, pow(10.0, -4 + 3.5 * rand_uniform(&st)));
        double depth = 0.5 + 3 * rand_uniform(&st);
        m.mean[0] = (float)((rand_uniform(&st) - 0.5) * 3.2 * depth), m.mean[1] = (float)((rand_uniform(&st) - 0.5) * 2 * depth);
        m.mean[2] = (float)depth;
        double cx = 100 * m.mean[0] / depth + 50, cy = 80 * m.mean[1] / depth + 50;
        double x = cx + 40 * (rand_uniform(&st) - 0.5), y = cy + 40 * (rand_uniform(&st) - 0.5);
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
        outside += !box_holds_point(box, v3_scale(dir, h.t));
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
    double z = 0.3 + 3.7 * rand_uniform(st), rx = 5 * (rand_uniform(st) - 0.5), ry = 5 * (rand_uniform(st) - 0.5);
    double tx = clamped_ratio(gsplat, rx, v->width, v->fx, v->cx), ty = clamped_ratio(gsplat, ry, v->height, v->fy, v->cy);
    /* J = diag(fx, fy) / z [[1, 0, -tx], [0, 1, -ty]] stretches (tx, ty, -(tx^2 + ty^2)) the most */
    vec3 d = v3_normalize(v3(tx, ty, -(tx * tx + ty * ty)));
    if (!(tx * tx + ty * ty > 1e-6))
        d = v3(1, 0, 0);
    double q[4] = {1 + d.x, 0, -d.z, d.y}, len = sqrt(q[0] * q[0] + q[2] * q[2] + q[3] * q[3]); /* x axis -> d */
    double px = (1 + 14 * rand_uniform(st)) * z / v->fx; /* major sigma 1 to 15 pixels at the axis */
    for (int k = 0; k < 4; k++)
        m->rotation[k] = (float)(q[k] / len);
    m->scale[0] = (float)px, m->scale[1] = m->scale[2] = (float)(px / 100);
    m->mean[0] = (float)(rx * z), m->mean[1] = (float)(ry * z), m->mean[2] = (float)z;
    m->opacity[0] = 1.0f;
    double ax = v->fx * (d.x - tx * d.z) / z * px, ay = v->fy * (d.y - ty * d.z) / z * px; /* the major sigma */
    double u = 1.15 * rand_uniform(st) * 3.33;
    *x = v->fx * rx + v->cx + u * ax + (rand_uniform(st) - 0.5), *y = v->fy * ry + v->cy + u * ay + (rand_uniform(st) - 0.5);
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
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 50, 50 + 20 * rand_uniform(st),
                     100 * (0.05 + 0.9 * rand_uniform(st)), 80 * (0.05 + 0.9 * rand_uniform(st)), 100, 80};
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
        out.outside = !box_holds_point(gaussian_view_bounds(one, 0, &vb), v3_scale(dir, h.t));
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
        hit_test_model(&one, 1, GAUSSIAN_3D);
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
    double z = 0.3 + 3.7 * rand_uniform(st), rx = 3 * (rand_uniform(st) - 0.5), ry = 2.4 * (rand_uniform(st) - 0.5);
    vec3 d = v3_normalize(v3(a * ux, b * uy, -t * (a * ux + b * uy))); /* J^T u */
    double q4[4] = {1 + d.x, 0, -d.z, d.y}, len = sqrt(q4[0] * q4[0] + q4[2] * q4[2] + q4[3] * q4[3]);
    double s = (0.3 + 5 * rand_uniform(st)) * z / v->fx;
    for (int k = 0; k < 4; k++)
        m->rotation[k] = (float)(q4[k] / len);
    m->scale[0] = (float)s, m->scale[1] = m->scale[2] = (float)(s / 100);
    m->mean[0] = (float)(rx * z), m->mean[1] = (float)(ry * z), m->mean[2] = (float)z;
    m->opacity[0] = 1.0f;
    double ax = a * (d.x - t * d.z) / z * s, ay = b * (d.y - t * d.z) / z * s; /* the major sigma, pixels */
    double u = 1.15 * rand_uniform(st) * 3.33;
    *x = v->fx * rx + v->cx + u * ax + (rand_uniform(st) - 0.5), *y = v->fy * ry + v->cy + u * ay + (rand_uniform(st) - 0.5);
}

TEST(gaussian_3d_fov_minus_one_culls_and_bounds_hold_the_pinned_footprint)
{
    camera_view v = {v3(0, 0, 0), {v3(1, 0, 0), v3(0, 1, 0), v3(0, 0, 1)}, 30, 30, 50, 40, 100, 80};
    gaussian_model one;
    hit_test_model(&one, 1, GAUSSIAN_3D);
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
        hit_test_model(&one, 1, GAUSSIAN_3D), hit_test_model(&batch, N, GAUSSIAN_3D);
        one.formation = batch.formation = raster_formations[trial % RASTER_FORMATIONS];
        double x = 100 * rand_uniform(&st), y = 80 * rand_uniform(&st);
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
