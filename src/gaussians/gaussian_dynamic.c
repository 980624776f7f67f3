/* What every dynamic kind shares (gaussian_dynamic.h): the one-block
 * allocation, the proved bounds of a cubic and of a linear path, and the
 * reach box of a moving Gaussian. Each kind's own rules live in its file
 * (gaussian_stg.c, gaussian_fdgs.c). */
#include "gaussians/gaussian_dynamic.h"

#include "core/interval.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* The unit roundoff of doubles (core/interval.h), short for the proofs below. */
#define U RR_UNIT_ROUNDOFF

gaussian_dynamic *gaussian_dynamic_alloc(size_t n, size_t size, const gaussian_dynamic_ops *ops,
                                         const gaussian_dynamic_array *arrays, int count)
{
    size_t floats = 0;
    for (int k = 0; k < count; k++)
        floats += arrays[k].width;
    RR_DCHECK(size >= sizeof(gaussian_dynamic) && floats > 0 && ops->free);
    gaussian_dynamic *d = calloc(1, size);
    float *block = n <= SIZE_MAX / (floats * sizeof(float)) ? malloc(n * floats * sizeof(float)) : NULL;
    if (!d || !block) {
        free(d);
        free(block);
        return NULL;
    }
    d->ops = ops, d->block = block;
    size_t offset = 0;
    for (int k = 0; k < count; k++) {
        *(float **)((char *)d + arrays[k].member) = block + offset;
        offset += arrays[k].width * n;
    }
    return d;
}

void gaussian_dynamic_free(gaussian_dynamic *d)
{
    if (d)
        free(d->block);
    free(d);
}

/* ---- a cubic path over a D-interval ---------------------------------------
 *
 * The coordinate is the cubic p(D) = x + m1 D + m2 D^2 + m3 D^3 (c = (x,
 * m1, m2, m3), floats). Its extrema over an interval lie at the interval's
 * ends or where p' = g(D) = A D^2 + B D + C vanishes (A = 3 m3, B = 2 m2,
 * C = m1: exact, as m1..m3 are floats). The box is the hull of
 *   (a) p at the ends a, b of a D-interval holding every D the path takes,
 *   (b) for each span K = [k0, k1] of D proved to hold a root of g (all
 *       roots in [a, b] lie in such spans), p(c) +- h max_K |g|, c the
 *       span's midpoint, h >= |D - c| on K: the mean value theorem;
 *       outside the spans g keeps its sign, so p is monotone between the
 *       ends and the spans and (a), (b) hold every value,
 * padded by 16 eps (M + ov), where M = |x| + |m1| R + |m2| R^2 + |m3| R^3
 * (R = max(|a|, |b|)) and ov the largest (b) term. Why that suffices:
 *   - D interval: the kind computes D = fl(t - c); rounding is
 *     monotone, so for t in [t0, t1] fl(t - c) lies in [fl(t0 - c),
 *     fl(t1 - c)], and so does the exact t - c after one step outward
 *     (nextafter: the rounding error is at most half a step);
 *   - evaluation: gaussian_dynamic_cubic_at rounds each term at most 4 times (D^3 m3: D^2,
 *     D^3, the product, the last sum; x: three sums), so at any |D| <= R
 *     |fl(p(D)) - p(D)| <= gamma_4 M, gamma_4 = 4U / (1 - 4U) < 2.01 eps.
 *     The computed candidates are within gamma_4 M of the exact ones, and
 *     the computed path within gamma_4 M of the exact path: 4.02 eps M;
 *   - (b)'s terms are inflated by 1e-10 (fewer than 20 roundings, each U)
 *     and the sums p(c) +- ov round by at most U (M + ov); M itself is
 *     computed within 6 U. Altogether below 16 eps (M + ov).
 * The spans: see root_spans. */

/* An upper bound on the rounding of fl(g(y)) in Horner form
 * ((A y + B) y + C: at most 4 roundings a term, gamma_4 < 4.01 U; 5 U with
 * the margin for this bound's own rounding, and one DBL_TRUE_MIN an
 * operation for results that underflow). */
static double g_rounding(double A, double B, double C, double y)
{
    return 5 * U * (fabs(A) * y * y + fabs(B) * fabs(y) + fabs(C)) + 4 * DBL_TRUE_MIN;
}

/* The sign of g(y) when the rounding cannot have changed it, else 0. */
static int certain_sign(double A, double B, double C, double y)
{
    double g = (A * y + B) * y + C, e = g_rounding(A, B, C, y);
    return g > e ? 1 : g < -e ? -1 : 0;
}

/* A span around the approximate root r on whose ends g has proved opposite
 * signs (so it holds a root), widening from a few ulps; 0 if none is found
 * (a double root, where g touches 0 without crossing). */
