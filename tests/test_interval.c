/* core/interval.h, the one outward-rounding helper of the conservative
 * bounds: every interval it makes holds the exact one. The exact values
 * come from long double arithmetic (64-bit mantissas: a difference of
 * doubles within 11 binary orders of each other, and a sum of a float and
 * a double's multiple here, are exact there), not from the helper. */
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "core/interval.h"
#include "harness.h"

/* A double in [lo, hi) from a fixed sequence (rand with a fixed seed). */
static double uniform(double lo, double hi) { return lo + (hi - lo) * (rand() / (RAND_MAX + 1.0)); }

/* One step out holds the exact t - c for every t, c whose rounded
 * difference is an end: the case gaussian_dynamic.c's D-interval rests
 * on. 1 - 1e-17 rounds to 1, above the exact value: the unstepped end
 * misses it. */
TEST(a_step_out_holds_the_exact_difference)
{
    double t = 1.0, c = 1e-17;
    long double exact = (long double)t - (long double)c;
    CHECK((long double)(t - c) > exact); /* the rounded end alone misses it */
    interval d = interval_step_out(interval_make(t - c, t - c));
    CHECK(d.lo <= exact && exact <= d.hi);
    srand(7);
    for (int i = 0; i < 100000; i++) {
        double t0 = uniform(0, 1), t1 = t0 + uniform(0, 1), cc = uniform(-1, 2);
        interval D = interval_step_out(interval_make(t0 - cc, t1 - cc));
        long double e0 = (long double)t0 - cc, e1 = (long double)t1 - cc;
        if (!(D.lo <= e0 && e1 <= D.hi && D.lo < t0 - cc && D.hi > t1 - cc))
            CHECK(!"a stepped-out D-interval missed the exact difference");
    }
}

/* A splat's or Gaussian's box [c - e, c + e] widened by the float room and
 * rounded outward to floats holds the exact box strictly, with at least
 * 1e-5 of the reach to spare (the room float traversal needs), at any
 * position and size from 1e-20 to 1e15 (RR_MAX_REACH). */
TEST(a_box_with_float_room_rounded_out_holds_the_exact_box)
{
    srand(11);
    for (int i = 0; i < 100000; i++) {
        float c = (float)(uniform(-1, 1) * pow(10, uniform(-20, 15)));
        float e = (float)pow(10, uniform(-20, 15));
        interval box = interval_widen(interval_around(c, e), interval_float_room(e, c));
        float lo, hi;
        interval_round_out_f(box, &lo, &hi);
        long double xlo = (long double)c - e, xhi = (long double)c + e, spare = 1e-5L * e;
        if (!(lo < xlo - spare && hi > xhi + spare))
            CHECK(!"a rounded-out box cut into the exact one");
    }
    float lo, hi; /* a point at the origin still gets a box */
    interval_round_out_f(interval_widen(interval_around(0, 0), interval_float_room(0, 0)), &lo, &hi);
    CHECK(lo < 0 && hi > 0);
}

/* The relative room worked by hand: [1, 3] with rel 1e-4 and abs 1e-6
 * grows by 1e-4 (2 + 1 + 3) + 1e-6 = 6.01e-4 at each end. */
TEST(relative_room_by_hand)
{
    interval a = interval_widen_rel(interval_make(1, 3), 1e-4, 1e-6);
    CHECK(fabs(a.lo - (1 - 6.01e-4)) < 1e-15 && fabs(a.hi - (3 + 6.01e-4)) < 1e-15);
    interval z = interval_widen_rel(interval_make(0, 0), 1e-4, 1e-6);
    CHECK(z.lo == -1e-6 && z.hi == 1e-6);
}

/* The unit roundoff is half the gap between 1 and the next double. */
TEST(unit_roundoff_is_half_an_ulp_of_one)
{
    CHECK(RR_UNIT_ROUNDOFF == (nextafter(1.0, 2.0) - 1.0) / 2);
    CHECK(1.0 + RR_UNIT_ROUNDOFF == 1.0 && 1.0 + 2 * RR_UNIT_ROUNDOFF > 1.0);
}
