#include "shutter.h"

void shutter_default(shutter *s)
{
    s->open = 0.0;
    s->close = 1.0;
    s->kind = WEIGHT_BOX;
    s->center = 1.0;
    s->rate = 1.0;
    s->table_size = 0;
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
    /* a(t) must not vanish on the whole interval, or no pixel is defined. */
    double sum = 0;
    for (int i = 0; i <= 1000; i++)
        sum += shutter_weight(s, s->open + (s->close - s->open) * i / 1000.0);
    if (!(sum > 0))
        return rr_fail(err, "temporal weight a(t) is zero over the whole shutter interval");
    return 0;
}
