/* Keyed curves (curve.h): values at and between keys worked by hand for
 * every tangent type and infinity mode, and the slope bound. */
#include <stdlib.h>
#include <string.h>

#include "curve.h"
#include "harness.h"

/* A curve from (time, value) pairs, all keys with the same tangents. */
static curve make(int n, const double *tv, tangent_kind in, tangent_kind out, infinity_kind pre,
                  infinity_kind post)
{
    curve c = {n, calloc((size_t)n, sizeof(curve_key)), pre, post};
    for (int i = 0; i < n; i++) {
        c.keys[i].time = tv[2 * i], c.keys[i].value = tv[2 * i + 1];
        c.keys[i].in = in, c.keys[i].out = out;
    }
    rr_error e;
    CHECK(curve_prepare(&c, &e) == 0);
    return c;
}

TEST(linear_step_stepnext_and_flat_segments)
{
    const double tv[] = {0, 1, 2, 5};
    curve c = make(2, tv, TAN_LINEAR, TAN_LINEAR, INF_CONSTANT, INF_CONSTANT);
    CHECK_NEAR(curve_eval(&c, 0.5), 2.0, 1e-15);
    CHECK_NEAR(curve_eval(&c, 2.0), 5.0, 0);
    curve_free(&c);
    c = make(2, tv, TAN_FLAT, TAN_STEP, INF_CONSTANT, INF_CONSTANT);
    CHECK(curve_eval(&c, 1.999) == 1.0 && curve_eval(&c, 2.0) == 5.0);
    CHECK(curve_eval_left(&c, 2.0) == 1.0); /* the jump happens at the key */
    curve_free(&c);
    c = make(2, tv, TAN_FLAT, TAN_STEPNEXT, INF_CONSTANT, INF_CONSTANT);
    CHECK(curve_eval(&c, 0.0) == 1.0 && curve_eval(&c, 0.2) == 5.0 && curve_eval_left(&c, 2.0) == 5.0);
    curve_free(&c);
    /* flat: Hermite with zero slopes, 1 + 4 (3u^2 - 2u^3); u = 1/4 -> 5/32 */
    c = make(2, tv, TAN_FLAT, TAN_FLAT, INF_CONSTANT, INF_CONSTANT);
    CHECK_NEAR(curve_eval(&c, 0.5), 1 + 4 * 0.15625, 1e-15);
    CHECK_NEAR(curve_eval(&c, 1.0), 3.0, 1e-15);
    curve_free(&c);
}

TEST(spline_tangents_are_catmull_rom_and_c1)
{
    const double tv[] = {0, 0, 1, 1, 2, 0};
    curve c = make(3, tv, TAN_SPLINE, TAN_SPLINE, INF_CONSTANT, INF_CONSTANT);
    /* slopes 1 (one-sided), 0, -1; at u = 1/2: h10 * 1 + h01 * 1 = 1/8 + 1/2 */
    CHECK_NEAR(c.keys[1].in_slope, 0.0, 0);
    CHECK_NEAR(curve_eval(&c, 0.5), 0.625, 1e-15);
    CHECK_NEAR(curve_eval(&c, 1.5), 0.625, 1e-15); /* mirror image */
    /* C1 at the middle key: one-sided difference quotients agree */
    double h = 1e-6, left = (curve_eval(&c, 1) - curve_eval(&c, 1 - h)) / h;
    double right = (curve_eval(&c, 1 + h) - curve_eval(&c, 1)) / h;
    CHECK_NEAR(left, right, 1e-5);
    curve_free(&c);
}

TEST(clamped_tangents_never_overshoot)
{
    const double rising[] = {0, 0, 1, 1, 2, 1.1, 3, 3};
    curve c = make(4, rising, TAN_CLAMPED, TAN_CLAMPED, INF_CONSTANT, INF_CONSTANT);
    /* secants 1 and 0.1: the spline slope 0.55 is limited to 3 * 0.1 */
    CHECK_NEAR(c.keys[1].out_slope, 0.3, 1e-15);
    for (double t = 0; t <= 3; t += 0.001) /* monotone data stay monotone */
        if (curve_eval(&c, t + 0.001) < curve_eval(&c, t) - 1e-15) {
            CHECK(!"clamped curve decreases");
            break;
        }
    curve_free(&c);
    const double peak[] = {0, 0, 1, 2, 2, 0};
    c = make(3, peak, TAN_CLAMPED, TAN_CLAMPED, INF_CONSTANT, INF_CONSTANT);
    CHECK(c.keys[1].in_slope == 0 && c.keys[1].out_slope == 0); /* flat at the extremum */
    CHECK(curve_eval(&c, 0.9) < 2.0 && curve_eval(&c, 1.1) < 2.0);
    curve_free(&c);
}

