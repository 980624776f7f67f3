/* Rotations and rigid transforms, the one home of their maths: unit
 * quaternions q = (w, x, y, z), rotation vectors phi (the rotation by |phi|
 * about phi: SO(3)'s Log and Exp), twists (phi, rho) (SE(3)'s Log and
 * Exp), row-major rotation matrices, and xform, the affine map
 * p' = r p + t with its exact inverse. Animation, camera trajectories, the
 * transforms.json reader and the Gaussian kernels all use these; this
 * module depends on nothing but common.h, so every layer above may.
 *
 * Two rounding recipes exist on purpose for the matrix of a quaternion and
 * for the quaternion of a matrix (each keeps its callers' results as they
 * were; see each function): quat_matrix and quat_of_matrix work in long
 * double, rounding once, so that a pose written to a file as a matrix
 * reads back as the same quaternion; quat_unit_matrix and quat_of_frame
 * stay in binary64, the Gaussian kernels' (their scalar and AVX2 paths
 * must agree bit for bit). */
#ifndef RR_ROTATION_H
#define RR_ROTATION_H

#include "core/common.h"

/* ---- rigid (and scaled) transforms ---------------------------------------- */

typedef struct {
    double r[3][3];  /* linear part (rotation times scale), row-major */
    double ri[3][3]; /* its inverse */
    vec3 t;          /* translation */
    int scaled;      /* 0: r is a rotation (ri = r^T) */
} xform;

vec3 xform_point(const xform *x, vec3 p);
vec3 xform_vector(const xform *x, vec3 v);
/* Exact inverse: ri (p - T) and ri v. */
vec3 xform_inverse_point(const xform *x, vec3 p);
vec3 xform_inverse_vector(const xform *x, vec3 v);
/* An object-space normal in world space (inverse transpose; unit length
 * kept for rotations, renormalised under scale). */
vec3 xform_normal(const xform *x, vec3 n);

/* ---- rotation matrices ----------------------------------------------------- */

/* Rotation matrix for angle (radians) about a unit axis (Rodrigues). */
void rotation_matrix(vec3 axis, double angle, double r[3][3]);

/* The axis and angle (in [0, pi]) of the rotation r, from its
 * antisymmetric part and trace; 0 with the axis z when r is (numerically)
 * none, pi with the axis z at half a turn (where the axis is not found
 * this way: callers refuse turns near it). */
double rotation_axis_angle(const double r[3][3], vec3 *axis);

/* ---- quaternions (w, x, y, z) ---------------------------------------------- */

/* a . b, summed in component order, and |q| = sqrt(q . q). */
double quat_dot(const double a[4], const double b[4]);
double quat_norm(const double q[4]);

/* The conjugate (the inverse of a unit q) and the product a b (b applied
 * first); out may be a or b. */
void quat_conj(const double q[4], double out[4]);
void quat_mul(const double a[4], const double b[4], double out[4]);

/* The rotation matrix of a (not necessarily unit) quaternion, and back
 * (Shepperd's method, the sign with w >= 0). Both work in long double and
 * round once at the end: a matrix written to a file and read back then
 * moves the quaternion by at most about an ulp. transforms.c keeps the
 * quaternion its written matrix reads back as, a fixed point this pair of
 * maps reaches in a few steps; in binary64 the pair wandered on instead. */
void quat_matrix(const double q[4], double r[3][3]);
void quat_of_matrix(const double r[3][3], double q[4]);

/* v rotated by q (through quat_matrix). */
vec3 quat_rotate(const double q[4], vec3 v);

/* The matrix of a unit quaternion in binary64, 1 - 2 (y^2 + z^2) and so
 * on with no division by |q|^2: the Gaussian kernels' formula, which their
 * AVX2 lanes also take, one Gaussian at a time (gaussian_hit_2d.c splat_axes). */
static inline void quat_unit_matrix(double w, double x, double y, double z, double r[3][3])
{
    r[0][0] = 1 - 2 * (y * y + z * z), r[0][1] = 2 * (x * y - w * z), r[0][2] = 2 * (x * z + w * y);
    r[1][0] = 2 * (x * y + w * z), r[1][1] = 1 - 2 * (x * x + z * z), r[1][2] = 2 * (y * z - w * x);
    r[2][0] = 2 * (x * z - w * y), r[2][1] = 2 * (y * z + w * x), r[2][2] = 1 - 2 * (x * x + y * y);
}

/* The unit quaternion of the rotation whose columns are the orthonormal
 * frame (a, b, c), in binary64 (Shepperd's method: the trace first when
 * positive, else the largest diagonal). The Gaussian models made from
 * surfels (gaussian_from_surfels) keep these roundings. */
void quat_of_frame(vec3 a, vec3 b, vec3 c, double q[4]);

/* Exp: the rotation by |phi| about phi, as a unit quaternion. */
void quat_exp(vec3 phi, double q[4]);
/* Log: the rotation vector of q, the short arc (|phi| <= pi: q and -q are
 * one rotation, the sign with w >= 0 is taken). */
vec3 quat_log(const double q[4]);

/* The turn from a to b scaled by u: Exp(u Log(a^-1 b)) (the short arc). */
void quat_between(const double a[4], const double b[4], double u, double out[4]);
/* Spherical linear interpolation on the short arc: a Exp(u Log(a^-1 b)). */
void quat_slerp(const double a[4], const double b[4], double u, double out[4]);

/* ---- SE(3): poses (p, q) and twists ---------------------------------------- */

typedef struct {
    vec3 phi, rho; /* rotation vector, and the translation's twist part */
} se3_twist;

/* Log and Exp of the pose (p, q): phi = Log q, p = V(phi) rho. */
se3_twist se3_log(vec3 p, const double q[4]);
void se3_exp(se3_twist x, vec3 *p, double q[4]);

/* (p, q) = (pa, qa)^-1 (pb, qb). */
void se3_relative(vec3 pa, const double qa[4], vec3 pb, const double qb[4], vec3 *p, double q[4]);

#endif
