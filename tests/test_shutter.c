#include <string.h>
/* Temporal weights a(t) (thesis eq. 3.1, Figure 3.1). */
#include "harness.h"
#include "motion/shutter.h"

TEST(box_weight_is_constant)
{
    shutter s;
    shutter_default(&s);
    CHECK(shutter_weight(&s, 0.0) == 1.0 && shutter_weight(&s, 0.7) == 1.0);
}

TEST(linear_weight_falls_to_zero_at_shutter_length_from_center)
{
    shutter s;
    shutter_default(&s);
    s.open = 1, s.close = 3, s.kind = WEIGHT_LINEAR, s.center = 3;
    CHECK_NEAR(shutter_weight(&s, 3), 1.0, 1e-15);
    CHECK_NEAR(shutter_weight(&s, 2), 0.5, 1e-15);
    CHECK_NEAR(shutter_weight(&s, 1), 0.0, 1e-15);
    s.center = 2; /* centered: 1 - |t-2|/2 */
    CHECK_NEAR(shutter_weight(&s, 1), 0.5, 1e-15);
}

TEST(exp_weight_decreases_from_center)
{
    shutter s;
    shutter_default(&s);
    s.kind = WEIGHT_EXP, s.center = 1, s.rate = 2;
    CHECK_NEAR(shutter_weight(&s, 1), 1.0, 1e-15);
    CHECK_NEAR(shutter_weight(&s, 0.25), exp(-1.5), 1e-15);
    CHECK(shutter_weight(&s, 0.2) < shutter_weight(&s, 0.4));
}

TEST(table_weight_interpolates_linearly_and_clamps)
{
    shutter s;
    shutter_default(&s);
    s.kind = WEIGHT_TABLE;
    s.table_size = 3;
    double t[3] = {0.2, 0.4, 0.8}, w[3] = {1, 3, 0};
    for (int i = 0; i < 3; i++)
        s.table_t[i] = t[i], s.table_w[i] = w[i];
    CHECK_NEAR(shutter_weight(&s, 0.0), 1.0, 1e-15);
    CHECK_NEAR(shutter_weight(&s, 0.3), 2.0, 1e-12);
    CHECK_NEAR(shutter_weight(&s, 0.6), 1.5, 1e-12);
    CHECK_NEAR(shutter_weight(&s, 0.9), 0.0, 1e-15);
    CHECK(shutter_check(&s, NULL) == 0);
}

TEST(shutter_check_rejects_bad_settings)
{
    shutter s;
    rr_error e;
    shutter_default(&s);
    s.close = s.open;
    CHECK(shutter_check(&s, &e) != 0);
    shutter_default(&s);
    s.kind = WEIGHT_TABLE;
    s.table_size = 2;
    s.table_t[0] = 0.5, s.table_t[1] = 0.5, s.table_w[0] = s.table_w[1] = 1;
    CHECK(shutter_check(&s, &e) != 0); /* times not increasing */
    s.table_t[1] = 0.7, s.table_w[0] = s.table_w[1] = 0;
    CHECK(shutter_check(&s, &e) != 0); /* zero everywhere */
    s.table_w[0] = -1;
    CHECK(shutter_check(&s, &e) != 0); /* negative */
}

/* The integral of a(t) from open to t by the composite Simpson rule on
 * 20000 intervals (an argument independent of the pieces shutter_cdf_init
 * derives: only shutter_weight is read). */
static double weight_integral(const shutter *s, double t)
{
    const int n = 20000;
    double h = (t - s->open) / n, sum = 0;
    for (int i = 0; i <= n; i++) {
        double w = i == 0 || i == n ? 1 : i % 2 ? 4 : 2;
        sum += w * shutter_weight(s, s->open + i * h);
    }
    return sum * h / 3;
}

/* Drawing times from a(t): the a-mass before t(u) is u of the whole, for
 * every weight kind (linear with its kinks, exp both sides of its center,
 * a table that is zero on 98% of the shutter, where most draws of a
 * uniform time would find a(t) = 0). */
static int cdf_matches(const shutter *s)
{
    shutter_cdf c;
    shutter_cdf_init(&c, s);
    double total = weight_integral(s, s->close);
    int bad = 0;
    for (int k = 0; k < 50; k++) {
        double u = (k + 0.5) / 50, t = shutter_cdf_time(&c, u);
        if (!(t >= s->open && t <= s->close) || !(fabs(weight_integral(s, t) / total - u) < 2e-6)) {
            printf("    u %.3f: t %.9f, mass before it %.9f\n", u, t, weight_integral(s, t) / total);
            bad++;
        }
        if (!(shutter_weight(s, t) > 0)) /* never a time a(t) does not see */
            bad++;
    }
    return bad;
}

TEST(times_drawn_from_the_weight_follow_its_integral)
{
    shutter s;
    shutter_default(&s);
    CHECK(cdf_matches(&s) == 0);
    s.kind = WEIGHT_LINEAR, s.center = 0.3;
    CHECK(cdf_matches(&s) == 0);
    s.kind = WEIGHT_EXP, s.center = 0.7, s.rate = 3;
    CHECK(cdf_matches(&s) == 0);
    s.kind = WEIGHT_TABLE; /* zero but on [0.49, 0.51] */
    double t[] = {0, 0.49, 0.495, 0.505, 0.51, 1}, w[] = {0, 0, 1, 1, 0, 0};
    s.table_size = 6;
    for (int i = 0; i < 6; i++)
        s.table_t[i] = t[i], s.table_w[i] = w[i];
    CHECK(cdf_matches(&s) == 0);
    s.open = -2, s.close = 3, s.kind = WEIGHT_LINEAR, s.center = 3; /* the default: ramp up to close */
    CHECK(cdf_matches(&s) == 0);
}

/* A shutter whose length overflows (--shutter -1e308,1e308) was accepted:
 * every time and weight computed from close - open was then inf or NaN. */
TEST(shutter_check_rejects_a_length_that_overflows)
{
    shutter s;
    rr_error e;
    shutter_default(&s);
    s.open = -1e308, s.close = 1e308;
    CHECK(shutter_check(&s, &e) != 0 && strstr(e.msg, "overflows"));
    s.open = -1e307, s.close = 1e307;
    CHECK(shutter_check(&s, &e) == 0);
}

/* A subnormal length ([0, 1e-310]) was accepted; the smallest normal one is not refused. */
TEST(shutter_check_rejects_a_subnormal_length)
{
    shutter s;
    rr_error e;
    shutter_default(&s);
    s.open = 0, s.close = 1e-310;
    CHECK(shutter_check(&s, &e) != 0 && strstr(e.msg, "subnormal"));
    s.close = 0x1p-1022; /* DBL_MIN, written as its value (C99 hex float), not through float.h */
    CHECK(shutter_check(&s, &e) == 0);
}
