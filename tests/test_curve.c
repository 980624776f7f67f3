/* Keyed curves (curve.h): values at and between keys worked by hand for
 * every tangent type and infinity mode, and the slope bound. */
#include <stdlib.h>
#include <string.h>

#include "motion/curve.h"
#include "harness.h"

/* A curve from (time, value) pairs, all keys with the same tangents. */
static curve make(int n, const double *tv, tangent_kind in, tangent_kind out, infinity_kind pre,
                  infinity_kind post)
{
    curve c = {n, calloc((size_t)n, sizeof(curve_key)), pre, post, 0, 0.0, 0.0};
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

/* Re-prepares a curve after its keys' tangents or the curve's settings
 * changed. */
static void reprepare(curve *c)
{
    rr_error e;
    CHECK(curve_prepare(c, &e) == 0);
}

/* Keys (0, 0), (1, 1), (2, 1.125), (3, 3): secants 1, 0.125, 1.875; spline
 * slopes 0.5625 at key 2 and 1 at key 3. animEngine's clamped is flat only
 * next to a value within clamp_flat, else spline (it may overshoot);
 * plateau is the spline slope unless it exceeds 3x the smaller secant
 * (0.375 at both inner keys), then flat; auto limits it to 0.375 (animx). */
TEST(clamped_plateau_and_auto_follow_autodesk)
{
    const double tv[] = {0, 0, 1, 1, 2, 1.125, 3, 3};
    curve c = make(4, tv, TAN_CLAMPED, TAN_CLAMPED, INF_CONSTANT, INF_CONSTANT);
    CHECK_NEAR(c.keys[1].out_slope, 0.5625, 1e-15); /* 0.125 apart, clamp_flat 0 */
    CHECK_NEAR(c.keys[0].out_slope, 1.0, 1e-15);    /* an end: the one-sided secant */
    /* between keys 2 and 3, slopes 0.5625 and 1: Hermite at u = 1/2 is
     * 1/2 + 0.5625 / 8 + 1.125 / 2 - 1 / 8 */
    CHECK_NEAR(curve_eval(&c, 1.5), 1.0078125, 1e-15);
    c.clamp_flat = 0.125; /* Maya's rule is <= */
    reprepare(&c);
    CHECK(c.keys[1].in_slope == 0 && c.keys[1].out_slope == 0 && c.keys[2].in_slope == 0);
    CHECK_NEAR(c.keys[0].out_slope, 1.0, 1e-15);
    CHECK_NEAR(curve_eval(&c, 1.5), 1.0625, 1e-15); /* both flat: the mean */
    CHECK(curve_eval(&c, 2.0) == 1.125);
    curve_free(&c);
    c = make(4, tv, TAN_PLATEAU, TAN_PLATEAU, INF_CONSTANT, INF_CONSTANT);
    CHECK(c.keys[0].out_slope == 0 && c.keys[1].out_slope == 0 && c.keys[2].in_slope == 0 &&
          c.keys[3].in_slope == 0);
    curve_free(&c);
    c = make(4, tv, TAN_AUTO, TAN_AUTO, INF_CONSTANT, INF_CONSTANT);
    CHECK_NEAR(c.keys[1].out_slope, 0.375, 1e-15);
    CHECK_NEAR(c.keys[2].in_slope, 0.375, 1e-15);
    curve_free(&c);
    const double up[] = {0, 0, 1, 1, 2, 3}; /* spline 1.5, within 3x the smaller secant */
    c = make(3, up, TAN_PLATEAU, TAN_PLATEAU, INF_CONSTANT, INF_CONSTANT);
    CHECK(c.keys[1].in_slope == 1.5 && c.keys[1].out_slope == 1.5 && c.keys[0].out_slope == 0);
    /* first segment, slopes 0 and 1.5: 1/2 - 1.5 / 8 at u = 1/2; the key's value at the key */
    CHECK_NEAR(curve_eval(&c, 0.5), 0.3125, 1e-15);
    CHECK(curve_eval(&c, 1.0) == 1.0);
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
    curve c = {2, keys, INF_CONSTANT, INF_CONSTANT, 0, 0.0, 0.0};
    CHECK(curve_prepare(&c, &e) == -1 && strstr(e.msg, "key 2") && strstr(e.msg, "not after"));
    keys[1].time = 2, keys[1].value = NAN;
    CHECK(curve_prepare(&c, &e) == -1 && strstr(e.msg, "NaN"));
    tangent_kind t;
    CHECK(tangent_from_name("wobbly", &t) == -1 && tangent_from_name("auto", &t) == 0 && t == TAN_AUTO);
    /* Maya's obsolete slow and fast: animEngine gives them the secant */
    CHECK(tangent_from_name("slow", &t) == 0 && t == TAN_LINEAR);
    CHECK(tangent_from_name("fast", &t) == 0 && t == TAN_LINEAR);
    keys[1].value = 1, keys[0].out_handle = -1;
    CHECK(curve_prepare(&c, &e) == -1 && strstr(e.msg, "weight must not be negative"));
}

/* Keys (0, 0), (1, 1), (2, 0). auto (animx's autoTangent): flat at both
 * ends, flat at the peak, so each segment is 3u^2 - 2u^3 and the value at
 * t = 0.5 is 0.5. clamped keeps the one-sided secant (slope 1) at the first
 * key (spline, since no value is within clamp_flat): Hermite 0.125 * 1 +
 * 0.5 * 1 = 0.625. */
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
    /* rising keys (0, 0), (1, 1), (2, 3): between, the spline slope 1.5,
     * within 3x the smaller secant (3) */
    const double up[] = {0, 0, 1, 1, 2, 3};
    c = make(3, up, TAN_AUTO, TAN_AUTO, INF_CONSTANT, INF_CONSTANT);
    CHECK(c.keys[1].in_slope == 1.5 && c.keys[1].out_slope == 1.5);
    CHECK(c.keys[0].out_slope == 0.0 && c.keys[2].in_slope == 0.0);
    curve_free(&c);
}

