#include "motion/curve.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

int tangent_from_name(const char *name, tangent_kind *k)
{
    static const struct {
        const char *name;
        tangent_kind kind;
    } names[] = {{"linear", TAN_LINEAR},   {"flat", TAN_FLAT},       {"spline", TAN_SPLINE},
                 {"clamped", TAN_CLAMPED}, {"plateau", TAN_PLATEAU}, {"auto", TAN_AUTO},
                 {"fixed", TAN_FIXED},     {"step", TAN_STEP},       {"stepnext", TAN_STEPNEXT},
                 {"slow", TAN_LINEAR},     {"fast", TAN_LINEAR}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(name, names[i].name)) {
            *k = names[i].kind;
            return 0;
        }
    return -1;
}

int infinity_from_name(const char *name, infinity_kind *k)
{
    static const char *const names[] = {"constant", "linear", "cycle", "cycleRelative", "oscillate"};
    _Static_assert(sizeof names / sizeof *names == INFINITY_KIND_COUNT, "an infinity mode without its name");
    for (int i = 0; i < INFINITY_KIND_COUNT; i++)
        if (!strcmp(name, names[i])) {
            *k = (infinity_kind)i;
            return 0;
        }
    return -1;
}

/* Slope of the straight line from key i to key i + 1. */
static double secant(const curve *c, int i)
{
    const curve_key *a = &c->keys[i], *b = &c->keys[i + 1];
    return (b->value - a->value) / (b->time - a->time);
}

static double spline_slope(const curve *c, int i)
{
    int n = c->count;
    if (n == 1)
        return 0.0;
    if (i == 0)
        return secant(c, 0);
    if (i == n - 1)
        return secant(c, n - 2);
    const curve_key *p = &c->keys[i - 1], *q = &c->keys[i + 1];
    return (q->value - p->value) / (q->time - p->time);
}

/* The spline slope limited to 3x the smaller adjacent secant and 0 at an
 * extremum (animx autoTangent: the handles then stay within the
 * neighbours' values); *limited says whether the limit applied. */
static double limited_slope(const curve *c, int i, int *limited)
{
    *limited = 1;
    if (i == 0 || i == c->count - 1)
        return 0.0; /* no neighbour on one side: flat */
    double a = secant(c, i - 1), b = secant(c, i);
    if (a * b <= 0)
        return 0.0;
    double m = spline_slope(c, i), limit = 3.0 * fmin(fabs(a), fabs(b));
    *limited = fabs(m) > limit;
    return *limited ? copysign(limit, a) : m;
}

/* animEngine's clamped: flat when the key's value is within clamp_flat of
 * a neighbour's (a missing neighbour on the tangent's own side leaves the
 * spline slope; on the other side it counts as the same distance). */
static double clamped_slope(const curve *c, int i, int outgoing)
{
    int n = c->count;
    if (n == 1 || (outgoing ? i == n - 1 : i == 0))
        return spline_slope(c, i);
    double v = c->keys[i].value;
    double near = fabs(c->keys[outgoing ? i + 1 : i - 1].value - v);
    int other = outgoing ? i - 1 : i + 1;
    double far = other >= 0 && other < n ? fabs(c->keys[other].value - v) : near;
    return fmin(near, far) <= c->clamp_flat ? 0.0 : spline_slope(c, i);
}

static double tangent_slope(const curve *c, int i, tangent_kind kind, double angle, int outgoing)
{
    int n = c->count, limited;
    switch (kind) {
    case TAN_LINEAR:
        if (n == 1)
            return 0.0;
        if (outgoing)
            return secant(c, i < n - 1 ? i : n - 2);
        return secant(c, i > 0 ? i - 1 : 0);
    case TAN_SPLINE:
        return spline_slope(c, i);
    case TAN_CLAMPED:
        return clamped_slope(c, i, outgoing);
    case TAN_AUTO:
        return limited_slope(c, i, &limited);
    case TAN_PLATEAU: {
        double m = limited_slope(c, i, &limited);
        return limited ? 0.0 : m;
    }
    case TAN_FIXED:
        return tan(angle);
    default: /* flat, step, stepnext */
        return 0.0;
    }
}

/* A computed tangent's handle on a weighted curve: a third of the interval
 * to the neighbouring key on its side (the other side's at the ends); a
 * step in-tangent has none (animEngine). */
static double computed_handle(const curve *c, int i, int outgoing)
{
    int n = c->count;
    if (n == 1 || (!outgoing && c->keys[i].in == TAN_STEP))
        return 0.0;
    int j = outgoing ? (i < n - 1 ? i : i - 1) : (i > 0 ? i - 1 : i);
    return (c->keys[j + 1].time - c->keys[j].time) / 3.0;
}

