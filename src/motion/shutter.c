#include "motion/shutter.h"

#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void shutter_default(shutter *s)
{
    s->open = 0.0;
    s->close = 1.0;
    s->kind = WEIGHT_BOX;
    s->center = 1.0;
    s->rate = 1.0;
    s->table_size = 0;
    s->rolling = (rolling_shutter){ROLLING_OFF, READOUT_TOP_TO_BOTTOM, 0.0, 0.0};
}

/* ---- rolling shutter ---------------------------------------------------- */

static const char *const ROLLING_NAMES[] = {"off", "lines", "3dgs-deblur", "gsplat"};
static const char *const READOUT_NAMES[] = {"top-to-bottom", "bottom-to-top", "left-to-right", "right-to-left"};
_Static_assert(sizeof ROLLING_NAMES / sizeof *ROLLING_NAMES == ROLLING_KIND_COUNT, "a rolling kind without its name");
_Static_assert(sizeof READOUT_NAMES / sizeof *READOUT_NAMES == READOUT_DIR_COUNT, "a readout without its name");

const char *shutter_rolling_name(rolling_kind k) { return ROLLING_NAMES[k]; }
const char *shutter_readout_name(readout_dir d) { return READOUT_NAMES[d]; }

static int name_index(const char *const *names, int n, const char *name)
{
    for (int i = 0; i < n; i++)
        if (!strcmp(names[i], name))
            return i;
    return -1;
}

int shutter_rolling_parse(const char *name) { return name_index(ROLLING_NAMES, ROLLING_KIND_COUNT, name); }
int shutter_readout_parse(const char *name) { return name_index(READOUT_NAMES, READOUT_DIR_COUNT, name); }

int shutter_line(const shutter *s, int x, int y, int width, int height, int *lines)
{
    readout_dir d = s->rolling.readout;
    int rows = d == READOUT_TOP_TO_BOTTOM || d == READOUT_BOTTOM_TO_TOP;
    *lines = rows ? height : width;
    if (rows)
        return d == READOUT_TOP_TO_BOTTOM ? y : height - 1 - y;
    return d == READOUT_LEFT_TO_RIGHT ? x : width - 1 - x;
}

double shutter_line_time(const shutter *s, int line, int lines, double t)
{
    const rolling_shutter *r = &s->rolling;
    switch (r->kind) {
    case ROLLING_LINES:
        return t + r->line_delay * line;
    case ROLLING_3DGS_DEBLUR:
        return t + r->readout_time * ((line + 0.5) / lines - 0.5);
    case ROLLING_GSPLAT: { /* the fraction first: no overflow */
        double readout = r->readout_time != 0 ? r->readout_time : s->close - s->open;
        return lines > 1 ? s->open + readout * ((double)line / (lines - 1)) : s->open;
    }
    default:
        return t;
    }
}

void shutter_at_instant(shutter *s, double t)
{
    if (s->rolling.kind == ROLLING_GSPLAT && s->rolling.readout_time == 0)
        s->rolling.readout_time = s->close - s->open; /* its readout spanned the shutter */
    s->open = s->close = t, s->kind = WEIGHT_BOX;
}

void shutter_span(const shutter *s, int width, int height, double *t0, double *t1)
{
    int lines;
    shutter_line(s, 0, 0, width, height, &lines);
    /* each line's time is monotone in the line: the ends bound every line */
    double a = shutter_line_time(s, 0, lines, s->open), b = shutter_line_time(s, lines - 1, lines, s->open);
    double c = shutter_line_time(s, 0, lines, s->close), d = shutter_line_time(s, lines - 1, lines, s->close);
    *t0 = fmin(fmin(a, b), fmin(c, d)), *t1 = fmax(fmax(a, b), fmax(c, d));
}

void shutter_rolling_text(const shutter *s, char *buf, size_t size)
{
    const rolling_shutter *r = &s->rolling;
    if (r->kind == ROLLING_OFF)
        snprintf(buf, size, "off");
    else
        snprintf(buf, size, "%s %s lineDelay %.17g readoutTime %.17g", ROLLING_NAMES[r->kind],
                 READOUT_NAMES[r->readout], r->line_delay, r->readout_time);
}

const char *shutter_weight_name(weight_kind k)
{
    static const char *const names[] = {"box", "linear", "exp", "table"};
    return names[k];
}

static double table_weight(const shutter *s, double t)
{
    int n = s->table_size;
    if (t <= s->table_t[0])
        return s->table_w[0];
    if (t >= s->table_t[n - 1])
        return s->table_w[n - 1];
    int i = 1;
    while (s->table_t[i] < t)
        i++;
    double t0 = s->table_t[i - 1], t1 = s->table_t[i];
    double f = (t - t0) / (t1 - t0);
    return s->table_w[i - 1] + f * (s->table_w[i] - s->table_w[i - 1]);
}

double shutter_weight(const shutter *s, double t)
{
    switch (s->kind) {
    case WEIGHT_BOX:
        return 1.0;
    case WEIGHT_LINEAR: /* reaches 0 at distance close - open from the center */
        return fmax(0.0, 1.0 - fabs(t - s->center) / (s->close - s->open));
    case WEIGHT_EXP: /* thesis prints 1-exp(-|t_c-t|) but calls it decreasing */
        return exp(-s->rate * fabs(t - s->center));
    case WEIGHT_TABLE:
        return table_weight(s, t);
    }
    return 0.0;
}

