/* Exact time integration (exact.h) against closed forms worked by hand,
 * against brute force for candidate gathering, and against the sampled
 * path's own per-time colors (accel_trace + shade_hits, code exact.c does
 * not share) averaged over many random times, within k = 5 standard
 * errors. */
#include <stdlib.h>
#include <string.h>

#include "render/exact.h"
#include "render/sampler.h"
#include "scenexml/scene_xml.h"
#include "scene/shade.h"
#include "harness.h"

typedef struct {
    scene s;
    accel *a;
    exact_plan *p;
    exact_scratch *scr;
} exact_fixture;

static int fixture_open(const char *xml, double box_scale, exact_fixture *f)
{
    rr_error e;
    if (scene_load_memory(xml, strlen(xml), "mem.xml", RR_SOURCE_DIR, &f->s, &e)) {
        printf("    %s\n", e.msg);
        return -1;
    }
    accel_settings set = {f->s.epsilon, f->s.kernel_sigma, 1};
    if (accel_build(&f->s, &set, &f->a, &e) || exact_plan_new(f->a, box_scale, NULL, &f->p, &e)) {
        printf("    %s\n", e.msg);
        return -1;
    }
    f->scr = exact_scratch_new(NULL);
    return f->scr ? 0 : -1;
}

static void fixture_close(exact_fixture *f)
{
    exact_scratch_free(f->scr);
    exact_plan_free(f->p);
    accel_free(f->a);
    scene_free(&f->s);
}

/* The image center: the default camera at (0 0 5) looks straight down -z. */
static int center_sample(const char *xml, double rgba[4], exact_stats *st)
{
    exact_fixture f;
    if (fixture_open(xml, 1.0, &f))
        return -1;
    int rc = exact_sample(f.p, f.scr, f.s.cam.width * 0.5, f.s.cam.height * 0.5, rgba, st);
    fixture_close(&f);
    return rc;
}

/* A disc of radius 0.3 crossing the ray at distance 0.1 from its center,
 * at speed 2: covered for chord / speed = 2 sqrt(0.3^2 - 0.1^2) / 2 of the
 * unit shutter. Unlit white on black: coverage and color equal that time. */
TEST(translating_disc_covers_chord_over_speed)
{
    const char *xml = "<scene><shutter open='0' close='1'/><object><pointModel>"
                      "<splat center='-1 0.1 0' normal='0 0 1' radius='0.3' color='1 1 1'/></pointModel>"
                      "<material shading='unlit'/><animation><linear velocity='2 0 0'/></animation>"
                      "</object></scene>";
    double rgba[4];
    exact_stats st = {0};
    CHECK(center_sample(xml, rgba, &st) == 0);
    /* the splat is stored in floats: its radius is 0.3 to about 3e-8 */
    CHECK_NEAR(rgba[3], sqrt(0.08), 3e-8);
    printf("    unresolved %.3g\n", st.unresolved);
    CHECK(st.unresolved <= 1e-7);
}

/* A disc of radius rho at distance R0 from the z axis, turning about it at
 * 90 degrees per unit time over [-0.5, 0.5], passes the ray through
 * (R0, 0): covered while 2 R0 sin(|theta| / 2) <= rho, an angle of
 * 4 asin(rho / (2 R0)), so a time of that over (pi / 2). The disc's
 * center is at angle 0 at t = 0, on the ray. */
TEST(rotating_disc_covers_closed_form_angle)
{
    const char *xml = "<scene><shutter open='-0.5' close='0.5'/><object position='0 0 0'><pointModel>"
                       "<splat center='0 0 0' normal='0 0 1' radius='0.25' color='1 1 1'/></pointModel>"
                       "<material shading='unlit'/><animation>"
                       "<rotation axis='0 0 1' center='-0.8 0 0' degrees_per_unit_time='90'/>"
                       "</animation></object></scene>";
    double rgba[4];
    CHECK(center_sample(xml, rgba, NULL) == 0);
    double expected = 4.0 * asin(0.25 / (2.0 * 0.8)) / (M_PI / 2.0);
    CHECK_NEAR(rgba[3], expected, 2e-9);
}

