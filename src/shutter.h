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

#endif