/* A weighted two-key curve (0, v0) -> (h, v1): the first key's out-tangent
 * fixed at `angle` with a handle reaching `out` in time, the second key's
 * in-tangent of the given kind. */
static curve weighted(double h, double v0, double v1, double angle, double out, tangent_kind in)
{
    const double tv[] = {0, v0, h, v1};
    curve c = make(2, tv, TAN_FLAT, in, INF_CONSTANT, INF_CONSTANT);
    c.weighted = 1;
    c.keys[0].out = TAN_FIXED, c.keys[0].out_angle = angle, c.keys[0].out_handle = out;
    reprepare(&c);
    return c;
}

/* Collinear control points: a straight line whatever the handle lengths
 * (which only change how fast the parameter runs), so v(t) = t. */
TEST(weighted_segment_with_collinear_handles_is_a_straight_line)
{
    curve c = weighted(3, 0, 3, M_PI / 4, 0.5, TAN_FIXED);
    c.keys[1].in = TAN_FIXED, c.keys[1].in_angle = M_PI / 4, c.keys[1].in_handle = 2; /* x at 1/6 and 1/3 */
    reprepare(&c);
    for (double t = 0; t <= 3; t += 0.125)
        CHECK_NEAR(curve_eval(&c, t), t, 1e-14);
    curve_free(&c);
}

/* Handles of a third of the interval space the time controls evenly, so
 * time is linear in the parameter and the segment is the Hermite cubic with
 * the same slopes: slope 1 out, flat in, h = 3: 3 u (1 - u)^2, 0.375 at the
 * middle. A handle of 1/2 on a unit interval: controls x (0, 1/2, 2/3, 1),
 * y (0, 1/2, 0, 0); at u = 1/2, x = 3/16 + 1/4 + 1/8 = 9/16 and y = 3/16. */
TEST(weighted_segment_is_the_bezier_of_its_handles)
{
    curve c = weighted(3, 0, 0, M_PI / 4, 1, TAN_FLAT);
    CHECK_NEAR(curve_eval(&c, 1.5), 0.375, 1e-15);
    CHECK(curve_eval(&c, 0) == 0 && curve_eval(&c, 3) == 0);
    curve_free(&c);
    c = weighted(1, 0, 0, M_PI / 4, 0.5, TAN_FLAT);
    CHECK_NEAR(curve_eval(&c, 9.0 / 16), 3.0 / 16, 1e-15);
    c.weighted = 0; /* the same keys unweighted: the Hermite value differs */
    CHECK(fabs(curve_eval(&c, 9.0 / 16) - 3.0 / 16) > 0.01);
    curve_free(&c);
}

/* Handles whose time extents overlap past the ellipse where time stops
 * being monotonic, or meet it (x controls 1 and 0: a vertical tangent at
 * the middle), are refused; a zero handle (a step in-tangent, weight 0) is
 * not: there both coordinates stop together. */