/* Red disc A still at z = 0 (depth 5); green disc B moving along z at
 * z = -0.25 + t, the ray 0.5 of its radius off its center (kernel weight
 * w = exp(-0.5^2 / (2 * 0.5^2)) = exp(-0.5)), epsilon 0.05. A alone while
 * B is more than epsilon behind (t < 0.2), both within epsilon for 0.1,
 * B alone after: red = 0.2 + 0.1 / (1 + w), green = 0.7 + 0.1 w / (1 + w). */
TEST(epsilon_window_events_by_hand)
{
    const char *xml = "<scene><shutter open='0' close='1'/><render epsilon='0.05' kernel_sigma='0.5'/>"
                      "<object name='a'><pointModel><splat center='0 0 0' normal='0 0 1' radius='2' color='1 0 0'/>"
                      "</pointModel><material shading='unlit'/></object>"
                      "<object name='b' position='0 0 -0.25'><pointModel>"
                      "<splat center='0.5 0 0' normal='0 0 1' radius='1' color='0 1 0'/></pointModel>"
                      "<material shading='unlit'/><animation><linear velocity='0 0 1'/></animation></object>"
                      "</scene>";
    double rgba[4], w = exp(-0.5);
    CHECK(center_sample(xml, rgba, NULL) == 0);
    CHECK_NEAR(rgba[0], 0.2 + 0.1 / (1 + w), 1e-7);
    CHECK_NEAR(rgba[1], 0.7 + 0.1 * w / (1 + w), 1e-7);
    CHECK_NEAR(rgba[3], 1.0, 1e-12);
}

/* Does the ray at time t hit splat i of object o? (double math, the same
 * rule as splat_intersect: in front, inside the ellipse) */
static int brute_hit(const scene *sc, int obj, size_t i, vec3 org, vec3 dir, double t)
{
    const scene_object *o = &sc->objects[obj];
    xform x = animation_at(&o->anim, t);
    vec3 so = xform_inverse_point(&x, org), sd = xform_inverse_vector(&x, dir);
    const splat_geom *g = &o->model.geom[i];
    vec3 n = v3(g->plane_normal[0], g->plane_normal[1], g->plane_normal[2]);
    vec3 co = v3_sub(v3(g->center[0], g->center[1], g->center[2]), so);
    double den = v3_dot(sd, n);
    if (den == 0)
        return 0;
    double s = v3_dot(co, n) / den;
    vec3 q = v3_sub(v3_scale(sd, s), co);
    double a = g->dual_u[0] * q.x + g->dual_u[1] * q.y + g->dual_u[2] * q.z;
    double b = g->dual_v[0] * q.x + g->dual_v[1] * q.y + g->dual_v[2] * q.z;
    return s >= 0 && a * a + b * b <= 1;
}

static int contains(const exact_scratch *scr, int n, unsigned obj, unsigned prim)
{
    for (int k = 0; k < n; k++) {
        unsigned o, p;
        exact_candidate(scr, k, &o, &p);
        if (o == obj && p == prim)
            return 1;
    }
    return 0;
}

/* Splats some time of the shutter's 2000 meets that the gathering left out. */
static int missed_candidates(const char *xml, double box_scale, int rays, double spread)
{
    exact_fixture f;
    if (fixture_open(xml, box_scale, &f))
        return -1;
    int missed = 0;
    for (int r = 0; r < rays; r++) {
        double x = f.s.cam.width * (0.5 + spread * (sampler_uniform(7, (uint64_t)r, 0, 0) - 0.5));
        double y = f.s.cam.height * (0.5 + spread * (sampler_uniform(7, (uint64_t)r, 0, 1) - 0.5));
        int n = exact_candidates(f.p, f.scr, x, y);
        vec3 org = f.s.cam.position, dir = camera_ray_direction(&f.s.cam, x, y);
        for (size_t i = 0; i < f.s.objects[0].model.count; i++) {
            int hit = 0;
            for (int k = 0; k < 2000 && !hit; k++)
                hit = brute_hit(&f.s, 0, i, org, dir, (k + 0.5) / 2000.0);
            missed += hit && !contains(f.scr, n, 0, (unsigned)i);
        }
    }
    fixture_close(&f);
    return missed;
}