static int bracket(double A, double B, double C, double r, interval *out)
{
    double w = 4 * U * fabs(r) + 4 * DBL_TRUE_MIN;
    for (int k = 0; k < 24 && isfinite(w); k++, w *= 8) {
        double y0 = r - w, y1 = r + w;
        int s0 = certain_sign(A, B, C, y0), s1 = certain_sign(A, B, C, y1);
        if (s0 && s1 && s0 != s1)
            return out->lo = y0, out->hi = y1, 1;
    }
    return 0;
}

/* Spans that hold every real root of g = A D^2 + B D + C (A != 0) from its
 * vertex v = -B / 2A and half-gap d = sqrt(B^2 - 4AC) / 2|A|, each with
 * proved error bounds: fl(v) within 2 U |v| (one division), the
 * discriminant within (2U + U^2)(B^2 + 4|AC|) (three roundings) < eD,
 * sqrt and the division then move d by under 3 U relatively (8 U taken),
 * and the span ends' own two roundings by under 2 U (|v| + d_hi + E).
 * Returns the number of spans (0: g has no real root). */
static int vertex_spans(double A, double B, double C, interval out[2])
{
    double disc = B * B - 4 * A * C, eD = 4 * U * (B * B + 4 * fabs(A * C));
    if (disc + eD < 0)
        return 0;
    double v = -B / (2 * A), two_a = 2 * fabs(A);
    double d_hi = sqrt(disc + eD) / two_a * (1 + 8 * U), d_lo = sqrt(fmax(disc - eD, 0)) / two_a * (1 - 8 * U);
    double E = 6 * U * (fabs(v) + d_hi) + 2 * DBL_TRUE_MIN;
    out[0] = (interval){v - d_hi - E, v - d_lo + E};
    out[1] = (interval){v + d_lo - E, v + d_hi + E};
    return 2;
}

/* Spans holding every real root of g. A linear g's root -C/B is within
 * 2 U of the computed one (one division; 4 U with the span ends'
 * rounding). A quadratic's roots come from the stable formula
 * (q = -(B + sign(B) sqrt(disc)) / 2, roots q/A and C/q), each then
 * bracketed by a proved sign change: two disjoint brackets hold both of
 * g's (at most two) roots. Otherwise, near a double root, the vertex
 * spans (vertex_spans) hold them. */
static int root_spans(double A, double B, double C, interval out[2])
{
    if (A == 0) {
        if (B == 0)
            return 0;
        double r = -C / B, e = 4 * U * fabs(r) + 2 * DBL_TRUE_MIN;
        out[0] = (interval){r - e, r + e};
        return 1;
    }
    double disc = B * B - 4 * A * C;
    if (disc >= 0) {
        double q = -0.5 * (B + copysign(sqrt(disc), B)), r1 = q / A, r2 = q != 0 ? C / q : r1;
        interval s[2];
        if (bracket(A, B, C, fmin(r1, r2), &s[0]) && bracket(A, B, C, fmax(r1, r2), &s[1]) && s[0].hi < s[1].lo)
            return out[0] = s[0], out[1] = s[1], 2;
    }
    return vertex_spans(A, B, C, out);
}

/* The (b) term of the span K = [k0, k1]: p(c) +- ov. */
static void span_extremes(const double c[4], double k0, double k1, double *lo, double *hi, double *ov_max)
{
    double A = 3 * c[3], B = 2 * c[2], C = c[1];
    double mid = 0.5 * k0 + 0.5 * k1, h = fmax(mid - k0, k1 - mid) * (1 + 4 * U);
    double g = fabs((A * mid + B) * mid + C) + g_rounding(A, B, C, mid);
    double slope = 2 * fabs(A) * (fabs(mid) + h) + fabs(B);
    double ov = h * (g + h * slope) * (1 + 1e-10), p = gaussian_dynamic_cubic_at(c, mid);
    *lo = fmin(*lo, p - ov), *hi = fmax(*hi, p + ov), *ov_max = fmax(*ov_max, ov);
}

/* The cubic path's bound over the D-interval D (the proof above). */
int gaussian_dynamic_cubic_bounds(const double c[4], interval D, interval *out)
{
    double pa = gaussian_dynamic_cubic_at(c, D.lo), pb = gaussian_dynamic_cubic_at(c, D.hi), ov = 0;
    double lo = fmin(pa, pb), hi = fmax(pa, pb);
    interval s[2];
    int n = root_spans(3 * c[3], 2 * c[2], c[1], s);
    for (int k = 0; k < n; k++) {
        double k0 = fmax(s[k].lo, D.lo), k1 = fmin(s[k].hi, D.hi);
        if (k0 <= k1)
            span_extremes(c, k0, k1, &lo, &hi, &ov);
    }
    double R = fmax(fabs(D.lo), fabs(D.hi));
    double M = fabs(c[0]) + fabs(c[1]) * R + fabs(c[2]) * R * R + fabs(c[3]) * R * R * R;
    *out = interval_widen(interval_make(lo, hi), 16 * DBL_EPSILON * (M + ov));
    return isfinite(out->lo) && isfinite(out->hi) ? 0 : -1;
}

