/* Epsilon-blending k-buffer and the two-level Embree traversal with the
 * exact per-time inverse ray transform. */
#include <stdlib.h>
#include <string.h>

#include "accel/accel.h"
#include "accel/accel_internal.h"
#include "motion/animation.h"
#include "formats/gaussian_ply.h"
#include "harness.h"
#include "scenexml/scene_xml.h"

static surface_hit hit_at(float t, unsigned prim)
{
    surface_hit h;
    memset(&h, 0, sizeof h);
    h.t = t;
    h.prim = prim;
    h.weight = 1;
    return h;
}

TEST(kbuffer_result_is_independent_of_insertion_order)
{
    enum { N = 40 };
    float ts[N];
    for (int i = 0; i < N; i++)
        ts[i] = 1.0f + 0.5f * (float)((i * 7919) % N) / N; /* distinct in [1, 1.5) */
    kbuffer ref, kb;
    static const int stride[6] = {1, 39, 3, 7, 11, 13}; /* coprime to N: permutations */
    for (int round = 0; round < 6; round++) {
        kbuffer_reset(&kb, 0.1f);
        for (int i = 0; i < N; i++) {
            int j = (i * stride[round]) % N;
            surface_hit h = hit_at(ts[j], (unsigned)j);
            kbuffer_insert(&kb, &h);
        }
        if (round == 0)
            ref = kb;
        CHECK(kb.count == ref.count);
        for (int k = 0; k < kb.count && k < ref.count; k++)
            CHECK(kb.hits[k].t == ref.hits[k].t && kb.hits[k].prim == ref.hits[k].prim);
    }
    /* exactly the hits within epsilon of the closest (t = 1.0): 1.0 .. 1.1 */
    int expect = 0;
    for (int i = 0; i < N; i++)
        expect += ts[i] <= 1.0f + 0.1f;
    CHECK(ref.count == expect);
    CHECK(ref.closest == 1.0f);
}

TEST(kbuffer_overflow_keeps_the_closest_hits)
{
    kbuffer kb;
    kbuffer_reset(&kb, 1.0f);
    for (int i = 99; i >= 0; i--) {
        surface_hit h = hit_at(2.0f + 0.001f * (float)i, (unsigned)i);
        kbuffer_insert(&kb, &h);
    }
    CHECK(kb.count == KBUFFER_MAX);
    CHECK(kbuffer_overflowed(&kb));
    for (int k = 0; k < kb.count; k++)
        CHECK(kb.hits[k].prim == (unsigned)k);
}

/* Whether more than KBUFFER_MAX hits lay within epsilon is a property of
 * the set of hits, not of the order a traversal offers them. KBUFFER_MAX
 * hits at 10 .. 10.063 and one at 1, epsilon 0.1: within epsilon of the closest (1) lies one hit, whichever comes first (the count
 * of drops once said 1 for far-then-near, 0 for near-then-far). And
 * KBUFFER_MAX + 1 hits at 10 .. 10.064, all within 0.1 of 10, overflow
 * whether they come nearest or farthest first. */
/* near_first: 1 the hit at 1 first, 0 last, -1 none */
static int far_hits_overflow(int near_first, int far_count, int descending)
{
    kbuffer kb;
    kbuffer_reset(&kb, 0.1f);
    surface_hit near = hit_at(1.0f, 1000);
    if (near_first == 1)
        kbuffer_insert(&kb, &near);
    for (int k = 0; k < far_count; k++) {
        int i = descending ? far_count - 1 - k : k;
        surface_hit h = hit_at(10.0f + 0.001f * (float)i, (unsigned)i);
        kbuffer_insert(&kb, &h);
    }
    if (near_first == 0)
        kbuffer_insert(&kb, &near);
    CHECK(kb.count == (far_count == KBUFFER_MAX ? 1 : KBUFFER_MAX));
    return kbuffer_overflowed(&kb);
}