/* A fast, tumbling and drifting sphere of small splats: brute force over
 * every splat and 2000 times finds nothing the gathering missed. */
TEST(candidate_gathering_is_conservative)
{
    const char *xml = "<scene><camera position='0 0 4' lookat='0 0 0' width='64' height='64'/>"
                      "<shutter open='0' close='1'/><object>"
                      "<pointModel generate='sphere' count='1500' radius='0.8'/>"
                      "<animation><rotation axis='0.3 1 0.2' center='0 0 0' degrees_per_unit_time='120'/>"
                      "<linear velocity='0.4 -0.3 0.2'/></animation></object></scene>";
    CHECK(missed_candidates(xml, 1.0, 8, 0.4) == 0);
}

/* Pure translation along x makes the boxes tight along x (the ray sweeps
 * exactly speed * slice / 2 each side of a slice's middle): a row of tiny
 * splats swept past the ray is gathered whole, and boxes shrunk by 10%
 * leave gaps between time slices in which splats are missed. */
TEST(candidate_boxes_are_tight_under_translation)
{
    static char xml[65536];
    size_t len = (size_t)snprintf(xml, sizeof xml, "<scene><camera position='0 0 4' lookat='0 0 0' width='64' "
                                  "height='64'/><shutter open='0' close='1'/><object position='-2 0 0'><pointModel>");
    for (int i = 0; i < 400; i++)
        len += (size_t)snprintf(xml + len, sizeof xml - len,
                                "<splat center='%.4f 0 0' normal='0 0 1' radius='0.003'/>", 0.01 * i);
    snprintf(xml + len, sizeof xml - len, "</pointModel><animation><linear velocity='4 0 0'/></animation>"
                                          "</object></scene>");
    CHECK(missed_candidates(xml, 1.0, 2, 0.0) == 0);
    CHECK(missed_candidates(xml, 0.9, 2, 0.0) > 0);
}

/* The sampled path's color at (x, y) averaged over n random times (a(t)
 * weighted), with its standard error per channel. */
static void sampled_average(const exact_fixture *f, double x, double y, int n, double mean[4], double se[4])
{
    double sum[4] = {0}, sum2[4] = {0}, wsum = 0;
    for (int i = 0; i < n; i++) {
        double t = f->s.shut.open + (f->s.shut.close - f->s.shut.open) * sampler_uniform(11, (uint64_t)i, 0, 2);
        double w = shutter_weight(&f->s.shut, t);
        vec3 org, dir;
        kbuffer kb;
        scene_camera_ray(&f->s, x, y, t, &org, &dir);
        accel_trace(f->a, org, dir, t, &kb);
        vec3 c = kb.count ? shade_hits(&f->s, &kb, org, dir) : f->s.background;
        double v[4] = {c.x, c.y, c.z, kb.count ? 1.0 : 0.0};
        for (int k = 0; k < 4; k++)
            sum[k] += w * v[k], sum2[k] += w * w * v[k] * v[k];
        wsum += w;
    }
    /* ratio estimator; its error as that of the mean of w v / mean(w) */
    double mw = wsum / n;
    for (int k = 0; k < 4; k++) {
        mean[k] = sum[k] / wsum;
        double var = (sum2[k] / n - (sum[k] / n) * (sum[k] / n)) / (mw * mw);
        se[k] = sqrt(fmax(var, 0.0) / n);
    }
}

/* Exact and sampled agree at random positions within 5 standard errors
 * (plus 1e-6: both are float-shaded). Returns the number of disagreements. */
