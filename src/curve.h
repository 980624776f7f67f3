/* Keyed animation curves: one scalar channel over time, as Maya's animCurve
 * defines them (thesis sec. 4.6: keyframes "interpolated linearly or by
 * cubic splines"). Between two keys the curve is a cubic Hermite segment in
 * time, shaped by the first key's out-tangent and the second key's
 * in-tangent slope; a step out-tangent holds the value instead.
 *
 * Tangent slopes (value units per time unit), with p/n the previous/next key:
 *   linear   in: secant to p, out: secant to n
 *   flat     0
 *   spline   (v_n - v_p) / (t_n - t_p)  (Catmull-Rom; C1 across the key);
 *            at the first/last key the one-sided secant
 *   clamped, plateau
 *            the spline slope, but 0 at a local extremum (or next to an equal
 *            value), and at most 3x the smaller adjacent secant so the
 *            segment never overshoots its keys (Fritsch-Carlson)
 *   auto     as clamped between keys, but flat (0) at the first and the last
 *            key (Autodesk animx's autoTangent, which computes auto tangents
 *            "in the exact same way as Maya")
 *   fixed    tan(angle), the angle given with the key
 *   step     out: the segment keeps the first key's value up to the next key
 *   stepnext out: the segment takes the next key's value right away
 * Outside the keys, pre/post infinity: constant, linear (the end slope),
 * cycle, cycleRelative (each cycle offset by the end-to-end change) and
 * oscillate (back and forth). */
#ifndef RR_CURVE_H
#define RR_CURVE_H

#include "common.h"

typedef enum {
    TAN_LINEAR, TAN_FLAT, TAN_SPLINE, TAN_CLAMPED, TAN_FIXED, TAN_STEP, TAN_STEPNEXT, TAN_AUTO
} tangent_kind;

typedef enum { INF_CONSTANT, INF_LINEAR, INF_CYCLE, INF_CYCLE_RELATIVE, INF_OSCILLATE } infinity_kind;

typedef struct {
    double time, value;
    tangent_kind in, out;
    double in_angle, out_angle; /* TAN_FIXED: radians in the (time, value) plane */
    double in_slope, out_slope; /* derived by curve_prepare */
} curve_key;

typedef struct {
    int count;
    curve_key *keys; /* increasing times */
    infinity_kind pre, post;
} curve;

/* Parses a tangent or infinity name (as in .anim files and the scene XML).
 * "plateau" maps to TAN_CLAMPED. Returns -1 if unknown. */
int tangent_from_name(const char *name, tangent_kind *k);
int infinity_from_name(const char *name, infinity_kind *k);

/* Checks the keys (finite, strictly increasing times) and computes the
 * tangent slopes. Returns -1 with a reason naming the key. */
int curve_prepare(curve *c, rr_error *err);

/* Value at time t; curve_eval_left is the limit from the left (differs at
 * the end of a step segment). A curve without keys is 0. */
double curve_eval(const curve *c, double t);
double curve_eval_left(const curve *c, double t);

/* An upper bound on |dv/dt| wherever the curve is continuous (steps jump;
 * callers sample the key times themselves). */
double curve_max_slope(const curve *c);

/* Appends a key: 0, or -1 when its time is not after the last key's, or
 * -2 when out of memory (the curve is unchanged then). */
int curve_append(curve *c, const curve_key *k);

void curve_free(curve *c);

#endif
