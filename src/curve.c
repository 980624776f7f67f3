#include "curve.h"

#include <stdlib.h>
#include <string.h>

int tangent_from_name(const char *name, tangent_kind *k)
{
    static const struct {
        const char *name;
        tangent_kind kind;
    } names[] = {{"linear", TAN_LINEAR}, {"flat", TAN_FLAT},       {"spline", TAN_SPLINE},
                 {"clamped", TAN_CLAMPED}, {"plateau", TAN_CLAMPED}, {"auto", TAN_AUTO},
                 {"fixed", TAN_FIXED},   {"step", TAN_STEP},       {"stepnext", TAN_STEPNEXT}};
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
    for (int i = 0; i < 5; i++)
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

/* Spline slope that never makes the neighbouring segments overshoot:
 * flat at extrema, else limited to 3x the smaller secant (Fritsch-Carlson). */
static double clamped_slope(const curve *c, int i)
{
    int n = c->count;
    if (n == 1)
        return 0.0;
    if (i == 0 || i == n - 1)
        return spline_slope(c, i);
    double a = secant(c, i - 1), b = secant(c, i);
    if (a * b <= 0)
        return 0.0;
    double m = spline_slope(c, i), limit = 3.0 * fmin(fabs(a), fabs(b));
    return fabs(m) > limit ? copysign(limit, a) : m;
}

static double tangent_slope(const curve *c, int i, tangent_kind kind, double angle, int outgoing)
{
    int n = c->count;
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
        return clamped_slope(c, i);
    case TAN_AUTO: /* animx autoTangent: a key without a neighbour on either side is flat */
        return i == 0 || i == n - 1 ? 0.0 : clamped_slope(c, i);
    case TAN_FIXED:
        return tan(angle);
    default: /* flat, step, stepnext */
        return 0.0;
    }
}

int curve_prepare(curve *c, rr_error *err)
{
    if (c->count < 1)
        return rr_fail(err, "an animation curve needs at least one key");
    for (int i = 0; i < c->count; i++) {
        curve_key *k = &c->keys[i];
        if (!isfinite(k->time) || !isfinite(k->value) || !isfinite(k->in_angle) || !isfinite(k->out_angle))
            return rr_fail(err, "key %d has a NaN or infinite value", i + 1);
        if (i > 0 && !(k->time > c->keys[i - 1].time))
            return rr_fail(err, "key %d: time %g is not after the previous key's %g", i + 1, k->time,
                           c->keys[i - 1].time);
        if ((k->in == TAN_FIXED && fabs(k->in_angle) >= M_PI / 2) ||
            (k->out == TAN_FIXED && fabs(k->out_angle) >= M_PI / 2))
            return rr_fail(err, "key %d: a fixed tangent angle must lie strictly between -90 and 90 degrees", i + 1);
    }
    for (int i = 0; i < c->count; i++) {
        curve_key *k = &c->keys[i];
        k->in_slope = tangent_slope(c, i, k->in, k->in_angle, 0);
        k->out_slope = tangent_slope(c, i, k->out, k->out_angle, 1);
    }
    return 0;
}

/* Segment i (keys i, i+1) at time t inside it: cubic Hermite, or held. */
static double segment_value(const curve *c, int i, double t)
{
    const curve_key *a = &c->keys[i], *b = &c->keys[i + 1];
    if (a->out == TAN_STEP)
        return a->value;
    if (a->out == TAN_STEPNEXT) /* the key's own value at its time only */
        return t == a->time ? a->value : b->value;
    double h = b->time - a->time, u = (t - a->time) / h, u2 = u * u, u3 = u2 * u;
    if (a->out == TAN_LINEAR && b->in == TAN_LINEAR) /* the Hermite form, evaluated exactly */
        return a->value + (b->value - a->value) * u;
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

double curve_max_slope(const curve *c)
{
    double m = 0;
    for (int i = 0; i + 1 < c->count; i++) {
        const curve_key *a = &c->keys[i], *b = &c->keys[i + 1];
        if (a->out == TAN_STEP || a->out == TAN_STEPNEXT)
            continue;
        /* The segment as a Bezier in u = (t - t_a) / h: dv/du = 3 (d0 (1-u)^2 +
         * 2 d1 u (1-u) + d2 u^2) with the control steps d_i, a quadratic whose
         * largest magnitude on [0, 1] is at an end or at its vertex. */
        double h = b->time - a->time;
        double p1 = a->value + h * a->out_slope / 3, p2 = b->value - h * b->in_slope / 3;
        double d0 = p1 - a->value, d1 = p2 - p1, d2 = b->value - p2;
        double qa = d0 - 2 * d1 + d2, qb = 2 * (d1 - d0);
        double q = fmax(fabs(d0), fabs(d2));
        if (qa != 0) {
            double u = -qb / (2 * qa);
            if (u > 0 && u < 1)
                q = fmax(q, fabs(d0 + u * (qb + u * qa)));
        }
        m = fmax(m, 3.0 * q / h * (1 + 1e-12));
    }
    if (c->count > 0) {
        if (c->pre == INF_LINEAR)
            m = fmax(m, fabs(c->keys[0].in_slope));
        if (c->post == INF_LINEAR)
            m = fmax(m, fabs(c->keys[c->count - 1].out_slope));
    }
    return m;
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