static int check_key(const curve *c, int i, rr_error *err)
{
    const curve_key *k = &c->keys[i];
    if (!isfinite(k->time) || !isfinite(k->value) || !isfinite(k->in_angle) || !isfinite(k->out_angle) ||
        !isfinite(k->in_handle) || !isfinite(k->out_handle))
        return rr_fail(err, "key %d has a NaN or infinite value", i + 1);
    if (i > 0 && !(k->time > c->keys[i - 1].time))
        return rr_fail(err, "key %d: time %g is not after the previous key's %g", i + 1, k->time,
                       c->keys[i - 1].time);
    if ((k->in == TAN_FIXED && fabs(k->in_angle) >= M_PI / 2) ||
        (k->out == TAN_FIXED && fabs(k->out_angle) >= M_PI / 2))
        return rr_fail(err, "key %d: a fixed tangent angle must lie strictly between -90 and 90 degrees", i + 1);
    if (k->in_handle < 0 || k->out_handle < 0)
        return rr_fail(err, "key %d: a tangent weight must not be negative", i + 1);
    return 0;
}

/* A quadratic c0 + c1 u + c2 u^2 and its range over [lo, hi] (at the ends
 * or the vertex). */
typedef struct {
    double c0, c1, c2;
} quadratic;

static double quadratic_at(quadratic q, double u) { return q.c0 + u * (q.c1 + u * q.c2); }

static void quadratic_range(quadratic q, double lo, double hi, double *min, double *max)
{
    double a = quadratic_at(q, lo), b = quadratic_at(q, hi);
    *min = fmin(a, b), *max = fmax(a, b);
    if (q.c2 != 0) {
        double u = -q.c1 / (2 * q.c2);
        if (u > lo && u < hi)
            *min = fmin(*min, quadratic_at(q, u)), *max = fmax(*max, quadratic_at(q, u));
    }
}

/* The derivative of a cubic Bezier with control steps d0, d1, d2, over 3:
 * d0 (1-u)^2 + 2 d1 u (1-u) + d2 u^2, with a factor u (drop_u) or 1 - u
 * (drop_v) divided out where both coordinates share it (a zero handle). */
static quadratic bezier_slope(double d0, double d1, double d2, int drop_u, int drop_v)
{
    if (drop_u && drop_v)
        return (quadratic){2 * d1, 0, 0};
    if (drop_u)
        return (quadratic){2 * d1, d2 - 2 * d1, 0};
    if (drop_v)
        return (quadratic){d0, 2 * d1 - d0, 0};
    return (quadratic){d0, 2 * (d1 - d0), d0 - 2 * d1 + d2};
}

/* A weighted segment as a Bezier in the (time, value) plane, time
 * normalized to [0, 1] over the segment: controls (0, y0) (x1, y1)
 * (x2, y2) (1, y3). */
typedef struct {
    double x1, x2, y0, y1, y2, y3;
} bezier_span;

static bezier_span weighted_span(const curve *c, int i)
{
    const curve_key *a = &c->keys[i], *b = &c->keys[i + 1];
    double h = b->time - a->time;
    bezier_span z = {a->out_handle / h, 1 - b->in_handle / h, a->value, a->value + a->out_slope * a->out_handle,
                     b->value - b->in_slope * b->in_handle, b->value};
    return z;
}

static double bezier_at(double p0, double p1, double p2, double p3, double u)
{
    double v = 1 - u; /* de Casteljau */
    double q0 = v * p0 + u * p1, q1 = v * p1 + u * p2, q2 = v * p2 + u * p3;
    double r0 = v * q0 + u * q1, r1 = v * q1 + u * q2;
    return v * r0 + u * r1;
}

/* The parameter u where the span's time is s: time is monotonic
 * (curve_prepare refuses handles for which it is not), so Newton steps
 * kept inside a shrinking bracket converge to it. */
static double solve_time(const bezier_span *z, double s)
{
    double lo = 0, hi = 1, u = s;
    for (int it = 0; it < 100 && hi - lo > 4 * DBL_EPSILON; it++) {
        double f = bezier_at(0, z->x1, z->x2, 1, u) - s;
        if (f == 0)
            return u;
        if (f < 0)
            lo = u;
        else
            hi = u;
        double d = 3 * quadratic_at(bezier_slope(z->x1, z->x2 - z->x1, 1 - z->x2, 0, 0), u);
        double next = u - f / d;
        u = d > 0 && next > lo && next < hi ? next : 0.5 * (lo + hi);
    }
    return u;
}