int shutter_check(const shutter *s, rr_error *err)
{
    if (!isfinite(s->open) || !isfinite(s->close) || !(s->close > s->open))
        return rr_fail(err, "shutter close (%g) must be greater than open (%g)", s->close, s->open);
    if (!isfinite(s->close - s->open)) /* every time and weight computed from it would overflow */
        return rr_fail(err, "shutter [%g, %g]: its length overflows a double", s->open, s->close);
    /* A subnormal length keeps fewer significant bits than a double's 53: a
     * pixel's stratified instants open + length * u round onto fewer distinct
     * values, and every quotient by the length loses precision. */
    if (s->close - s->open < DBL_MIN)
        return rr_fail(err, "shutter [%g, %g]: its length %g is subnormal (below %g)", s->open, s->close,
                       s->close - s->open, DBL_MIN);
    if (!isfinite(s->center) || !isfinite(s->rate) || s->rate < 0)
        return rr_fail(err, "shutter center must be finite and rate >= 0");
    if (s->kind == WEIGHT_TABLE) {
        if (s->table_size < 1)
            return rr_fail(err, "shutter weight 'table' needs at least one 't w' pair");
        for (int i = 0; i < s->table_size; i++) {
            if (!isfinite(s->table_t[i]) || !isfinite(s->table_w[i]) || s->table_w[i] < 0)
                return rr_fail(err, "shutter table entry %d: weights must be finite and >= 0", i + 1);
            if (i > 0 && !(s->table_t[i] > s->table_t[i - 1]))
                return rr_fail(err, "shutter table times must increase (entry %d)", i + 1);
        }
    }
    const rolling_shutter *r = &s->rolling;
    if (!isfinite(r->line_delay) || !isfinite(r->readout_time))
        return rr_fail(err, "rolling shutter: lineDelay and readoutTime must be finite");
    if (r->kind == ROLLING_GSPLAT && s->kind != WEIGHT_BOX)
        return rr_fail(err, "rolling shutter 'gsplat' exposes each line at one instant: a weight a(t) has nothing "
                            "to weigh (drop 'weight')");
    /* a(t) must not vanish on the whole interval, or no pixel is defined. */
    double sum = 0;
    for (int i = 0; i <= 1000; i++)
        sum += shutter_weight(s, s->open + (s->close - s->open) * i / 1000.0);
    if (!(sum > 0))
        return rr_fail(err, "temporal weight a(t) is zero over the whole shutter interval");
    return 0;
}

int shutter_knots(const shutter *s, double knots[SHUTTER_MAX_KNOTS])
{
    int n = 0;
    double span = s->close - s->open;
    knots[n++] = s->open;
    if (s->kind == WEIGHT_LINEAR || s->kind == WEIGHT_EXP) {
        knots[n++] = s->center;
        if (s->kind == WEIGHT_LINEAR) /* where it reaches 0 */
            knots[n++] = s->center - span, knots[n++] = s->center + span;
    }
    for (int k = 0; s->kind == WEIGHT_TABLE && k < s->table_size; k++)
        knots[n++] = s->table_t[k];
    qsort(knots + 1, (size_t)n - 1, sizeof *knots, cmp_double);
    int m = 0;
    for (int k = 0; k < n; k++) /* inside the shutter, increasing */
        if (knots[k] >= s->open && knots[k] < s->close && (m == 0 || knots[k] > knots[m - 1]))
            knots[m++] = knots[k];
    knots[m++] = s->close;
    return m;
}

/* The integral of a piece of length h starting at value a0 with the given
 * rate, and its inverse (the length x whose integral is r). */
static double piece_integral(int exponential, double a0, double rate, double h)
{
    if (exponential)
        return rate != 0 ? a0 * expm1(rate * h) / rate : a0 * h;
    return a0 * h + 0.5 * rate * h * h;
}

static double piece_inverse(int exponential, double a0, double rate, double r)
{
    if (exponential)
        return rate != 0 ? log1p(rate * r / a0) / rate : r / a0;
    /* a0 x + rate x^2 / 2 = r, in the form without cancellation */
    double root = a0 + sqrt(fmax(0.0, a0 * a0 + 2.0 * rate * r));
    return root > 0 ? 2.0 * r / root : 0.0;
}

void shutter_cdf_init(shutter_cdf *c, const shutter *s)
{
    int n = shutter_knots(s, c->knot);
    c->pieces = n - 1;
    c->exponential = s->kind == WEIGHT_EXP;
    c->cum[0] = 0;
    for (int i = 0; i < c->pieces; i++) {
        double t0 = c->knot[i], t1 = c->knot[i + 1], h = t1 - t0;
        c->start[i] = shutter_weight(s, t0);
        if (c->exponential) /* decreasing away from the center on either side */
            c->rate[i] = t0 >= s->center ? -s->rate : s->rate;
        else /* a(t) is continuous inside the shutter: the slope from the two ends */
            c->rate[i] = (shutter_weight(s, t1) - c->start[i]) / h;
        c->cum[i + 1] = c->cum[i] + piece_integral(c->exponential, c->start[i], c->rate[i], h);
    }
}

double shutter_cdf_time(const shutter_cdf *c, double u)
{
    double r = u * c->cum[c->pieces];
    int lo = 0, hi = c->pieces - 1; /* the piece with cum[i] <= r < cum[i + 1] */
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (c->cum[mid] <= r)
            lo = mid;
        else
            hi = mid - 1;
    }
    while (lo > 0 && !(c->cum[lo + 1] > c->cum[lo])) /* never a piece of zero weight */
        lo--;
    double h = c->knot[lo + 1] - c->knot[lo];
    double x = piece_inverse(c->exponential, c->start[lo], c->rate[lo], r - c->cum[lo]);
    return c->knot[lo] + fmin(fmax(x, 0.0), h);
}
