#include "core/rotation.h"

#include <string.h>

/* ---- rigid (and scaled) transforms ---------------------------------------- */

vec3 xform_vector(const xform *x, vec3 v)
{
    return v3(x->r[0][0] * v.x + x->r[0][1] * v.y + x->r[0][2] * v.z,
              x->r[1][0] * v.x + x->r[1][1] * v.y + x->r[1][2] * v.z,
              x->r[2][0] * v.x + x->r[2][1] * v.y + x->r[2][2] * v.z);
}

vec3 xform_point(const xform *x, vec3 p) { return v3_add(xform_vector(x, p), x->t); }

vec3 xform_inverse_vector(const xform *x, vec3 v)
{
    return v3(x->ri[0][0] * v.x + x->ri[0][1] * v.y + x->ri[0][2] * v.z,
              x->ri[1][0] * v.x + x->ri[1][1] * v.y + x->ri[1][2] * v.z,
              x->ri[2][0] * v.x + x->ri[2][1] * v.y + x->ri[2][2] * v.z);
}

vec3 xform_inverse_point(const xform *x, vec3 p) { return xform_inverse_vector(x, v3_sub(p, x->t)); }

vec3 xform_normal(const xform *x, vec3 n)
{
    vec3 w = v3(x->ri[0][0] * n.x + x->ri[1][0] * n.y + x->ri[2][0] * n.z,
                x->ri[0][1] * n.x + x->ri[1][1] * n.y + x->ri[2][1] * n.z,
                x->ri[0][2] * n.x + x->ri[1][2] * n.y + x->ri[2][2] * n.z);
    return x->scaled ? v3_normalize(w) : w;
}

/* ---- rotation matrices ----------------------------------------------------- */

void rotation_matrix(vec3 k, double angle, double r[3][3])
{
    double c = cos(angle), s = sin(angle), C = 1 - c;
    r[0][0] = c + k.x * k.x * C;
    r[0][1] = k.x * k.y * C - k.z * s;
    r[0][2] = k.x * k.z * C + k.y * s;
    r[1][0] = k.y * k.x * C + k.z * s;
    r[1][1] = c + k.y * k.y * C;
    r[1][2] = k.y * k.z * C - k.x * s;
    r[2][0] = k.z * k.x * C - k.y * s;
    r[2][1] = k.z * k.y * C + k.x * s;
    r[2][2] = c + k.z * k.z * C;
}

double rotation_axis_angle(const double r[3][3], vec3 *axis)
{
    vec3 s = v3(0.5 * (r[2][1] - r[1][2]), 0.5 * (r[0][2] - r[2][0]), 0.5 * (r[1][0] - r[0][1])); /* axis sin */
    double c = 0.5 * (r[0][0] + r[1][1] + r[2][2] - 1.0), sn = v3_len(s);
    if (!(sn > 1e-15)) {
        *axis = v3(0, 0, 1);
        return c > 0 ? 0.0 : M_PI; /* none, or half a turn (refused by the caller) */
    }
    *axis = v3_scale(s, 1.0 / sn);
    return atan2(sn, c);
}

/* ---- quaternions (w, x, y, z) ---------------------------------------------- */

double quat_dot(const double a[4], const double b[4]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]; }

double quat_norm(const double q[4]) { return sqrt(quat_dot(q, q)); }

void quat_conj(const double q[4], double out[4])
{
    out[0] = q[0], out[1] = -q[1], out[2] = -q[2], out[3] = -q[3];
}