static double bezier_value(const curve *c, int i, double t)
{
    const curve_key *a = &c->keys[i], *b = &c->keys[i + 1];
    bezier_span z = weighted_span(c, i);
    double u = solve_time(&z, (t - a->time) / (b->time - a->time));
    return bezier_at(z.y0, z.y1, z.y2, z.y3, u);
}

/* Segment i (keys i, i+1) at time t inside it: cubic Hermite or Bezier,
 * or held. */
static double segment_value(const curve *c, int i, double t)
{
    const curve_key *a = &c->keys[i], *b = &c->keys[i + 1];
    if (a->out == TAN_STEP)
        return a->value;
    if (a->out == TAN_STEPNEXT) /* the key's own value at its time only */
        return t == a->time ? a->value : b->value;
    double h = b->time - a->time, u = (t - a->time) / h;
    if (a->out == TAN_LINEAR && b->in == TAN_LINEAR) /* the Hermite form, evaluated exactly */
        return a->value + (b->value - a->value) * u;
    if (c->weighted)
        return bezier_value(c, i, t);
    double u2 = u * u, u3 = u2 * u;
    return (2 * u3 - 3 * u2 + 1) * a->value + (u3 - 2 * u2 + u) * h * a->out_slope +
           (-2 * u3 + 3 * u2) * b->value + (u3 - u2) * h * b->in_slope;
}

/* Within [t_0, t_n]: the segment holding t; with `left`, a key time belongs
 * to the segment that ends there. */
static double inside_value(const curve *c, double t, int left)
{
    int lo = 0, hi = c->count - 1; /* find the segment [keys[lo], keys[lo+1]] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (left ? c->keys[mid].time < t : c->keys[mid].time <= t)
            lo = mid;
        else
            hi = mid;
    }
    if (!left && t >= c->keys[c->count - 1].time)
        return c->keys[c->count - 1].value;
    if (left && t <= c->keys[0].time)
        return c->keys[0].value;
    return segment_value(c, lo, t);
}

static double eval_at(const curve *c, double t, int left)
{
    if (c->count == 0)
        return 0.0;
    const curve_key *first = &c->keys[0], *last = &c->keys[c->count - 1];
    double t0 = first->time, tn = last->time, span = tn - t0;
    if (c->count == 1) { /* no span to cycle: constant or the key's slopes */
        if (t < t0 && c->pre == INF_LINEAR)
            return first->value + first->in_slope * (t - t0);
        if (t > t0 && c->post == INF_LINEAR)
            return first->value + first->out_slope * (t - t0);
        return first->value;
    }
    int before = left ? t <= t0 : t < t0, after = left ? t > tn : t >= tn;
    if ((!before && !after) || (after && t == tn))
        return inside_value(c, t, left);
    infinity_kind mode = before ? c->pre : c->post;
    if (mode == INF_CONSTANT)
        return before ? first->value : last->value;
    if (mode == INF_LINEAR)
        return before ? first->value + first->in_slope * (t - t0) : last->value + last->out_slope * (t - tn);
    /* cycles: bring t into the keyed range; k counts whole spans moved */
    double k = left ? ceil((t - tn) / span) : floor((t - t0) / span);
    double local = t - k * span;
    if (mode == INF_OSCILLATE && fmod(fabs(k), 2.0) == 1.0)
        return inside_value(c, t0 + tn - local, !left);
    double offset = mode == INF_CYCLE_RELATIVE ? k * (last->value - first->value) : 0.0;
    return inside_value(c, local, left) + offset;
}

double curve_eval(const curve *c, double t) { return eval_at(c, t, 0); }
double curve_eval_left(const curve *c, double t) { return eval_at(c, t, 1); }

/* max |dv/dt| = max |Y'(u)| / (h X'(u)) over a weighted segment, bounded
 * piece by piece by the largest |Y'| over the smallest X' on each. */
static double bezier_max_slope(const curve *c, int i)
{
    enum { PIECES = 256 };
    bezier_span z = weighted_span(c, i);
    double h = c->keys[i + 1].time - c->keys[i].time;
    int drop_u = z.x1 == 0 && z.y1 == z.y0, drop_v = z.x2 == 1 && z.y2 == z.y3;
    quadratic x = bezier_slope(z.x1, z.x2 - z.x1, 1 - z.x2, drop_u, drop_v);
    quadratic y = bezier_slope(z.y1 - z.y0, z.y2 - z.y1, z.y3 - z.y2, drop_u, drop_v);
    double m = 0;
    for (int p = 0; p < PIECES; p++) {
        double xlo, xhi, ylo, yhi;
        quadratic_range(x, (double)p / PIECES, (double)(p + 1) / PIECES, &xlo, &xhi);
        quadratic_range(y, (double)p / PIECES, (double)(p + 1) / PIECES, &ylo, &yhi);
        double rise = fmax(fabs(ylo), fabs(yhi));
        if (rise > 0)
            m = fmax(m, xlo > 0 ? rise / (h * xlo) : INFINITY);
    }
    return m;
}

