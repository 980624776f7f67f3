/* rotation.c, the rotation maths every layer shares, against closed forms:
 * the rotation by theta about z is [[c, -s, 0], [s, c, 0], [0, 0, 1]] and
 * its quaternion (cos theta/2, 0, 0, sin theta/2); rotating v by q is the
 * sandwich q (0, v) q*; a screw of angle theta about z with twist (v, 0, 0)
 * ends at (v sin theta / theta, v (1 - cos theta) / theta, 0) (the SE(3)
 * left Jacobian about one axis, Barfoot 2017, eq. 7.86); and group laws:
 * Exp(Log q) = q, matrices orthonormal with determinant 1, the matrix of a
 * product the product of the matrices, slerp through both ends and halving
 * the angle, xforms composing as 4x4 matrices multiply. */
#include <float.h>
#include <math.h>

#include "core/rotation.h"
#include "harness.h"

/* A spread of unit quaternions: angles up to 3 (short of pi) about varied axes. */
static void sample_quat(int i, double q[4])
{
    vec3 axis = v3_normalize(v3(sin(1.3 * i + 0.2), cos(0.7 * i), sin(2.9 * i + 1.0) + 0.1));
    double angle = 3.0 * (i % 17) / 16.0, s = sin(0.5 * angle);
    q[0] = cos(0.5 * angle), q[1] = s * axis.x, q[2] = s * axis.y, q[3] = s * axis.z;
}

static double matrix_distance(const double a[3][3], const double b[3][3])
{
    double d = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            d = fmax(d, fabs(a[i][j] - b[i][j]));
    return d;
}

/* |q - p| up to the sign (q and -q are one rotation). */
static double quat_distance(const double q[4], const double p[4])
{
    double plus = 0, minus = 0;
    for (int k = 0; k < 4; k++)
        plus = fmax(plus, fabs(q[k] - p[k])), minus = fmax(minus, fabs(q[k] + p[k]));
    return fmin(plus, minus);
}