void quat_mul(const double a[4], const double b[4], double out[4])
{
    double r[4] = {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
                   a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
                   a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
                   a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
    memcpy(out, r, sizeof r);
}

void quat_matrix(const double q[4], double r[3][3])
{
    long double w = q[0], x = q[1], y = q[2], z = q[3], s = 2.0L / (w * w + x * x + y * y + z * z);
    r[0][0] = (double)(1 - s * (y * y + z * z)), r[0][1] = (double)(s * (x * y - w * z));
    r[0][2] = (double)(s * (x * z + w * y)), r[1][0] = (double)(s * (x * y + w * z));
    r[1][1] = (double)(1 - s * (x * x + z * z)), r[1][2] = (double)(s * (y * z - w * x));
    r[2][0] = (double)(s * (x * z - w * y)), r[2][1] = (double)(s * (y * z + w * x));
    r[2][2] = (double)(1 - s * (x * x + y * y));
}

void quat_of_matrix(const double r[3][3], double q[4])
{
    /* Shepperd's method: divide by the largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2 */
    long double m[3][3];
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            m[a][b] = r[a][b];
    long double tr = m[0][0] + m[1][1] + m[2][2], d[4] = {tr, m[0][0], m[1][1], m[2][2]};
    int k = 0;
    for (int i = 1; i < 4; i++)
        if (d[i] > d[k])
            k = i;
    long double big = k ? sqrtl(1.0L + 2.0L * d[k] - tr) * 0.5L : sqrtl(1.0L + tr) * 0.5L, f = 0.25L / big;
    long double wx = m[2][1] - m[1][2], wy = m[0][2] - m[2][0], wz = m[1][0] - m[0][1];
    long double xy = m[0][1] + m[1][0], xz = m[0][2] + m[2][0], yz = m[1][2] + m[2][1];
    long double all[4][4] = {{big, wx * f, wy * f, wz * f},
                             {wx * f, big, xy * f, xz * f},
                             {wy * f, xy * f, big, yz * f},
                             {wz * f, xz * f, yz * f, big}};
    int flip = all[k][0] < 0; /* the sign with w >= 0 */
    for (int i = 0; i < 4; i++)
        q[i] = (double)(flip ? -all[k][i] : all[k][i]);
}

vec3 quat_rotate(const double q[4], vec3 v)
{
    double r[3][3];
    quat_matrix(q, r);
    return v3(r[0][0] * v.x + r[0][1] * v.y + r[0][2] * v.z, r[1][0] * v.x + r[1][1] * v.y + r[1][2] * v.z,
              r[2][0] * v.x + r[2][1] * v.y + r[2][2] * v.z);
}

void quat_of_frame(vec3 a, vec3 b, vec3 c, double q[4])
{
    double m[3][3] = {{a.x, b.x, c.x}, {a.y, b.y, c.y}, {a.z, b.z, c.z}};
    double t = m[0][0] + m[1][1] + m[2][2];
    if (t > 0) {
        double s = 2 * sqrt(1 + t);
        q[0] = s / 4, q[1] = (m[2][1] - m[1][2]) / s, q[2] = (m[0][2] - m[2][0]) / s, q[3] = (m[1][0] - m[0][1]) / s;
    } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
        double s = 2 * sqrt(1 + m[0][0] - m[1][1] - m[2][2]);
        q[0] = (m[2][1] - m[1][2]) / s, q[1] = s / 4, q[2] = (m[0][1] + m[1][0]) / s, q[3] = (m[0][2] + m[2][0]) / s;
    } else if (m[1][1] > m[2][2]) {
        double s = 2 * sqrt(1 + m[1][1] - m[0][0] - m[2][2]);
        q[0] = (m[0][2] - m[2][0]) / s, q[1] = (m[0][1] + m[1][0]) / s, q[2] = s / 4, q[3] = (m[1][2] + m[2][1]) / s;
    } else {
        double s = 2 * sqrt(1 + m[2][2] - m[0][0] - m[1][1]);
        q[0] = (m[1][0] - m[0][1]) / s, q[1] = (m[0][2] + m[2][0]) / s, q[2] = (m[1][2] + m[2][1]) / s, q[3] = s / 4;
    }
}

void quat_exp(vec3 phi, double q[4])
{
    double theta = v3_len(phi), half = 0.5 * theta;
    /* sin(theta/2)/theta, by its series where the quotient loses digits */
    double k = theta < 1e-4 ? 0.5 - theta * theta / 48.0 : sin(half) / theta;
    q[0] = cos(half), q[1] = k * phi.x, q[2] = k * phi.y, q[3] = k * phi.z;
}

vec3 quat_log(const double q[4])
{
    double s = q[0] < 0 ? -1.0 : 1.0, w = s * q[0];
    vec3 v = v3(s * q[1], s * q[2], s * q[3]);
    double n = v3_len(v);
    if (n == 0)
        return v3(0, 0, 0);
    return v3_scale(v, 2.0 * atan2(n, w) / n);
}

void quat_between(const double a[4], const double b[4], double u, double out[4])
{
    double rq[4];
    quat_conj(a, rq);
    quat_mul(rq, b, rq);
    quat_exp(v3_scale(quat_log(rq), u), out);
}

void quat_slerp(const double a[4], const double b[4], double u, double out[4])
{
    double e[4];
    quat_between(a, b, u, e);
    quat_mul(a, e, out);
}

/* ---- SE(3) ----------------------------------------------------------------- */

/* The SE(3) left Jacobian's action V(phi) rho and its inverse (Barfoot,
 * State Estimation for Robotics, 2017, eqs. 7.86 and 7.95 with J = V):
 * the translation of Exp((phi, rho)) is V(phi) rho. */
static vec3 se3_v(vec3 phi, vec3 rho, int inverse)
{
    double th2 = v3_dot(phi, phi), th = sqrt(th2), a, b;
    vec3 c1 = v3_cross(phi, rho), c2 = v3_cross(phi, c1);
    /* 1 - cos th as 2 sin^2(th/2): computed as written it cancels, an error
     * of eps / th^2 relative, 5e-9 |rho| in Log just above the series' switch */
    double half = sin(0.5 * th), one_minus_cos = 2.0 * half * half;
    if (inverse) {
        a = -0.5;
        b = th < 1e-4 ? 1.0 / 12.0 + th2 / 720.0 : (1.0 - th * sin(th) / (2.0 * one_minus_cos)) / th2;
    } else {
        a = th < 1e-4 ? 0.5 - th2 / 24.0 : one_minus_cos / th2;
        b = th < 1e-4 ? 1.0 / 6.0 - th2 / 120.0 : (th - sin(th)) / (th2 * th);
    }
    return v3_add(rho, v3_add(v3_scale(c1, a), v3_scale(c2, b)));
}

se3_twist se3_log(vec3 p, const double q[4])
{
    se3_twist x;
    x.phi = quat_log(q);
    x.rho = se3_v(x.phi, p, 1);
    return x;
}

void se3_exp(se3_twist x, vec3 *p, double q[4])
{
    quat_exp(x.phi, q);
    *p = se3_v(x.phi, x.rho, 0);
}

void se3_relative(vec3 pa, const double qa[4], vec3 pb, const double qb[4], vec3 *p, double q[4])
{
    double ca[4];
    quat_conj(qa, ca);
    quat_mul(ca, qb, q);
    *p = quat_rotate(ca, v3_sub(pb, pa));
}
