/* Keyed animation curves: one scalar channel over time, as Maya's animCurve
 * defines them (thesis sec. 4.6: keyframes "interpolated linearly or by
 * cubic splines"). The reference is Autodesk's animx library, which
 * evaluates curves "in the exact same way as Maya"; where animx takes a
 * tangent from a running Maya instead of computing it (clamped, plateau,
 * slow, fast), Autodesk's devkit animEngine sample is.
 *
 * Between two keys an unweighted curve is a cubic Hermite segment in time,
 * shaped by the first key's out-tangent and the second key's in-tangent
 * slope. A weighted curve is a cubic Bezier in the (time, value) plane
 * whose inner control points sit at key +- handle (animx: key +- tan/3), so
 * time is solved for (a cubic) before the value is read. Handles so long
 * that time would stand still or run backwards are refused: animx's
 * Tbezier shortens them until the tangent is vertical, and a value that
 * changes infinitely fast has no motion bound. A step out-tangent holds
 * the value instead.
 *
 * Tangent slopes (value units per time unit), with p/n the previous/next key:
 *   linear   in: secant to p, out: secant to n (slow and fast, which Maya
 *            calls obsolete, are read as linear: animEngine's rule)
 *   flat     0
 *   spline   (v_n - v_p) / (t_n - t_p)  (Catmull-Rom; C1 across the key);
 *            at the first/last key the one-sided secant
 *   clamped  flat when a neighbouring value is within clamp_flat of the
 *            key's (Maya: 0.05 internal units), else spline (animEngine)
 *   auto     the spline slope limited to 3x the smaller adjacent secant, 0
 *            at a local extremum and at the first and last key (animx's
 *            autoTangent), so the handles never pass a neighbour's value
 *   plateau  spline, but flat wherever auto would limit it, at extrema and
 *            at the first and last key (animEngine)
 *   fixed    tan(angle), the angle given with the key
 *   step     out: the segment keeps the first key's value up to the next
 *            key; in: slope 0 (and a zero handle)
 *   stepnext out: the segment takes the next key's value right away
 * Handles on weighted curves: a fixed tangent's comes with the key; every
 * other reaches a third of the interval to the neighbouring key in time
 * (animx's autoTangent and animEngine set the tangent's x to the whole
 * interval), along the slope.
 * Outside the keys, pre/post infinity: constant, linear (the end slope),
 * cycle, cycleRelative (each cycle offset by the end-to-end change) and
 * oscillate (back and forth). */
#ifndef RR_CURVE_H
#define RR_CURVE_H

#include "core/common.h"

typedef enum {
    TAN_LINEAR, TAN_FLAT, TAN_SPLINE, TAN_CLAMPED, TAN_FIXED, TAN_STEP, TAN_STEPNEXT, TAN_AUTO, TAN_PLATEAU
} tangent_kind;

/* (INFINITY_KIND_COUNT, last, is how many: curve.c's names assert it) */
typedef enum {
    INF_CONSTANT, INF_LINEAR, INF_CYCLE, INF_CYCLE_RELATIVE, INF_OSCILLATE, INFINITY_KIND_COUNT
} infinity_kind;

typedef struct {
    double time, value;
    tangent_kind in, out;
    double in_angle, out_angle;   /* TAN_FIXED: radians in the (time, value) plane */
    double in_handle, out_handle; /* weighted curves: how far the tangent's Bezier handle
                                   * reaches in time; given with TAN_FIXED keys, derived
                                   * by curve_prepare for the others */
    double in_slope, out_slope;   /* derived by curve_prepare */
} curve_key;

typedef struct {
    int count;
    curve_key *keys; /* increasing times */
    infinity_kind pre, post;
    int weighted;      /* Bezier segments with handles instead of Hermite */
    double clamp_flat; /* TAN_CLAMPED is flat next to a value this close */
    double max_slope;  /* derived by curve_prepare (curve_max_slope) */
} curve;

/* Parses a tangent or infinity name (as in .anim files and the scene XML).
 * "slow" and "fast" map to TAN_LINEAR. Returns -1 if unknown. */
int tangent_from_name(const char *name, tangent_kind *k);
int infinity_from_name(const char *name, infinity_kind *k);

/* Checks the keys (finite, strictly increasing times, finite handles of at
 * least 0) and computes the tangent slopes and handles. Returns -1 with a
 * reason naming the key, also for weighted handles that give a segment a
 * vertical tangent (a value changing infinitely fast, which no motion bound
 * encloses). */
int curve_prepare(curve *c, rr_error *err);

/* Value at time t; curve_eval_left is the limit from the left (differs at
 * the end of a step segment). A curve without keys is 0. */
double curve_eval(const curve *c, double t);
double curve_eval_left(const curve *c, double t);

/* An upper bound on |dv/dt| wherever the curve is continuous (steps jump;
 * callers sample the key times themselves), computed once by
 * curve_prepare; 0 for a curve without keys. */
double curve_max_slope(const curve *c);

/* 1 when the curve never jumps: no step or stepnext segment between keys
 * of different values, and no cycle infinity between different first and
 * last values (its value then moves at most at curve_max_slope). */
int curve_is_continuous(const curve *c);

/* Appends a key: 0, or -1 when its time is not after the last key's, or
 * -2 when out of memory (the curve is unchanged then). */
int curve_append(curve *c, const curve_key *k);

void curve_free(curve *c);

#endif