TEST(fixed_tangent_uses_its_angle)
{
    const double tv[] = {0, 0, 1, 0};
    curve c = make(2, tv, TAN_LINEAR, TAN_LINEAR, INF_CONSTANT, INF_CONSTANT);
    c.keys[0].out = TAN_FIXED, c.keys[0].out_angle = M_PI / 4; /* slope 1 */
    rr_error e;
    CHECK(curve_prepare(&c, &e) == 0);
    CHECK_NEAR(c.keys[0].out_slope, 1.0, 1e-15);
    /* h10(1/2) * 1 + h11(1/2) * 0 (linear in-tangent: secant 0) */
    CHECK_NEAR(curve_eval(&c, 0.5), 0.125, 1e-15);
    c.keys[0].out_angle = M_PI / 2;
    CHECK(curve_prepare(&c, &e) == -1); /* vertical: no slope */
    curve_free(&c);
}

TEST(infinity_modes_extend_the_curve)
{
    const double tv[] = {0, 0, 1, 2};
    static const struct {
        infinity_kind mode;
        double before, after; /* values at -0.25 and 2.25 */
    } cases[] = {{INF_CONSTANT, 0, 2}, {INF_LINEAR, -0.5, 4.5}, {INF_CYCLE, 1.5, 0.5},
                 {INF_CYCLE_RELATIVE, -0.5, 4.5}, {INF_OSCILLATE, 0.5, 0.5}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        curve c = make(2, tv, TAN_LINEAR, TAN_LINEAR, cases[i].mode, cases[i].mode);
        CHECK_NEAR(curve_eval(&c, -0.25), cases[i].before, 1e-12);
        CHECK_NEAR(curve_eval(&c, 2.25), cases[i].after, 1e-12);
        curve_free(&c);
    }
    curve c = make(2, tv, TAN_LINEAR, TAN_LINEAR, INF_OSCILLATE, INF_OSCILLATE);
    CHECK_NEAR(curve_eval(&c, 1.25), 1.5, 1e-12); /* going back */
    curve_free(&c);
}

TEST(slope_bound_holds_everywhere)
{
    const double tv[] = {0, 0, 0.3, 2, 1, -1, 1.2, 0.5, 2, 0};
    tangent_kind kinds[] = {TAN_LINEAR, TAN_SPLINE, TAN_CLAMPED, TAN_FLAT};
    for (int k = 0; k < 4; k++) {
        curve c = make(5, tv, kinds[k], kinds[k], INF_LINEAR, INF_CYCLE);
        double bound = curve_max_slope(&c), steepest = 0, h = 1e-5;
        for (double t = -1; t < 5; t += h * 37)
            steepest = fmax(steepest, fabs(curve_eval(&c, t + h) - curve_eval(&c, t)) / h);
        CHECK(steepest <= bound * (1 + 1e-6));
        CHECK(steepest >= 0.99 * bound); /* and it is tight */
        curve_free(&c);
    }
}

TEST(bad_keys_are_rejected)
{
    rr_error e;
    curve_key keys[2];
    memset(keys, 0, sizeof keys);
    keys[0].time = 1, keys[1].time = 1;
    curve c = {2, keys, INF_CONSTANT, INF_CONSTANT};
    CHECK(curve_prepare(&c, &e) == -1 && strstr(e.msg, "key 2") && strstr(e.msg, "not after"));
    keys[1].time = 2, keys[1].value = NAN;
    CHECK(curve_prepare(&c, &e) == -1 && strstr(e.msg, "NaN"));
    tangent_kind t;
    CHECK(tangent_from_name("slow", &t) == -1 && tangent_from_name("auto", &t) == 0 && t == TAN_AUTO);
}

/* Keys (0, 0), (1, 1), (2, 0). auto (animx's autoTangent): flat at both
 * ends, flat at the peak, so each segment is 3u^2 - 2u^3 and the value at
 * t = 0.5 is 0.5. clamped keeps the one-sided secant (slope 1) at the first
 * key: Hermite 0.125 * 1 + 0.5 * 1 = 0.625. */
TEST(auto_tangents_are_flat_at_the_ends_as_animx_computes_them)
{
    const double tv[] = {0, 0, 1, 1, 2, 0};
    curve c = make(3, tv, TAN_AUTO, TAN_AUTO, INF_CONSTANT, INF_CONSTANT);
    CHECK_NEAR(curve_eval(&c, 0.5), 0.5, 1e-15);
    CHECK_NEAR(curve_eval(&c, 1.5), 0.5, 1e-15);
    curve_free(&c);
    c = make(3, tv, TAN_CLAMPED, TAN_CLAMPED, INF_CONSTANT, INF_CONSTANT);
    CHECK_NEAR(curve_eval(&c, 0.5), 0.625, 1e-15);
    curve_free(&c);
    /* rising keys (0, 0), (1, 1), (2, 3): between, as clamped: spline slope
     * 1.5, within 3x the smaller secant (3) */
    const double up[] = {0, 0, 1, 1, 2, 3};
    c = make(3, up, TAN_AUTO, TAN_AUTO, INF_CONSTANT, INF_CONSTANT);
    curve d = make(3, up, TAN_CLAMPED, TAN_CLAMPED, INF_CONSTANT, INF_CONSTANT);
    CHECK(c.keys[1].in_slope == 1.5 && c.keys[1].out_slope == d.keys[1].out_slope);
    CHECK(c.keys[0].out_slope == 0.0 && c.keys[2].in_slope == 0.0);
    curve_free(&c), curve_free(&d);
}
