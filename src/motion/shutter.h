/* Shutter interval [open, close] and temporal weight a(t) (thesis eq. 3.1,
 * Figure 3.1): G(x) = integral a(t) g(x,t) dt, estimated as
 * sum a(t_k) g(x, t_k) / sum a(t_k) (thesis sec. 4.5, step 3). */
#ifndef RR_SHUTTER_H
#define RR_SHUTTER_H

#include "core/common.h"

typedef enum { WEIGHT_BOX, WEIGHT_LINEAR, WEIGHT_EXP, WEIGHT_TABLE } weight_kind;

#define SHUTTER_TABLE_MAX 256

/* Rolling shutter (a CMOS sensor's, as 3dgs-deblur and gsplat model it):
 * the sensor's lines, read in turn, are each exposed over their own window.
 * Line r counts along the readout direction (top-to-bottom: r = pixel row
 * y; bottom-to-top: H - 1 - y;
 * left-to-right: column x; right-to-left: W - 1 - x), L lines in all:
 *   lines        [open, close] + delta r, a(t) shifted with it (the general
 *                model: line delay delta, line exposure close - open)
 *   3dgs-deblur  [open, close] + t_ro ((r + 0.5) / L - 1/2): [open, close] is
 *                the middle's window, readoutTime t_ro spans the frame
 *                (3dgs-deblur's gsplat fork 64154bb, forward.cu:360-363)
 *   gsplat       the single instant open + R r / (L - 1), no exposure, the
 *                readout R = close - open (gsplat's and 3DGUT's floor(y) /
 *                (H - 1) between a start and an end pose, gsplat 90d7b4b
 *                Cameras.cuh:504-528; bottom-to-top (H - ceil(y)) / (H - 1)
 *                is the same line count from the bottom for y off the pixel
 *                edges), or R = readoutTime once shutter_at_instant has
 *                shrunk [open, close] to an instant; the camera there is
 *                gsplat's pose between its poses at open and open + R
 *                (scene_for_shutter)
 * Rows and columns are the full image's, whatever the crop window. */
/* (each enum's _COUNT, last, is how many there are: shutter.c's name
 * tables assert they have that many at compile time) */
typedef enum { ROLLING_OFF, ROLLING_LINES, ROLLING_3DGS_DEBLUR, ROLLING_GSPLAT, ROLLING_KIND_COUNT } rolling_kind;
typedef enum {
    READOUT_TOP_TO_BOTTOM, READOUT_BOTTOM_TO_TOP, READOUT_LEFT_TO_RIGHT, READOUT_RIGHT_TO_LEFT, READOUT_DIR_COUNT
} readout_dir;

typedef struct {
    rolling_kind kind;
    readout_dir readout;
    double line_delay;   /* lines: delta */
    double readout_time; /* 3dgs-deblur: t_ro; gsplat: 0 (the readout spans the shutter) or, at an
                          * instant, the readout the shutter spanned */
} rolling_shutter;

typedef struct {
    double open, close;
    rolling_shutter rolling;
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

const char *shutter_rolling_name(rolling_kind k);
const char *shutter_readout_name(readout_dir d);
/* -1 for an unknown name. */
int shutter_rolling_parse(const char *name);
int shutter_readout_parse(const char *name);

/* The line of pixel (x, y) of a width x height image, and how many. */
int shutter_line(const shutter *s, int x, int y, int width, int height, int *lines);

/* The time of a sample drawn at t in [open, close] (a(t)'s distribution)
 * on line `line` of `lines`. Without rolling shutter, t. */
double shutter_line_time(const shutter *s, int line, int lines, double t);

/* A sharp image at t (--time): every line's exposure shrinks to an instant
 * and the readout stays, so line r is seen at t plus its readout offset, as
 * the sensor records a sharp frame: lines t + delta r; 3dgs-deblur t + t_ro
 * ((r + 0.5) / L - 1/2) (t is the middle line's instant); gsplat t + R r /
 * (L - 1) with R the shutter's length, kept as readoutTime. Each preset's
 * shutter [t, t] is then read by its own rule; without a rolling shutter
 * every sample is at t. a(t) becomes a box: an instant has nothing to weigh. */
void shutter_at_instant(shutter *s, double t);

/* Every time any line of a width x height image is exposed: [open, close]
 * without rolling shutter. What the BVHs' swept bounds must cover. */
void shutter_span(const shutter *s, int width, int height, double *t0, double *t1);

/* The rolling shutter as text, for the EXR identity ("off", or the kind,
 * readout and its parameters with every digit). */
void shutter_rolling_text(const shutter *s, char *buf, size_t size);

#endif