TEST(weighted_handles_that_stop_time_are_refused)
{
    const double tv[] = {0, 0, 1, 1};
    curve c = make(2, tv, TAN_FIXED, TAN_FIXED, INF_CONSTANT, INF_CONSTANT);
    c.weighted = 1;
    c.keys[0].out_handle = 1, c.keys[1].in_handle = 1;
    c.keys[0].out_angle = c.keys[1].in_angle = M_PI / 4;
    rr_error e;
    CHECK(curve_prepare(&c, &e) == -1 && strstr(e.msg, "keys 1 and 2") && strstr(e.msg, "vertical tangent"));
    c.keys[0].out_handle = 1.2, c.keys[1].in_handle = 0.9;
    CHECK(curve_prepare(&c, &e) == -1);
    c.keys[0].out_handle = 0.99, c.keys[1].in_handle = 0.99; /* just inside: monotonic */
    CHECK(curve_prepare(&c, &e) == 0);
    c.keys[0].out_handle = 0, c.keys[1].in = TAN_STEP;
    CHECK(curve_prepare(&c, &e) == 0);
    CHECK_NEAR(curve_eval(&c, 0.5), 0.5, 1e-15); /* both handles zero: x and y controls evenly spaced */
    curve_free(&c);
}

/* The slope bound of weighted curves holds and is tight, also near a zero
 * handle (where x and y both stop) and with long handles. */
TEST(weighted_slope_bound_holds_everywhere)
{
    const double tv[] = {0, 0, 0.3, 2, 1, -1, 1.2, 0.5, 2, 0};
    tangent_kind kinds[] = {TAN_LINEAR, TAN_SPLINE, TAN_AUTO, TAN_STEP, TAN_FIXED};
    for (int k = 0; k < 5; k++) {
        curve c = make(5, tv, kinds[k], kinds[k] == TAN_STEP ? TAN_SPLINE : kinds[k], INF_LINEAR, INF_CYCLE);
        c.weighted = 1;
        for (int i = 0; i < 5 && kinds[k] == TAN_FIXED; i++) {
            c.keys[i].in_angle = 0.3 * i - 0.5, c.keys[i].out_angle = 0.7 - 0.2 * i;
            c.keys[i].in_handle = i == 2 ? 0 : 0.09, c.keys[i].out_handle = 0.06 + 0.02 * i;
        }
        reprepare(&c);
        double bound = curve_max_slope(&c), steepest = 0, h = 1e-6;
        for (double t = -1; t < 5; t += h * 37)
            steepest = fmax(steepest, fabs(curve_eval(&c, t + h) - curve_eval(&c, t)) / h);
        CHECK(steepest <= bound * (1 + 1e-6));
        CHECK(steepest >= 0.99 * bound);
        curve_free(&c);
    }
}

/* Whether evaluation shows a jump over [t0, t1]: two samples dt apart that
 * differ by more than the slope bound allows. */
static int jumps_when_sampled(const curve *c, double t0, double t1)
{
    const int n = 200000;
    double dt = (t1 - t0) / n, prev = curve_eval(c, t0);
    for (int i = 1; i <= n; i++) {
        double v = curve_eval(c, t0 + i * dt);
        if (fabs(v - prev) > curve_max_slope(c) * dt * (1 + 1e-9) + 1e-12)
            return 1;
        prev = v;
    }
    return 0;
}

/* curve_is_continuous (the flattened Gaussian boxes trust a camera's turn
 * rate only when its rotation cannot jump) agrees with sampling: steps
 * between different values and cycles between different ends jump; steps
 * between equal values, linear and spline keys, cycle-relative and
 * oscillate infinities do not. */
TEST(curve_continuity_agrees_with_sampling)
{
    const double differ[] = {0, 1, 1, 3, 2, 2}, same_ends[] = {0, 1, 1, 3, 2, 1}, flat[] = {0, 2, 1, 2, 2, 2};
    struct {
        const double *tv;
        tangent_kind out;
        infinity_kind post;
        int continuous;
    } cases[] = {
        {differ, TAN_STEP, INF_CONSTANT, 0},        {differ, TAN_STEPNEXT, INF_CONSTANT, 0},
        {flat, TAN_STEP, INF_CONSTANT, 1},          {differ, TAN_LINEAR, INF_CONSTANT, 1},
        {differ, TAN_SPLINE, INF_LINEAR, 1},        {differ, TAN_LINEAR, INF_CYCLE, 0},
        {same_ends, TAN_LINEAR, INF_CYCLE, 1},      {differ, TAN_LINEAR, INF_CYCLE_RELATIVE, 1},
        {differ, TAN_SPLINE, INF_OSCILLATE, 1},
    };
    int disagree = 0;
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        curve c = make(3, cases[k].tv, cases[k].out == TAN_STEP || cases[k].out == TAN_STEPNEXT ? TAN_FLAT : cases[k].out,
                       cases[k].out, INF_CONSTANT, cases[k].post);
        int sampled = !jumps_when_sampled(&c, -1.0, 7.0);
        disagree += sampled != cases[k].continuous || curve_is_continuous(&c) != cases[k].continuous;
        curve_free(&c);
    }
    CHECK(disagree == 0);
}