TEST(kbuffer_overflow_does_not_depend_on_the_order_of_hits)
{
    kbuffer none;
    kbuffer_reset(&none, 0.1f);
    CHECK(!kbuffer_overflowed(&none)); /* no hit is no overflow */
    CHECK(!far_hits_overflow(1, KBUFFER_MAX, 0));
    CHECK(!far_hits_overflow(0, KBUFFER_MAX, 0));
    CHECK(far_hits_overflow(-1, KBUFFER_MAX + 1, 0));
    CHECK(far_hits_overflow(-1, KBUFFER_MAX + 1, 1));
}

/* An analytic sphere's Embree box holds the sphere: a 1 mm sphere at
 * x = 1000, where floats are 61 um apart, so a box rounded to the nearest
 * float may start up to 31 um inside it (it started 23 um inside). */
TEST(sphere_box_holds_a_small_sphere_far_out)
{
    scene s;
    rr_error e;
    const char *xml = "<scene><object><sphere center='1000 -1000 999.9997' radius='0.001'/></object></scene>";
    CHECK(scene_load_memory(xml, strlen(xml), "mem.xml", ".", &s, &e) == 0);
    struct RTCBounds box;
    struct RTCBoundsFunctionArguments args = {0};
    args.geometryUserPtr = &s.objects[0];
    args.bounds_o = &box;
    accel_sphere_bounds_cb(&args);
    double c[3] = {1000, -1000, 999.9997}, r = 0.001;
    float lo[3] = {box.lower_x, box.lower_y, box.lower_z}, hi[3] = {box.upper_x, box.upper_y, box.upper_z};
    for (int k = 0; k < 3; k++) {
        CHECK((double)lo[k] <= c[k] - r && (double)hi[k] >= c[k] + r);
        CHECK((double)hi[k] - (double)lo[k] < 2 * r + 4 * 6.2e-5); /* and stays tight: a step out each side */
    }
    scene_free(&s);
}

/* An in-memory scene and its BVHs, with static reuse. */
static int load_and_build(const char *xml, scene *s, accel **a)
{
    rr_error e;
    if (scene_load_memory(xml, strlen(xml), "mem.xml", ".", s, &e)) {
        printf("    %s\n", e.msg);
        return -1;
    }
    accel_settings set = {s->epsilon, s->kernel_sigma, 1};
    if (accel_build(s, &set, a, &e)) {
        printf("    %s\n", e.msg);
        scene_free(s);
        return -1;
    }
    return 0;
}

static int trace_scene(const char *xml, vec3 org, vec3 dir, double time, kbuffer *kb)
{
    scene s;
    accel *a;
    if (load_and_build(xml, &s, &a))
        return -1;
    accel_trace(a, org, dir, time, kb);
    accel_free(a);
    scene_free(&s);
    return 0;
}

#define TWO_SPLATS(eps) "<scene><render epsilon='" eps "'/><object><pointModel>" \
    "<splat center='0 0 -5' normal='0 0 1' radius='1' color='1 0 0'/>"            \
    "<splat center='0.2 0 -5.05' normal='0 0 -1' radius='1' color='0 0 1'/>"      \
    "</pointModel></object></scene>"

TEST(trace_collects_hits_within_epsilon_only)
{
    kbuffer kb;
    CHECK(trace_scene(TWO_SPLATS("0.1"), v3(0, 0, 0), v3(0, 0, -1), 0, &kb) == 0);
    CHECK(kb.count == 2);
    CHECK_NEAR(kb.hits[0].t, 5.0, 1e-5);
    CHECK_NEAR(kb.hits[1].t, 5.05, 1e-5);
    /* the back-facing splat's normal is flipped towards the eye */
    CHECK_NEAR(kb.hits[1].normal[2], 1.0, 1e-6);
    /* r2 of the second hit: (0.2)^2 -> weight exp(-0.04 / 0.5) */
    CHECK_NEAR(kb.hits[1].weight, exp(-0.04 / 0.5), 1e-5);
    CHECK(trace_scene(TWO_SPLATS("0.01"), v3(0, 0, 0), v3(0, 0, -1), 0, &kb) == 0);
    CHECK(kb.count == 1 && kb.hits[0].color[0] == 1.0f);
}

