/* gaussian_cull.c and the hits' keys: the culls never drop a Gaussian the
 * whole evaluation would hit; in vector lanes they keep what the scalar
 * cull keeps, bit for bit; hits after the lanes' culls are the hits one at
 * a time; a key floor lies below every hit's key; boxes flattened along the
 * view axis hold every hit; equal keys sort by object and Gaussian. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "motion/animation.h"
#include "gaussians/gaussian_hit.h"
#include "core/lanes.h"
#include "gaussian_hit_util.h"
#include "harness.h"

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
        hit_test_model(&m, 1, f <= GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? GAUSSIAN_2D : GAUSSIAN_3D);
        m.formation = f;
        double depth = GAUSSIAN_NEAR * (1 + 1e-3) + 2.8 * pow(rand_uniform(&st), 2);
        random_splat(&m, 0, &st, depth * pow(10.0, -3.5 + 3 * rand_uniform(&st)));
        m.mean[0] = (float)((rand_uniform(&st) - 0.5) * depth), m.mean[1] = (float)((rand_uniform(&st) - 0.5) * depth);
        m.mean[2] = (float)depth;
        double x = 100 * m.mean[0] / depth + 50 + 40 * (rand_uniform(&st) - 0.5);
        double y = 100 * m.mean[1] / depth + 50 + 40 * (rand_uniform(&st) - 0.5);
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
    vec3 axis = v3_normalize(v3(rand_uniform(st) - 0.5, rand_uniform(st) - 0.5, rand_uniform(st) - 0.5));
    double m[3][3];
    rotation_matrix(axis, angle_max * rand_uniform(st), m);
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
    hit_test_model(m, N, m->formation <= GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? GAUSSIAN_2D : GAUSSIAN_3D);
    m->formation = splatting_formations[trial % SPLATTING_FORMATIONS];
    double x = 100 * rand_uniform(st), y = 100 * rand_uniform(st);
    vec3 dir = v3_normalize(v3((x - 50) / 100, (y - 50) / 100, 1));
    for (size_t i = 0; i < N; i++) {
        double depth = -0.5 + 4.5 * rand_uniform(st) * rand_uniform(st) + (i % 7 == 0 ? GAUSSIAN_NEAR + 0.5 : 0);
        random_splat(m, i, st, fabs(depth) * pow(10.0, -4 + 3 * rand_uniform(st)));
        double reach = 3.4 * fmax(m->scale[3 * i], m->scale[3 * i + 1]) + 2.4 * fabs(depth) / 100; /* the cull's scale */
        vec3 at = v3_scale(dir, depth / dir.z);
        for (int k = 0; k < 3; k++)
            m->mean[3 * i + k] = (float)((k == 0 ? at.x : k == 1 ? at.y : at.z) + 1.3 * reach * (2 * rand_uniform(st) - 1));
    }
    for (size_t i = 0; i < N; i += 5) { /* exactly at the near plane of 2DGS and Inria (0.2): 0.5 - 0.3 */
        m->mean[3 * i] = (float)(0.5 * dir.x / dir.z), m->mean[3 * i + 1] = (float)(0.5 * dir.y / dir.z);
        m->mean[3 * i + 2] = 0.5f;
    }
    xform back = id;
    back.t = v3(0, 0, -0.3); /* the others 0.3 nearer */
    if (trial % 2) { /* a turned, unevenly scaled object: sums of unlike terms (their order shows) */
        double R[3][3], sc[3] = {0.7 + rand_uniform(st), 0.7 + rand_uniform(st), 0.7 + rand_uniform(st)};
        rotation_matrix(v3_normalize(v3(rand_uniform(st) - 0.5, rand_uniform(st) - 0.5, rand_uniform(st) - 0.5)), 3 * rand_uniform(st), R);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                back.r[a][b] = R[a][b] * sc[b], back.ri[a][b] = R[b][a] / sc[a];
        back.scaled = 1, back.t = v3(0.01 * rand_uniform(st), 0.01 * rand_uniform(st), -0.3);
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
        hit_test_model(&m, 1, f <= GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? GAUSSIAN_2D : GAUSSIAN_3D);
        m.formation = f;
        double R[3][3];
        rotation_matrix(v3_normalize(v3(rand_uniform(&st) - 0.5, rand_uniform(&st) - 0.5, rand_uniform(&st) - 0.5)), M_PI * rand_uniform(&st), R);
        double sc[3], depth = GAUSSIAN_NEAR * 1.5 + 2.8 * rand_uniform(&st);
        for (int k = 0; k < 3; k++)
            sc[k] = trial % 2 ? 0.5 + 1.5 * rand_uniform(&st) : 1.25;
        xform xf = {.scaled = trial % 2};
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                xf.r[i][j] = R[i][j] * sc[j], xf.ri[i][j] = R[j][i] / sc[i];
        random_splat(&m, 0, &st, depth * pow(10.0, -3.5 + 3 * rand_uniform(&st)));
        vec3 mean = v3((rand_uniform(&st) - 0.5) * depth, (rand_uniform(&st) - 0.5) * depth, depth); /* camera = world */
        xf.t = v3_sub(mean, xform_vector(&xf, v3(m.mean[0], m.mean[1], m.mean[2])));
        double reach = 3 + 400 * fmax(m.scale[0], fmax(m.scale[1], m.scale[2])) * 2 / depth;
        double x = 100 * mean.x / depth + 50 + 2 * reach * (rand_uniform(&st) - 0.5);
        double y = 100 * mean.y / depth + 50 + 2 * reach * (rand_uniform(&st) - 0.5);
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
        hit_test_model(&m, 1, f <= GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE ? GAUSSIAN_2D : GAUSSIAN_3D);
        m.formation = f;
        vec3 ref[3], turn[3], cam[3];
        double cone = trial % 2 ? 0.3 : 0.0;
        random_rotation(&st, M_PI, ref);
        random_rotation(&st, cone, turn);
        for (int k = 0; k < 3; k++) /* the camera's axes: the reference's, turned */
            cam[k] = rotate(turn, ref[k]);
        camera_view v = {v3(0, 0, 0), {cam[0], cam[1], cam[2]}, 100, 80, 50, 50, 100, 100};
        double depth = 0.3 + 3 * rand_uniform(&st);
        random_splat(&m, 0, &st, depth * pow(10.0, -4 + 3 * rand_uniform(&st)));
        vec3 mean = v3_scale(v3_add(cam[2], v3_add(v3_scale(cam[0], 0.8 * (rand_uniform(&st) - 0.5)),
                                                       v3_scale(cam[1], 0.6 * (rand_uniform(&st) - 0.5)))), depth);
        m.mean[0] = (float)mean.x, m.mean[1] = (float)mean.y, m.mean[2] = (float)mean.z;
        vec3 p = v3(v3_dot(cam[0], mean), v3_dot(cam[1], mean), v3_dot(cam[2], mean));
        double reach = 3 + 350 * fmax(m.scale[0], fmax(m.scale[1], m.scale[2])) / p.z; /* pixels: the footprint's order */
        double x = 100 * p.x / p.z + 50 + 2 * reach * (rand_uniform(&st) - 0.5), y = 80 * p.y / p.z + 50 + 2 * reach * (rand_uniform(&st) - 0.5);
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
        hit_test_model(&m, 1, GAUSSIAN_2D);
        m.formation = trial % 2 ? GAUSSIAN_FORMATION_2DGS : GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE;
        double depth = 0.5 + 2.5 * rand_uniform(&st);
        random_splat(&m, 0, &st, 1e-5 * depth);
        m.opacity[0] = 0.99999994f; /* the largest float below 1 */
        m.mean[0] = (float)((rand_uniform(&st) - 0.5) * depth / 1.7), m.mean[1] = (float)((rand_uniform(&st) - 0.5) * depth / 0.6);
        m.mean[2] = (float)(depth / 1.1);
        gaussian_ray r;
        double cx, cy, angle = 2 * M_PI * rand_uniform(&st);
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
        hit_test_model(&m, 1, GAUSSIAN_2D);
        m.formation = trial % 2 ? GAUSSIAN_FORMATION_2DGS : GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE;
        double depth = GAUSSIAN_NEAR + 3 * rand_uniform(&st), c = trial % 2 ? 3.0 : 1.0;
        random_splat(&m, 0, &st, depth / c * pow(10.0, -4 + 4 * rand_uniform(&st)));
        m.mean[0] = (float)((rand_uniform(&st) - 0.5) * 1.6 * depth), m.mean[1] = (float)((rand_uniform(&st) - 0.5) * 1.6 * depth);
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
    hit_test_model(&m, N, GAUSSIAN_2D);
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