static void matrix_product(const double a[3][3], const double b[3][3], double out[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            out[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
}

static double det3(const double r[3][3])
{
    return r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
           r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
}

TEST(quaternion_matrices_are_rotations_and_match_the_closed_form_about_z)
{
    for (int i = 0; i < 200; i++) {
        double q[4], r[3][3], rt[3][3], rrt[3][3], id[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        sample_quat(i, q);
        quat_matrix(q, r);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                rt[a][b] = r[b][a];
        matrix_product(r, rt, rrt);
        CHECK(matrix_distance(rrt, id) < 1e-15 * 4);
        CHECK(fabs(det3(r) - 1) < 1e-15 * 4);
        double u[3][3], scaled[4] = {3 * q[0], 3 * q[1], 3 * q[2], 3 * q[3]}, s3[3][3];
        quat_unit_matrix(q[0], q[1], q[2], q[3], u); /* the same rotation, rounded in binary64 */
        CHECK(matrix_distance(r, u) < 1e-15 * 4);
        quat_matrix(scaled, s3); /* quat_matrix divides by |q|^2 */
        CHECK(matrix_distance(r, s3) < 1e-15 * 4);
    }
    for (int k = -6; k <= 6; k++) {
        double th = 0.5 * k, q[4] = {cos(0.5 * th), 0, 0, sin(0.5 * th)}, r[3][3], u[3][3];
        double want[3][3] = {{cos(th), -sin(th), 0}, {sin(th), cos(th), 0}, {0, 0, 1}};
        quat_matrix(q, r);
        quat_unit_matrix(q[0], q[1], q[2], q[3], u);
        CHECK(matrix_distance(r, want) < 1e-15 * 4);
        CHECK(matrix_distance(u, want) < 1e-15 * 4);
        rotation_matrix(v3(0, 0, 1), th, r); /* Rodrigues: the same rotation */
        CHECK(matrix_distance(r, want) < 1e-15 * 4);
    }
}

TEST(matrices_and_frames_give_their_quaternion_back)
{
    for (int i = 0; i < 200; i++) {
        double q[4], r[3][3], back[4], framed[4];
        sample_quat(i, q);
        if (i % 3 == 1)
            for (int k = 0; k < 4; k++) /* the other sign: the w >= 0 one comes back */
                q[k] = -q[k];
        quat_matrix(q, r);
        quat_of_matrix(r, back);
        CHECK(back[0] >= 0);
        CHECK(quat_distance(back, q) < 1e-15 * 4);
        quat_of_frame(v3(r[0][0], r[1][0], r[2][0]), v3(r[0][1], r[1][1], r[2][1]), v3(r[0][2], r[1][2], r[2][2]),
                      framed);
        CHECK(quat_distance(framed, q) < 1e-15 * 8);
    }
    /* half a turn about x, y and z: the trace is -1, a non-w branch of each */
    double halves[3][4] = {{0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}, r[3][3], back[4];
    for (int k = 0; k < 3; k++) {
        quat_matrix(halves[k], r);
        quat_of_matrix(r, back);
        CHECK(quat_distance(back, halves[k]) < 1e-15);
        quat_of_frame(v3(r[0][0], r[1][0], r[2][0]), v3(r[0][1], r[1][1], r[2][1]), v3(r[0][2], r[1][2], r[2][2]),
                      back);
        CHECK(quat_distance(back, halves[k]) < 1e-15);
    }
}

TEST(the_product_of_quaternions_is_the_product_of_their_matrices_and_rotates_by_the_sandwich)
{
    for (int i = 0; i < 100; i++) {
        double a[4], b[4], ab[4], ra[3][3], rb[3][3], rab[3][3], want[3][3];
        sample_quat(i, a), sample_quat(3 * i + 7, b);
        quat_mul(a, b, ab);
        quat_matrix(a, ra), quat_matrix(b, rb), quat_matrix(ab, rab);
        matrix_product(ra, rb, want); /* b applied first */
        CHECK(matrix_distance(rab, want) < 1e-15 * 8);
        vec3 v = v3(0.3 * i - 2, 1.5, -0.25 * i);
        double pv[4] = {0, v.x, v.y, v.z}, ca[4], t[4], s[4];
        quat_conj(a, ca);
        quat_mul(a, pv, t), quat_mul(t, ca, s); /* a (0, v) a* */
        vec3 got = quat_rotate(a, v);
        CHECK(fabs(s[0]) < 1e-13 && v3_len(v3_sub(got, v3(s[1], s[2], s[3]))) < 1e-13);
        quat_mul(a, ca, t); /* the conjugate inverts a unit quaternion */
        CHECK(fabs(t[0] - 1) < 1e-15 && fabs(t[1]) < 1e-15 && fabs(t[2]) < 1e-15 && fabs(t[3]) < 1e-15);
    }
    double q[4] = {0.5, -0.5, 0.5, 0.5}, p[4] = {1, 2, 3, 4};
    CHECK(quat_dot(q, p) == 0.5 - 1 + 1.5 + 2);
    CHECK(quat_norm(p) == sqrt(30.0));
}

TEST(exp_and_log_invert_each_other_and_match_the_axis_angle_closed_form)
{
    for (int i = 0; i < 200; i++) {
        double q[4], e[4], r[3][3], re[3][3];
        sample_quat(i, q);
        vec3 phi = quat_log(q);
        quat_exp(phi, e);
        CHECK(quat_distance(e, q) < 1e-15 * 4);
        quat_matrix(q, r), quat_matrix(e, re); /* Exp(Log(R)) = R */
        CHECK(matrix_distance(r, re) < 1e-15 * 4);
        double minus[4] = {-q[0], -q[1], -q[2], -q[3]}; /* the same rotation: the same short arc */
        CHECK(v3_len(v3_sub(quat_log(minus), phi)) < 1e-15 * 4);
    }
    /* |phi| from 1e-9 (the series branch) through 1e-4 (the switch) to 3.1 */
    double angles[] = {1e-9, 1e-6, 0.99e-4, 1.01e-4, 0.01, 1.0, 2.5, 3.1};
    vec3 axis = v3_normalize(v3(1, -2, 0.5));
    for (int k = 0; k < (int)(sizeof angles / sizeof *angles); k++) {
        double th = angles[k], q[4], s = sin(0.5 * th);
        vec3 phi = v3_scale(axis, th);
        quat_exp(phi, q);
        double want[4] = {cos(0.5 * th), s * axis.x, s * axis.y, s * axis.z};
        CHECK(quat_distance(q, want) < 1e-15 * 2);
        CHECK(v3_len(v3_sub(quat_log(q), phi)) < 1e-15 * 8);
    }
}

TEST(slerp_runs_from_one_end_to_the_other_turning_uniformly)
{
    for (int i = 0; i < 100; i++) {
        double a[4], b[4], out[4], half[4], ca[4], rel[4];
        sample_quat(i, a), sample_quat(5 * i + 3, b);
        quat_slerp(a, b, 0, out);
        CHECK(quat_distance(out, a) < 1e-15 * 2);
        quat_slerp(a, b, 1, out);
        CHECK(quat_distance(out, b) < 1e-15 * 8);
        /* the half way rotation is as far from a as from b, half the whole turn */
        quat_slerp(a, b, 0.5, half);
        quat_conj(a, ca), quat_mul(ca, b, rel);
        double whole = v3_len(quat_log(rel));
        quat_mul(ca, half, rel);
        double first = v3_len(quat_log(rel));
        quat_conj(half, ca), quat_mul(ca, b, rel);
        double second = v3_len(quat_log(rel));
        CHECK(fabs(first - 0.5 * whole) < 1e-14 && fabs(second - 0.5 * whole) < 1e-14);
        double minus_b[4] = {-b[0], -b[1], -b[2], -b[3]}, other[4]; /* the short arc either way */
        quat_slerp(a, minus_b, 0.3, other), quat_slerp(a, b, 0.3, out);
        CHECK(quat_distance(other, out) < 1e-14);
    }
    /* from the identity to theta about z: theta u about z */
    double id[4] = {1, 0, 0, 0}, th = 2.4, b[4] = {cos(0.5 * th), 0, 0, sin(0.5 * th)}, out[4];
    for (int k = 0; k <= 8; k++) {
        double u = k / 8.0, want[4] = {cos(0.5 * u * th), 0, 0, sin(0.5 * u * th)};
        quat_slerp(id, b, u, out);
        CHECK(quat_distance(out, want) < 1e-15 * 2);
        quat_between(id, b, u, out); /* the same turn, from the identity */
        CHECK(quat_distance(out, want) < 1e-15 * 2);
    }
}

TEST(se3_exp_is_a_screw_motion_and_log_inverts_it)
{
    /* about z by theta with twist rho = (v, 0, h): the point moves along the
     * axis by h and across by v sin(theta)/theta, v (1 - cos theta)/theta.
     * Just above the series' switch (|phi| = 1e-4) 1 - cos theta computed
     * as written cancels (an error of eps / theta^2 relative: Log's twist
     * was off by 5e-9 |rho| at 2e-4); as 2 sin^2(theta/2) it does not, and
     * both directions hold to a few eps |rho| at every angle. */
    double thetas[] = {1e-7, 5e-5, 2e-4, 0.3, 1.2, 3.0};
    for (int k = 0; k < (int)(sizeof thetas / sizeof *thetas); k++) {
        double th = thetas[k], v = 1.7, h = -0.4, q[4];
        vec3 p;
        se3_exp((se3_twist){v3(0, 0, th), v3(v, 0, h)}, &p, q);
        double half_sin = sin(0.5 * th); /* 1 - cos th = 2 sin^2(th/2), without the cancellation */
        vec3 want = v3(v * sin(th) / th, v * 2 * half_sin * half_sin / th, h);
        double rho = sqrt(v * v + h * h);
        CHECK(v3_len(v3_sub(p, want)) < 1e-14 + 8 * DBL_EPSILON * rho);
        CHECK(fabs(q[0] - cos(0.5 * th)) < 1e-15 && fabs(q[3] - sin(0.5 * th)) < 1e-15);
        se3_twist x = se3_log(p, q);
        CHECK(v3_len(v3_sub(x.phi, v3(0, 0, th))) < 1e-14);
        CHECK(v3_len(v3_sub(x.rho, v3(v, 0, h))) < 1e-14 + 8 * DBL_EPSILON * rho);
    }
    for (int i = 0; i < 100; i++) {
        double q[4], back[4];
        sample_quat(i, q);
        vec3 p = v3(sin(i) * 3, cos(2 * i), 0.1 * i - 5), pb;
        se3_exp(se3_log(p, q), &pb, back);
        CHECK(v3_len(v3_sub(pb, p)) < 1e-13 && quat_distance(back, q) < 1e-15 * 4);
    }
    double id[4] = {1, 0, 0, 0}, q[4]; /* no turn: the twist is the translation */
    vec3 p;
    se3_twist x = se3_log(v3(1, 2, 3), id);
    CHECK(x.phi.x == 0 && x.phi.y == 0 && x.phi.z == 0 && x.rho.x == 1 && x.rho.y == 2 && x.rho.z == 3);
    se3_exp(x, &p, q);
    CHECK(p.x == 1 && p.y == 2 && p.z == 3 && q[0] == 1);
}

TEST(the_relative_pose_takes_the_first_pose_to_the_second)
{
    for (int i = 0; i < 50; i++) {
        double qa[4], qb[4], q[4], composed[4];
        sample_quat(i, qa), sample_quat(2 * i + 11, qb);
        vec3 pa = v3(i, -1, 0.5), pb = v3(2, 0.3 * i, -i), p;
        se3_relative(pa, qa, pb, qb, &p, q);
        quat_mul(qa, q, composed); /* (pa, qa) (p, q) = (pa + R_a p, qa q) */
        CHECK(quat_distance(composed, qb) < 1e-15 * 8);
        CHECK(v3_len(v3_sub(v3_add(pa, quat_rotate(qa, p)), pb)) < 1e-13);
    }
}

/* x's 4x4 matrix [r t; 0 1] */
static void xform_matrix(const xform *x, double m[4][4])
{
    double t[3] = {x->t.x, x->t.y, x->t.z};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            m[i][j] = x->r[i][j];
        m[i][3] = t[i];
        m[3][i] = 0;
    }
    m[3][3] = 1;
}

/* A rotation about axis by angle, scaled per column by s, then moved by t. */
static xform sample_xform(vec3 axis, double angle, vec3 s, vec3 t)
{
    xform x;
    double rot[3][3], sc[3] = {s.x, s.y, s.z};
    rotation_matrix(v3_normalize(axis), angle, rot);
    x.scaled = sc[0] != 1 || sc[1] != 1 || sc[2] != 1;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            x.r[i][j] = rot[i][j] * sc[j], x.ri[i][j] = rot[j][i] / sc[i];
    x.t = t;
    return x;
}

TEST(xforms_compose_as_their_matrices_multiply_and_invert_exactly)
{
    xform a = sample_xform(v3(1, 2, 3), 0.7, v3(1, 1, 1), v3(0.5, -1, 2));
    xform b = sample_xform(v3(-2, 0.5, 1), 2.2, v3(2, 0.5, 1.5), v3(-3, 0.25, 1));
    double ma[4][4], mb[4][4], mab[4][4];
    xform_matrix(&a, ma), xform_matrix(&b, mb);
    mat4_mul(ma, mb, mab);
    for (int i = 0; i < 20; i++) {
        vec3 p = v3(sin(i), 2 * cos(3 * i), 0.4 * i - 4);
        vec3 got = xform_point(&a, xform_point(&b, p));
        vec3 want = v3(mab[0][0] * p.x + mab[0][1] * p.y + mab[0][2] * p.z + mab[0][3],
                       mab[1][0] * p.x + mab[1][1] * p.y + mab[1][2] * p.z + mab[1][3],
                       mab[2][0] * p.x + mab[2][1] * p.y + mab[2][2] * p.z + mab[2][3]);
        CHECK(v3_len(v3_sub(got, want)) < 1e-13);
        vec3 dv = xform_vector(&a, xform_vector(&b, p)); /* vectors: the linear parts only */
        CHECK(v3_len(v3_sub(dv, v3_sub(want, v3(mab[0][3], mab[1][3], mab[2][3])))) < 1e-13);
        CHECK(v3_len(v3_sub(xform_inverse_point(&b, xform_inverse_point(&a, got)), p)) < 1e-13);
        CHECK(v3_len(v3_sub(xform_inverse_vector(&b, xform_vector(&b, p)), p)) < 1e-13);
        /* a normal stays perpendicular to every tangent under scale, and unit */
        vec3 n = v3_normalize(v3(1, i, -2)), tangent = v3_cross(n, v3(0.3, 1, 0.2));
        vec3 wn = xform_normal(&b, n), wt = xform_vector(&b, tangent);
        CHECK(fabs(v3_dot(wn, wt)) < 1e-13 * v3_len(wt) && fabs(v3_len(wn) - 1) < 1e-15 * 4);
    }
}

TEST(the_axis_and_angle_of_a_rotation_matrix_come_back)
{
    double r[3][3];
    vec3 axis = v3_normalize(v3(0.3, -1, 2)), got;
    for (int k = 1; k <= 30; k++) {
        double angle = 0.1 * k; /* up to 3.0 */
        rotation_matrix(axis, angle, r);
        double back = rotation_axis_angle(r, &got);
        CHECK(fabs(back - angle) < 1e-14 && v3_len(v3_sub(got, axis)) < 1e-13);
    }
    double id[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, half[3][3] = {{1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    CHECK(rotation_axis_angle(id, &got) == 0 && got.z == 1);
    CHECK(rotation_axis_angle(half, &got) == M_PI); /* half a turn: callers refuse it */
}