#define MOVING(anim) "<scene><shutter open='0' close='10'/><object><pointModel>"   \
    "<splat center='2 0 -5' normal='0 0 1' radius='0.5'/></pointModel>"             \
    "<animation>" anim "</animation></object></scene>"

TEST(trace_applies_the_object_transform_at_the_ray_time)
{
    kbuffer kb;
    const char *lin = MOVING("<linear velocity='1 0 0'/>");
    CHECK(trace_scene(lin, v3(2, 0, 0), v3(0, 0, -1), 0, &kb) == 0 && kb.count == 1);
    CHECK(trace_scene(lin, v3(2, 0, 0), v3(0, 0, -1), 5, &kb) == 0 && kb.count == 0);
    CHECK(trace_scene(lin, v3(7, 0, 0), v3(0, 0, -1), 5, &kb) == 0 && kb.count == 1);
    /* 180 degrees about +y through (0,0,-5) at t = 1 takes (2,0,-5) to (-2,0,-5) */
    const char *rot = MOVING("<rotation axis='0 1 0' center='0 0 -5' degrees_per_unit_time='180'/>");
    CHECK(trace_scene(rot, v3(-2, 0, 0), v3(0, 0, -1), 1, &kb) == 0 && kb.count == 1);
    CHECK_NEAR(kb.hits[0].t, 5.0, 1e-4);
    CHECK(trace_scene(rot, v3(2, 0, 0), v3(0, 0, -1), 1, &kb) == 0 && kb.count == 0);
}

TEST(trace_hits_analytic_sphere_front_surface)
{
    kbuffer kb;
    const char *xml = "<scene><object><sphere center='0 0 -10' radius='2' color='0 1 0'/></object></scene>";
    CHECK(trace_scene(xml, v3(0, 0, 0), v3(0, 0, -1), 0, &kb) == 0);
    CHECK(kb.count == 1);
    CHECK_NEAR(kb.hits[0].t, 8.0, 1e-5);
    CHECK_NEAR(kb.hits[0].normal[2], 1.0, 1e-6);
    CHECK(trace_scene(xml, v3(0, 2.01, 0), v3(0, 0, -1), 0, &kb) == 0 && kb.count == 0);
}

TEST(rotating_splat_is_hit_up_to_its_rim)
{
    kbuffer kb;
    /* 90 degrees per unit time about +y through (0,0,-5): at t = 0.5 the
     * splat's center is at (2 cos45, 0, -5 - 2 sin45) and its u axis is
     * (cos45, 0, -sin45); a ray down -z at x = cx + r cos45 meets the
     * plane at c + r u, i.e. at kernel radius r. */
    const char *rot = MOVING("<rotation axis='0 1 0' center='0 0 -5' degrees_per_unit_time='90'/>");
    double c45 = sqrt(0.5), cx = 2 * c45;
    CHECK(trace_scene(rot, v3(cx + 0.49 * c45, 0, 0), v3(0, 0, -1), 0.5, &kb) == 0 && kb.count == 1);
    CHECK_NEAR(kb.hits[0].t, 5 + 2 * c45 + 0.49 * c45, 1e-4);
    CHECK(trace_scene(rot, v3(cx + 0.51 * c45, 0, 0), v3(0, 0, -1), 0.5, &kb) == 0 && kb.count == 0);
}

/* Brute force, independent of the BVHs and bounds: does the world ray
 * meet a splat of the object at `time`? Sets *near_rim when a splat is met
 * or missed too close to its rim for float rounding to decide. */