static int exact_vs_sampled(const char *xml, int positions, int times)
{
    exact_fixture f;
    if (fixture_open(xml, 1.0, &f))
        return -1;
    int bad = 0;
    for (int p = 0; p < positions; p++) {
        double x = f.s.cam.width * (0.2 + 0.6 * sampler_uniform(5, (uint64_t)p, 0, 0));
        double y = f.s.cam.height * (0.2 + 0.6 * sampler_uniform(5, (uint64_t)p, 0, 1));
        double ex[4], mean[4], se[4];
        if (p % 4 == 0) /* batches of 4 positions, as a render's: the scratch arena reset between them */
            exact_scratch_begin_batch(f.scr);
        if (exact_sample(f.p, f.scr, x, y, ex, NULL))
            bad++;
        sampled_average(&f, x, y, times, mean, se);
        for (int k = 0; k < 4; k++)
            if (!(fabs(ex[k] - mean[k]) <= 5 * se[k] + 1e-6)) {
                printf("    (%.3f, %.3f) channel %d: exact %.6f, sampled %.6f +- %.6f\n", x, y, k, ex[k], mean[k],
                       se[k]);
                bad++;
            }
    }
    fixture_close(&f);
    return bad;
}

TEST(exact_matches_sampled_linear_rotation_phong)
{
    CHECK(exact_vs_sampled("<scene><camera position='0 0.6 7' lookat='0 0 0' fov='40' width='64' height='64'/>"
                           "<light type='directional' direction='-0.4 -0.7 -1'/>"
                           "<light type='point' position='-4 3 5' color='0.3 0.3 0.35'/>"
                           "<ambient color='0.15 0.15 0.15'/><background color='0.1 0.2 0.3'/>"
                           "<render epsilon='0.02'/>"
                           "<object position='0 0 -2'><pointModel generate='plane' count='4000' radius='3' checker='8'/>"
                           "</object>"
                           "<object position='0.3 0.2 0'><pointModel generate='torus' count='6000' radius='0.75' "
                           "minor_radius='0.28' checker='6'/><material specular='0.3'/><animation>"
                           "<rotation axis='0.3 1 0.2' center='0.3 0.2 0' degrees_per_unit_time='40'/>"
                           "<linear velocity='0.25 0.25 0'/></animation></object></scene>",
                           12, 6000) == 0);
}

TEST(exact_matches_sampled_keyframes_camera_spheres)
{
    CHECK(exact_vs_sampled("<scene><camera position='0 0 5' lookat='0 0 0' fov='40' width='64' height='64'>"
                           "<animation><keyframes interpolation='spline'><key time='0' translate='0 0 0' rotate='0 0 0'/>"
                           "<key time='1' translate='-0.3 0 0' rotate='0 8 0'/></keyframes></animation></camera>"
                           "<shutter open='0' close='1' weight='linear' center='0.3'/>"
                           "<light type='directional' direction='0 -0.5 -1'/><render epsilon='0.05'/>"
                           "<object><sphere center='0 0 0' radius='0.6' color='0.9 0.4 0.2'/></object>"
                           "<object position='0 0 -0.3'><pointModel generate='plane' count='3000' radius='2' checker='6'/>"
                           "<animation><keyframes><key time='0' translate='0 0 0' rotate='0 0 0'/>"
                           "<key time='1' translate='0.4 0 0' rotate='0 0 30'/></keyframes></animation></object>"
                           "</scene>",
                           12, 6000) == 0);
}

TEST(exact_matches_sampled_animated_scale_point_light_exp_weight)
{
    CHECK(exact_vs_sampled("<scene><camera position='0 0 5' lookat='0 0 0' fov='40' width='64' height='64'/>"
                           "<shutter open='0' close='1' weight='exp' center='0.7' rate='3'/>"
                           "<light type='point' position='-2 2 4'/><render epsilon='0.03'/>"
                           "<object><pointModel generate='plane' count='2500' radius='1' checker='5'/>"
                           "<material specular='0.5' shininess='20'/>"
                           "<animation><keyframes interpolation='spline'>"
                           "<key time='0' translate='-0.6 0 0' rotate='0 60 0' scale='1.6 0.3 1'/>"
                           "<key time='1' translate='0.6 0.2 0' rotate='20 75 10' scale='0.8 0.6 1'/>"
                           "</keyframes></animation></object></scene>",
                           12, 6000) == 0);
}