/* ---- a linear path over a D-interval ---------------------------------------
 *
 * The coordinate x + vel D is linear in D, and as computed,
 * fl(x + fl(vel D)), monotone in D (each rounding is); D = fl(t - c) is
 * monotone in t. So both the exact and the computed path lie between
 * their values at the ends a, b of the D-interval
 * (gaussian_dynamic_offset_interval's step holds the exact t - c too), and
 * the computed ends are within 2 U (|x| + |vel| R) of the exact ones (two
 * roundings), R = max(|a|, |b|): the pad 4 eps (|x| + |vel| R) holds both. */
int gaussian_dynamic_linear_bounds(double x, double vel, interval D, interval *out)
{
    double pa = x + vel * D.lo, pb = x + vel * D.hi;
    double pad = 4 * DBL_EPSILON * (fabs(x) + fabs(vel) * fmax(fabs(D.lo), fabs(D.hi)));
    *out = interval_widen(interval_make(fmin(pa, pb), fmax(pa, pb)), pad);
    return isfinite(out->lo) && isfinite(out->hi) ? 0 : -1;
}

/* Why the box of one static Gaussian suffices (gaussian_dynamic_reach_bounds).
 * At a time t the instant is the static Gaussian G(t): mean mu(t) in
 * [lo, hi], the constant scales s, opacity o(t) <= opacity_max, and the
 * matrix R of q(t). gaussian_view_bounds(G(t)) is mu(t) +- e per axis,
 * e_a the larger of
 *   - the kernel's reach k(o) |row a of R S|, k(o) = sqrt(2 ln(255 o))
 *     growing with o; |row a of R S| <= s_max |row a of R|, and
 *     |row a of R| <= 1 however q turns: q has |q| = 1, or |q| < 1 (STG's
 *     normalize(rot + omega D) below torch's eps), or q = 0, and the unit
 *     formula of q = |q| u is |q|^2 R(u) + (1 - |q|^2) I, a convex
 *     combination of two orthogonal matrices (q in floats: |q| <= 1 +
 *     2^-23);
 *   - the screen footprint's reach, from s_max, the opacity (growing with
 *     it) and the view bound alone (footprint_3d_reach, filter_2d_reach:
 *     not the rotation, not the mean but through v's distance).
 * So the static Gaussian at the origin with scales (s_max, s_max, s_max),
 * no rotation and opacity_max (rounded up to a float, as the instant's
 * opacity is rounded to one) has e_a at least every instant's: the
 * Minkowski sum of [lo, hi] and its box holds every instant's box. Its
 * own padding (1e-5 e) covers |q| up to 1 + 2^-23; the instant's mean,
 * rounded to floats, leaves [lo, hi] by at most 2^-24 |mu|, and the
 * instant's box is padded by 1e-6 |mu| for float rounding: the 2e-6 pad
 * below holds both. */
aabb gaussian_dynamic_reach_bounds(const gaussian_model *m, size_t i, const double lo[3], const double hi[3],
                                   double opacity_max, const gaussian_view_bound *v)
{
    const float *s = &m->scale[3 * i];
    float s_max = fmaxf(s[0], fmaxf(s[1], s[2])), o = (float)opacity_max;
    if (o < opacity_max)
        o = nextafterf(o, INFINITY);
    float mean[3] = {0, 0, 0}, scale[3] = {s_max, s_max, s_max}, rotation[4] = {1, 0, 0, 0};
    gaussian_model one = *m;
    one.count = 1, one.dynamic = NULL, one.sh = NULL;
    one.mean = mean, one.scale = scale, one.rotation = rotation, one.opacity = &o;
    aabb reach = gaussian_view_bounds(&one, 0, v), b;
    double l[3] = {reach.lo.x, reach.lo.y, reach.lo.z}, h[3] = {reach.hi.x, reach.hi.y, reach.hi.z};
    for (int k = 0; k < 3; k++) {
        double pad = 2e-6 * fmax(fabs(lo[k]), fabs(hi[k]));
        l[k] += lo[k] - pad, h[k] += hi[k] + pad;
    }
    b.lo = v3(l[0], l[1], l[2]), b.hi = v3(h[0], h[1], h[2]);
    return b;
}