/* An unweighted segment as a Bezier in u = (t - t_a) / h: dv/du = 3 (d0
 * (1-u)^2 + 2 d1 u (1-u) + d2 u^2) with the control steps d_i, a quadratic
 * whose largest magnitude on [0, 1] is at an end or at its vertex. */
static double hermite_max_slope(const curve *c, int i)
{
    const curve_key *a = &c->keys[i], *b = &c->keys[i + 1];
    double h = b->time - a->time;
    double p1 = a->value + h * a->out_slope / 3, p2 = b->value - h * b->in_slope / 3;
    double lo, hi;
    quadratic_range(bezier_slope(p1 - a->value, p2 - p1, b->value - p2, 0, 0), 0, 1, &lo, &hi);
    return 3.0 * fmax(fabs(lo), fabs(hi)) / h;
}

static double segment_max_slope(const curve *c, int i)
{
    const curve_key *a = &c->keys[i], *b = &c->keys[i + 1];
    if (a->out == TAN_STEP || a->out == TAN_STEPNEXT)
        return 0.0;
    if (a->out == TAN_LINEAR && b->in == TAN_LINEAR)
        return fabs(secant(c, i));
    return (c->weighted ? bezier_max_slope(c, i) : hermite_max_slope(c, i)) * (1 + 1e-12);
}

/* The slope bound over the segments and a linear infinity's line; NAN
 * (with *bad the segment) when a weighted segment's value changes
 * infinitely fast. */
static double slope_bound(const curve *c, int *bad)
{
    double m = 0;
    for (int i = 0; i + 1 < c->count; i++) {
        double s = segment_max_slope(c, i);
        if (c->weighted && !(s < 1e12))
            return *bad = i, NAN;
        m = fmax(m, s);
    }
    if (c->pre == INF_LINEAR)
        m = fmax(m, fabs(c->keys[0].in_slope));
    if (c->post == INF_LINEAR)
        m = fmax(m, fabs(c->keys[c->count - 1].out_slope));
    return m;
}

double curve_max_slope(const curve *c) { return c->max_slope; }

int curve_prepare(curve *c, rr_error *err)
{
    if (c->count < 1)
        return rr_fail(err, "an animation curve needs at least one key");
    for (int i = 0; i < c->count; i++)
        if (check_key(c, i, err))
            return -1;
    for (int i = 0; i < c->count; i++) {
        curve_key *k = &c->keys[i];
        k->in_slope = tangent_slope(c, i, k->in, k->in_angle, 0);
        k->out_slope = tangent_slope(c, i, k->out, k->out_angle, 1);
        if (k->in != TAN_FIXED)
            k->in_handle = computed_handle(c, i, 0);
        if (k->out != TAN_FIXED)
            k->out_handle = computed_handle(c, i, 1);
    }
    int bad = 0;
    c->max_slope = slope_bound(c, &bad);
    if (isnan(c->max_slope))
        return rr_fail(err, "keys %d and %d: the tangent weights give the segment a vertical tangent "
                            "(its value would change infinitely fast); shorten a handle",
                       bad + 1, bad + 2);
    return 0;
}

int curve_append(curve *c, const curve_key *k)
{
    if (c->count > 0 && !(k->time > c->keys[c->count - 1].time))
        return -1;
    curve_key *grown = realloc(c->keys, (size_t)(c->count + 1) * sizeof *grown);
    if (!grown)
        return -2;
    c->keys = grown;
    c->keys[c->count++] = *k;
    return 0;
}

void curve_free(curve *c)
{
    free(c->keys);
    c->keys = NULL;
    c->count = 0;
}

int curve_is_continuous(const curve *c)
{
    for (int i = 0; i + 1 < c->count; i++)
        if ((c->keys[i].out == TAN_STEP || c->keys[i].out == TAN_STEPNEXT) && c->keys[i].value != c->keys[i + 1].value)
            return 0;
    int cycles = c->pre == INF_CYCLE || c->post == INF_CYCLE;
    return !(cycles && c->count > 1 && c->keys[0].value != c->keys[c->count - 1].value);
}