static int brute_force_hit(const scene_object *o, vec3 org, vec3 dir, double time, int *near_rim)
{
    xform xf = animation_at(&o->anim, time);
    vec3 lo = xform_inverse_point(&xf, org), ld = xform_inverse_vector(&xf, dir);
    const float fo[3] = {(float)lo.x, (float)lo.y, (float)lo.z}, fd[3] = {(float)ld.x, (float)ld.y, (float)ld.z};
    int hit = 0;
    for (size_t i = 0; i < o->model.count; i++) {
        float t, r2;
        const splat_geom *g = &o->model.geom[i];
        float denom = fd[0] * g->plane_normal[0] + fd[1] * g->plane_normal[1] + fd[2] * g->plane_normal[2];
        if (splat_intersect(g, fo, fd, 0, INFINITY, &t, &r2))
            hit = 1, *near_rim |= r2 > 0.999f;
        else if (denom != 0) { /* how far outside the rim was it? */
            float loose = 0;
            splat_geom wide = *g;
            for (int k = 0; k < 3; k++)
                wide.dual_u[k] *= 0.999f, wide.dual_v[k] *= 0.999f;
            *near_rim |= splat_intersect(&wide, fo, fd, 0, INFINITY, &t, &loose);
        }
    }
    return hit;
}

/* The renderer skips the moving objects for rays that miss their swept
 * bounds (box and sphere, also used inside the traversal): checked against
 * brute-force hits for rays around the rim of a spinning, drifting object. */
/* Six splats on a circle of radius 2 around (0, 0, -5), facing the eye. */
#define RING "<pointModel>"                                                 \
    "<splat center='2 0 -5' normal='0 0 1' radius='0.5'/>"                   \
    "<splat center='1 1.7320508 -5' normal='0 0 1' radius='0.5'/>"           \
    "<splat center='-1 1.7320508 -5' normal='0 0 1' radius='0.5'/>"          \
    "<splat center='-2 0 -5' normal='0 0 1' radius='0.5'/>"                  \
    "<splat center='-1 -1.7320508 -5' normal='0 0 1' radius='0.5'/>"         \
    "<splat center='1 -1.7320508 -5' normal='0 0 1' radius='0.5'/></pointModel>"

/* Nearly parallel rays from far away (so the bounds tests are tight) over
 * the ring's rim at 40 times: every brute-force hit must be found. */
static void check_no_missed_hits(const char *xml, double rim)
{
    scene s;
    accel *a;
    CHECK(load_and_build(xml, &s, &a) == 0);
    vec3 eye = v3(0, 0, 45);
    int hits = 0, ruled_out = 0, missed = 0, rim_hits = 0;
    for (int i = 0; i < 120; i++)
        for (int j = 0; j < 120; j++) {
            vec3 dir = v3_normalize(v3(-0.09 + 0.18 * i / 119.0, -0.09 + 0.18 * j / 119.0, -1));
            accel_ray ray;
            accel_ray_begin(a, eye, dir, &ray);
            int may = ray.may_hit_moving;
            ruled_out += !may;
            for (int k = 0; k < 40; k++) {
                kbuffer kb;
                int near_rim = 0;
                int truth = brute_force_hit(&s.objects[0], eye, dir, (k + 0.5) / 40, &near_rim);
                accel_trace(a, eye, dir, (k + 0.5) / 40, &kb);
                hits += truth;
                missed += truth && !near_rim && (kb.count == 0 || !may);
                rim_hits += truth && hypot(dir.x, dir.y) * 50 / fabs(dir.z) > rim;
            }
        }
    printf("    hits %d rim %d ruled out %d missed %d\n", hits, rim_hits, ruled_out, missed);
    CHECK(missed == 0);
    CHECK(hits > 1000 && rim_hits > 20); /* rays do meet the object, also near its outer rim */
    CHECK(ruled_out > 5000);              /* and the test does skip most rays that cannot */
    accel_free(a);
    scene_free(&s);
}

TEST(swept_bounds_never_rule_out_a_ray_that_hits)
{
    /* the ring spinning in the image plane and drifting: the swept sphere
     * is nearly tight here, so a too-small one shows */
    check_no_missed_hits("<scene><shutter open='0' close='1'/><object>" RING
                         "<animation><rotation axis='0 0 1' center='0 0 -5' degrees_per_unit_time='50'/>"
                         "<linear velocity='0.2 0 0'/></animation></object></scene>",
                         2.4);
}

