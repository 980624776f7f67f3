/* Object (and camera) transforms as functions of time (thesis sec. 4.6,
 * B.2.3): static, linear, rotation, and keyframed.
 *
 * linear/rotation: p_world = R(t) (p_rest - c) + c + v t, with
 *   p_rest = model point + the object's rest offset, R(t) the rotation by
 *   degrees_per_time * t about the axis through c.
 * keyframes: p_world = pivot + T(t) + R(t) S(t) (p_rest - pivot), with
 *   T, the Euler angles and S from keyed curves (curve.h). R = Rz Ry Rx:
 *   the X rotation is applied first, then Y, then Z (Maya's default "xyz"
 *   rotate order). The angles are interpolated as curves (as Maya does),
 *   so R stays a rotation at every time.
 * Objects are never moved: the renderer applies the exact inverse to each
 * ray (thesis B.2.3 TransformRay). */
#ifndef RR_ANIMATION_H
#define RR_ANIMATION_H

#include "core/common.h"
#include "motion/curve.h"
#include "core/rotation.h"

struct trajectory; /* trajectory.h: an animation only holds one */

enum { CH_TX, CH_TY, CH_TZ, CH_RX, CH_RY, CH_RZ, CH_SX, CH_SY, CH_SZ, CH_COUNT };

/* Keyed channels; a channel without keys holds 0 (translate, rotate) or 1
 * (scale). Times in scene time, translate in scene units, rotate in
 * radians. */
typedef struct {
    curve ch[CH_COUNT];
    vec3 pivot;
} keyframes;

/* How close a neighbouring key's value makes a clamped tangent flat on
 * channel ch: Maya's 0.05 in its internal units (centimeters, radians,
 * scale), here in scene units (translation taken as meters, as .anim files
 * are read). */
double keyframes_clamp_flat(int ch);

typedef struct {
    vec3 offset;          /* rest position offset applied to model points */
    vec3 velocity;        /* <linear>: + velocity * t */
    int has_rotation;     /* <rotation>: angle = degrees_per_time * t */
    vec3 axis, center;    /* rotation axis (unit) through center */
    double degrees_per_time;
    keyframes *keys;      /* keyframed (owned) instead of linear/rotation */
    struct trajectory *path; /* a camera's trajectory file (owned) instead of the above:
                              * p_world = R(t) (p_rest + offset) + p(t), the pose's OpenCV axes */
} animation;

void animation_init_static(animation *a);
void animation_free(animation *a);

/* 1 when the transform is the same at every time. */
int animation_is_static(const animation *a);

/* 1 when the rotation never jumps (keyframed rotation channels are
 * continuous: curve_is_continuous), so directions turn at most at
 * animation_motion_bound's rate. */
int animation_turns_continuously(const animation *a);

/* The rigid motion that takes a pose (position, rotation whose columns are
 * the posed frame's axes) from a at time t0 to b at time t1 with the
 * position linear and the rotation slerped (a constant turn about one
 * axis): a <linear> plus a <rotation> animation, and the rest pose it
 * moves (the pose it gives at time 0). -1 when the poses turn by more
 * than 170 degrees (the turn between them is ambiguous near 180) or
 * t1 <= t0. */
int animation_between_poses(vec3 pa, const double ra[3][3], vec3 pb, const double rb[3][3], double t0, double t1,
                            animation *out, vec3 *rest_position, double rest_rotation[3][3], rr_error *err);

/* Transform at absolute scene time t. */
xform animation_at(const animation *a, double t);

/* The transform at time t (as animation_at) and its rotation as a unit
 * quaternion (w, x, y, z): a trajectory's own, exactly as interpolated
 * (its knots come back bit for bit); other motions' from their matrix. */
xform animation_pose_at(const animation *a, double t, double q[4]);

/* The times the bounds below evaluate the motion at over [t0, t1]: a grid
 * and every key time (repeated through cycling infinities, where steps
 * jump). Past ANIMATION_MAX_KEY_TIMES (128 MB of times) no bound is made:
 * accel refuses such a shutter, naming the object. */
#define ANIMATION_MAX_KEY_TIMES ((double)(1 << 24))
double animation_key_times(const animation *a, double t0, double t1);

/* A box containing the object-space box b transformed by every transform
 * over [t0, t1]. Conservative: the transform is evaluated at steps (and at
 * every key time, from both sides) and the union padded by the farthest
 * any point of b can move from the nearer step, (speed bound) * dt / 2. */
aabb animation_swept_bounds(const animation *a, aabb b, double t0, double t1);

/* Bounds on the motion over [t0, t1] (all 0 for a static animation): a
 * point p in model coordinates moves at most at linear + angular *
 * |p - center| (world units per unit time); directions turn at most at
 * `turn` (radians per unit time) and scale factors change at most at
 * scale_rate. */
typedef struct {
    double linear, angular;
    vec3 center;
    double turn, scale_rate;
} motion_bound;
motion_bound animation_motion_bound(const animation *a, double t0, double t1);

/* Whether a keyframed scale reaches 1e-9 or below anywhere in [t0, t1] (a
 * curve extrapolated through zero, or a spline overshooting between keys):
 * there it is held at 1e-9, where Maya would mirror the object; the caller
 * warns. */
int animation_scale_clamped(const animation *a, double t0, double t1);

/* A lower bound on the smallest scale factor over [t0, t1] (1 if unscaled). */
double animation_min_scale(const animation *a, double t0, double t1);

/* An upper bound on the largest scale factor over [t0, t1] (1 if unscaled). */
double animation_max_scale(const animation *a, double t0, double t1);

#endif
