/* Rigid object transforms as functions of time (thesis sec. 4.6, B.2.3).
 *
 * An object's world position at time t is  p_world = R(t) p_rest + T(t),
 * where p_rest is the model point plus the object's rest offset. Objects
 * are never moved: the renderer applies the exact inverse to each ray
 * (thesis B.2.3 TransformRay). */
#ifndef RR_ANIMATION_H
#define RR_ANIMATION_H

#include "common.h"

typedef struct {
    double r[3][3]; /* rotation, row-major */
    vec3 t;         /* translation */
} xform;

typedef struct {
    vec3 offset;          /* rest position offset applied to model points */
    vec3 velocity;        /* <linear>: + velocity * t */
    int has_rotation;     /* <rotation>: angle = degrees_per_time * t */
    vec3 axis, center;    /* rotation axis (unit) through center */
    double degrees_per_time;
} animation;

void animation_init_static(animation *a);

/* 1 when the transform is the same at every time. */
int animation_is_static(const animation *a);

/* Transform at absolute scene time t: rotate about the axis through center
 * by degrees_per_time * t (right-handed), then translate by velocity * t,
 * all after the rest offset. */
xform animation_at(const animation *a, double t);

vec3 xform_point(const xform *x, vec3 p);
vec3 xform_vector(const xform *x, vec3 v);
/* Exact inverse for rigid transforms: R^T (p - T) and R^T v. */
vec3 xform_inverse_point(const xform *x, vec3 p);
vec3 xform_inverse_vector(const xform *x, vec3 v);

/* Rotation matrix for angle (radians) about a unit axis (Rodrigues). */
void rotation_matrix(vec3 axis, double angle, double r[3][3]);

/* A box containing the object-space box b transformed by every transform
 * over [t0, t1]. Conservative: the transform is evaluated at steps and the
 * union padded by the largest distance any point of b can move between two
 * steps (|v| + |omega| * reach) * dt / 2. */
aabb animation_swept_bounds(const animation *a, aabb b, double t0, double t1);

#endif
