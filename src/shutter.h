/* Shutter interval [open, close] and temporal weight a(t) (thesis eq. 3.1,
 * Figure 3.1): G(x) = integral a(t) g(x,t) dt, estimated as
 * sum a(t_k) g(x, t_k) / sum a(t_k) (thesis sec. 4.5, step 3). */
#ifndef RR_SHUTTER_H
#define RR_SHUTTER_H

#include "common.h"

typedef enum { WEIGHT_BOX, WEIGHT_LINEAR, WEIGHT_EXP, WEIGHT_TABLE } weight_kind;

#define SHUTTER_TABLE_MAX 256

typedef struct {
    double open, close;
    weight_kind kind;
    double center; /* linear, exp: weighting center t_c (default: close) */
    double rate;   /* exp: a(t) = exp(-rate |t - t_c|) */
    int table_size;
    double table_t[SHUTTER_TABLE_MAX], table_w[SHUTTER_TABLE_MAX];
} shutter;

void shutter_default(shutter *s);
/* Validates the interval, the parameters and that a(t) is not zero almost
 * everywhere on [open, close]. */
int shutter_check(const shutter *s, rr_error *err);
double shutter_weight(const shutter *s, double t);
const char *shutter_weight_name(weight_kind k);

/* The times where a(t) has a kink or a jump, with open first and close
 * last, increasing: between two of them a(t) is linear (box, linear,
 * table) or one exponential (exp). Returns how many (at most
 * SHUTTER_MAX_KNOTS). */
#define SHUTTER_MAX_KNOTS (SHUTTER_TABLE_MAX + 5)
int shutter_knots(const shutter *s, double knots[SHUTTER_MAX_KNOTS]);

/* Times drawn from a(t) itself: the inverse of its normalised cumulative
 * integral, exact piece by piece (a quadratic on linear pieces, a
 * logarithm on exponential ones). A sampler's uniform time u maps to
 * t = A^-1(u), so the estimate of the a-weighted average (thesis eq. 3.1)
 * is the plain mean of the samples: every sample counts, and no batch can
 * draw only times where a(t) = 0 (the ratio sum a g / sum a was 0/0 there
 * and such batches came out black). */
typedef struct {
    int pieces;
    double knot[SHUTTER_MAX_KNOTS];
    double start[SHUTTER_MAX_KNOTS]; /* a(t) at the piece's start */
    double rate[SHUTTER_MAX_KNOTS];  /* linear: slope; exp: a' / a (0 for a constant piece) */
    double cum[SHUTTER_MAX_KNOTS];   /* integral of a from open to the piece's start */
    int exponential;                 /* the pieces are exponentials (exp weight) */
} shutter_cdf;
void shutter_cdf_init(shutter_cdf *c, const shutter *s);
/* u in [0, 1) -> t in [open, close] with density a(t) / integral of a. */
double shutter_cdf_time(const shutter_cdf *c, double u);

#endif