TEST(keyed_swept_bounds_never_rule_out_a_ray_that_hits)
{
    /* non-linear motion: a spline turn that overshoots, a growing scale and a
     * step in x part-way through the shutter */
    check_no_missed_hits("<scene><shutter open='0' close='1'/><object>" RING
                         "<animation><keyframes interpolation='spline' pivot='0 0 -5'>"
                         "<key time='0' rotate='0 0 0' scale='1 1 1'/>"
                         "<key time='0.4' rotate='0 0 40' scale='1.15 1.15 1'/>"
                         "<key time='1' rotate='0 0 20' scale='1.1 1.1 1'/>"
                         "<key time='0' translate='0 0 0' interpolation='step'/>"
                         "<key time='0.6' translate='0.15 0 0'/>"
                         "</keyframes></animation></object></scene>",
                         2.6);
}

/* A slowly turning sphere (its 16 time rays stay close: one packet), a fast
 * spinning torus (rays far apart: traced one by one), a drifting analytic
 * sphere and a static wall, all within epsilon of each other in places. */
static const char *const PACKET_SCENE =
    "<scene><shutter open='0' close='1'/><render epsilon='0.3'/>"
    "<object><pointModel generate='plane' count='4000' radius='3'/></object>"
    "<object position='-0.6 0 1.5'><pointModel generate='sphere' count='20000' radius='0.8'/>"
    "<animation><rotation axis='0 1 0' center='-0.6 0 1.5' degrees_per_unit_time='2'/></animation></object>"
    "<object position='0.7 0 1.5'><pointModel generate='torus' count='20000' radius='0.6' minor_radius='0.25'/>"
    "<animation><rotation axis='1 1 0' center='0.7 0 1.5' degrees_per_unit_time='200'/>"
    "<linear velocity='0 0.3 0'/></animation></object>"
    "<object position='0 0.5 1.2'><sphere radius='0.3'/>"
    "<animation><linear velocity='0.4 -0.2 0'/></animation></object></scene>";

static int same_kbuffer(const kbuffer *a, const kbuffer *b)
{
    return a->count == b->count && kbuffer_overflowed(a) == kbuffer_overflowed(b) && a->closest == b->closest &&
           !memcmp(a->hits, b->hits, (size_t)a->count * sizeof *a->hits);
}

/* The packet path (all the times of one world ray together) is an
 * optimisation only: every time's hits must equal, bit for bit, those of
 * tracing that time alone through the top-level BVH. */
TEST(packets_of_times_give_the_hits_of_single_rays)
{
    scene s;
    accel *a;
    CHECK(load_and_build(PACKET_SCENE, &s, &a) == 0);
    vec3 eye = v3(0, 0, 6);
    int rays = 0, differ = 0, moving_hits = 0;
    for (int i = 0; i < 60; i++)
        for (int j = 0; j < 30; j++) {
            vec3 dir = v3_normalize(v3(-0.3 + 0.6 * i / 59.0, -0.15 + 0.3 * j / 29.0, -1));
            double times[ACCEL_PACKET];
            for (int k = 0; k < ACCEL_PACKET; k++)
                times[k] = (k + 0.5 * ((i + j + k) % 3)) / ACCEL_PACKET; /* increasing, as the sampler lists them */
            kbuffer packet[ACCEL_PACKET], single;
            const kbuffer *result[ACCEL_PACKET];
            accel_ray ray;
            accel_ray_begin(a, eye, dir, &ray);
            accel_ray_trace_times(a, &ray, times, ACCEL_PACKET, packet, result);
            for (int k = 0; k < ACCEL_PACKET; k++) {
                accel_trace(a, eye, dir, times[k], &single);
                int moving = result[k] != &ray.static_hits;
                differ += !same_kbuffer(&single, result[k]) || (moving && result[k] != &packet[k]);
                moving_hits += moving;
                rays++;
            }
        }
    printf("    rays %d meeting moving objects %d differing %d\n", rays, moving_hits, differ);
    CHECK(differ == 0);
    CHECK(moving_hits > rays / 4);
    accel_free(a);
    scene_free(&s);
}
