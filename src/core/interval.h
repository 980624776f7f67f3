/* Conservative bounds: closed intervals [lo, hi] and the ways refrender
 * rounds them outward, in one place. The model is pbrt-v4's Interval
 * (src/pbrt/util/math.h): a bound is a pair of ends, and every step that
 * could round moves an end away from the value, never towards it, so the
 * computed interval always holds the exact one. Here the steps are the few
 * the bounds need (widen by a room, step out one ulp, store in floats);
 * where a proof needs the unit roundoff (gaussian_dynamic.c's cubic path)
 * it takes RR_UNIT_ROUNDOFF from here. The bound tests (test_accel.c,
 * test_gaussian_dynamic.c, test_gaussian_hit.c, test_exact.c) check that
 * each bound holds what it bounds. */
#ifndef RR_INTERVAL_H
#define RR_INTERVAL_H

#include <float.h>
#include <math.h>

typedef struct {
    double lo, hi;
} interval;

/* The unit roundoff u of doubles: every +, -, *, / and sqrt returns the
 * exact result times (1 + d), |d| <= u (Higham, Accuracy and Stability of
 * Numerical Algorithms, sec. 2.2), plus, only for results below DBL_MIN,
 * an absolute error of at most DBL_TRUE_MIN. */
#define RR_UNIT_ROUNDOFF (DBL_EPSILON / 2)

static inline interval interval_make(double lo, double hi) { return (interval){lo, hi}; }

/* [c - r, c + r] */
static inline interval interval_around(double c, double r) { return (interval){c - r, c + r}; }

/* a grown by pad (>= 0) at both ends: pad is the caller's room for the
 * rounding it proved (or, for ray_meets_box, far above it). */
static inline interval interval_widen(interval a, double pad) { return (interval){a.lo - pad, a.hi + pad}; }

/* a grown by rel times its width and magnitude plus abs: a room far above
 * the rounding of anything computed from a's ends. */
static inline interval interval_widen_rel(interval a, double rel, double abs)
{
    return interval_widen(a, rel * (a.hi - a.lo + fabs(a.lo) + fabs(a.hi)) + abs);
}

/* The room a box of half-width reach about centre leaves for being stored
 * in floats and traversed by float code (24-bit mantissas: 6e-8
 * relatively, so 1e-5 of the reach and 1e-6 of the centre hold it with
 * room; 1e-30 for a zero reach at the origin). */
static inline double interval_float_room(double reach, double centre)
{
    return reach * 1e-5 + 1e-6 * fabs(centre) + 1e-30;
}

/* a with each end one double step outward: the exact value of an operation
 * whose rounded result is an end lies within half a step of it. */
static inline interval interval_step_out(interval a)
{
    return (interval){nextafter(a.lo, -INFINITY), nextafter(a.hi, INFINITY)};
}

/* x rounded outward to a float, for bounds kept in floats (Embree's boxes):
 * the cast rounds to the nearest float, which may lie on either side of x,
 * so one more step out makes the result strictly below (above) x. */
static inline float rr_float_below(double x) { return nextafterf((float)x, -INFINITY); }
static inline float rr_float_above(double x) { return nextafterf((float)x, INFINITY); }

/* a's ends rounded outward to floats: the float interval holds a. */
static inline void interval_round_out_f(interval a, float *lo, float *hi)
{
    *lo = rr_float_below(a.lo);
    *hi = rr_float_above(a.hi);
}

#endif