/* A weighted Maya curve (scenes/animations/rig.anim's hand: a Bezier whose
 * long fixed handle makes the speed vary strongly, spline y, turning in z)
 * before its step: the motion bound covers the weighted segments. */
TEST(exact_matches_sampled_weighted_maya_curves)
{
    CHECK(exact_vs_sampled("<scene><camera position='0.3 0.1 4' lookat='0.3 0.1 0' fov='40' width='64' "
                           "height='64'/><shutter open='0' close='0.45'/>"
                           "<light type='directional' direction='0 -0.5 -1'/><render epsilon='0.03'/>"
                           "<object><pointModel generate='plane' count='2500' radius='0.8' checker='5'/>"
                           "<animation file='scenes/animations/rig.anim' node='hand'/></object></scene>",
                           12, 6000) == 0);
}

/* Regression: a plane of splats spinning about an axis in its plane
 * so fast that 16 candidate time slices cannot bound the motion (angular
 * speed x slice / 2 >= 1/2): the candidates were dropped and the pixel
 * rendered empty. Exact must still match the sampled average, k = 5. */
static int spinning_plane_matches(double degrees)
{
    char xml[1024];
    snprintf(xml, sizeof xml,
             "<scene><camera position='0 0 5' lookat='0 0 0' fov='30' width='64' height='64'/>"
             "<render epsilon='0.03'/><light type='directional' direction='0 -0.5 -1'/>"
             "<object><pointModel generate='plane' count='600' radius='1' checker='3'/>"
             "<animation><rotation axis='0.2 1 0' center='0 0 0' degrees_per_unit_time='%g'/></animation>"
             "</object></scene>",
             degrees);
    return exact_vs_sampled(xml, 6, 4000);
}

TEST(exact_matches_sampled_spinning_360_1000_5000_degrees)
{
    CHECK(spinning_plane_matches(360) == 0);
    CHECK(spinning_plane_matches(1000) == 0);
    CHECK(spinning_plane_matches(5000) == 0);
}

/* A keyframed scale from 1 to 30 over the shutter (same failure). */
TEST(exact_matches_sampled_scale_1_to_30)
{
    CHECK(exact_vs_sampled("<scene><camera position='0 0 40' lookat='0 0 0' fov='40' width='64' height='64'/>"
                           "<render epsilon='0.03'/><light type='directional' direction='0 -0.5 -1'/>"
                           "<object><pointModel generate='plane' count='600' radius='0.5' checker='3'/>"
                           "<animation><keyframes interpolation='linear'>"
                           "<key time='0' translate='0 0 0' rotate='0 0 0' scale='1 1 1'/>"
                           "<key time='1' translate='0 0 0' rotate='0 0 40' scale='30 30 1'/>"
                           "</keyframes></animation></object></scene>",
                           6, 4000) == 0);
}

/* Regression: a shutter at t = 1e7, where ulp(t) (1.9e-9) exceeds
 * the split tolerance (1e-9 of the shutter): a piece's midpoint equals an
 * end and splitting never stopped (a heap overflow). */
TEST(exact_matches_sampled_on_a_shutter_at_1e7)
{
    CHECK(exact_vs_sampled("<scene><camera position='0 0 5' lookat='0 0 0' fov='30' width='64' height='64'/>"
                           "<shutter open='1e7' close='10000001'/>"
                           "<render epsilon='0.03'/><light type='directional' direction='0 -0.5 -1'/>"
                           "<object><pointModel generate='plane' count='600' radius='1' checker='3'/>"
                           "<animation><rotation axis='0.2 1 0' center='0 0 0' degrees_per_unit_time='100'/>"
                           "</animation></object></scene>",
                           6, 4000) == 0);
}
