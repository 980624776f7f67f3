#include "motion/trajectory.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/rotation.h"

/* (p, q) = (pa, qa)^-1 (pb, qb) */
static void relative_pose(const trajectory_knot *a, const trajectory_knot *b, vec3 *p, double q[4])
{
    se3_relative(a->p, a->q, b->p, b->q, p, q);
}

/* A knot's world-to-camera translation -R^T p (R: q's matrix). */
static vec3 world_to_camera_translation(const trajectory_knot *k)
{
    double c[4];
    quat_conj(k->q, c);
    return v3_scale(quat_rotate(c, k->p), -1.0);
}

/* ---- names --------------------------------------------------------------- */

static const char *const INTERP_NAMES[] = {"linear", "se3", "cubic", "bezier", "bezier-se3", "gsplat"};

int trajectory_interp_parse(const char *name)
{
    for (int k = 0; k < TRAJECTORY_GSPLAT; k++) /* gsplat's is a rolling shutter's, not a file's */
        if (!strcmp(name, INTERP_NAMES[k]))
            return k;
    return -1;
}

const char *trajectory_interp_name(trajectory_interp k) { return INTERP_NAMES[k]; }

int trajectory_min_knots(trajectory_interp k) { return k == TRAJECTORY_CUBIC ? 4 : 2; }

/* ---- checks and bounds ----------------------------------------------------- */

static double rel_angle(const trajectory_knot *a, const trajectory_knot *b)
{
    vec3 p;
    double q[4];
    relative_pose(a, b, &p, q);
    return v3_len(quat_log(q));
}

/* Linear and se3, per segment: the origin moves at |dp|/dt (linear) or
 * |rho|/dt (a screw: point x of the camera frame moves at |phi x x + rho|
 * / dt), and turns at |phi| / dt. */
/* Segment k's speed and turn rate (linear, slerp, se3: the motion over its
 * time; the bounds are their maxima). */
static void segment_rates(const trajectory *tr, int k, double *speed, double *turn_rate)
{
    const trajectory_knot *a = &tr->knots[k], *b = &tr->knots[k + 1];
    double dt = b->t - a->t, q[4];
    vec3 p;
    relative_pose(a, b, &p, q);
    se3_twist x = se3_log(p, q);
    double moved = tr->interp == TRAJECTORY_SE3 ? v3_len(x.rho) : v3_len(v3_sub(b->p, a->p));
    if (tr->interp == TRAJECTORY_GSPLAT) { /* p = -R(u) t(u): |p'| <= |R'| |t(u)| + |t_b - t_a| */
        vec3 ta = world_to_camera_translation(a), tb = world_to_camera_translation(b);
        moved = v3_len(x.phi) * fmax(v3_len(ta), v3_len(tb)) + v3_len(v3_sub(tb, ta));
    }
    *speed = moved / dt, *turn_rate = v3_len(x.phi) / dt;
}

static void segment_bounds(trajectory *tr)
{
    for (int k = 0; k + 1 < tr->count; k++) {
        double speed, turn_rate;
        segment_rates(tr, k, &speed, &turn_rate);
        tr->speed = fmax(tr->speed, speed);
        tr->turn_rate = fmax(tr->turn_rate, turn_rate);
    }
}

/* The first of the segments of shortest time. */
static int shortest_segment(const trajectory *tr)
{
    int shortest = 0;
    for (int k = 1; k + 1 < tr->count; k++)
        if (tr->knots[k + 1].t - tr->knots[k].t < tr->knots[shortest + 1].t - tr->knots[shortest].t)
            shortest = k;
    return shortest;
}

/* Cubic: p' is the quadratic B-spline of the differences / dt (weights
 * >= 0 summing to 1), so |p'| <= max |P_j+1 - P_j| / dt; the body rate of
 * R_0 Exp(B1 L1) Exp(B2 L2) Exp(B3 L3) is at most sum |B_j'| |L_j| / dt,
 * with B1' = (1-u)^2/2 <= 1/2, B2' = (1 + 2u - 2u^2)/2 <= 3/4, B3' =
 * u^2/2 <= 1/2; dt the shortest spacing. */
static void cubic_bounds(trajectory *tr)
{
    int shortest = shortest_segment(tr); /* check_spacing lets the spacings differ by its slack */
    double dt = tr->knots[shortest + 1].t - tr->knots[shortest].t;
    for (int k = 0; k + 1 < tr->count; k++)
        tr->speed = fmax(tr->speed, v3_len(v3_sub(tr->knots[k + 1].p, tr->knots[k].p)) / dt);
    for (int k = 1; k + 2 < tr->count; k++) {
        double l1 = rel_angle(&tr->knots[k - 1], &tr->knots[k]), l2 = rel_angle(&tr->knots[k], &tr->knots[k + 1]);
        double l3 = rel_angle(&tr->knots[k + 1], &tr->knots[k + 2]);
        tr->turn_rate = fmax(tr->turn_rate, (0.5 * l1 + 0.75 * l2 + 0.5 * l3) / dt);
    }
}

/* The largest |P_i+1 - P_i| of n values, each given by get(i). */
static double max_step(const trajectory *tr, vec3 (*get)(const trajectory *, int, int), int part)
{
    double m = 0;
    for (int i = 0; i + 1 < tr->count; i++)
        m = fmax(m, v3_len(v3_sub(get(tr, i + 1, part), get(tr, i, part))));
    return m;
}

static vec3 knot_position(const trajectory *tr, int i, int part) { (void)part; return tr->knots[i].p; }

/* the twist of knot i (absolute, in the file's axes): part 0 phi, 1 rho */
static vec3 knot_twist(const trajectory *tr, int i, int part)
{
    se3_twist x = se3_log(tr->knots[i].p, tr->knots[i].q);
    return part ? x.rho : x.phi;
}

/* Bezier, per component: a Bezier curve of degree n moves at most at n
 * max |P_i+1 - P_i| / span (its hodograph's control points). The
 * quaternions, signs aligned, lie within one hemisphere about m with
 * q_i . m >= c > 0, so |q(u)| >= c and the unit q(u)/|q(u)| turns at
 * 2 |q'| / |q| <= 2 n max |q_i+1 - q_i| / (c span). */
static int bezier_bounds(trajectory *tr, const char *name, rr_error *err)
{
    int n = tr->count - 1;
    for (int i = 1; i <= n; i++) { /* q and -q are one rotation: blend the signs nearest their neighbours */
        double *q = tr->knots[i].q, *prev = tr->knots[i - 1].q;
        if (quat_dot(q, prev) < 0)
            for (int j = 0; j < 4; j++)
                q[j] = -q[j];
    }
    double span = tr->knots[n].t - tr->knots[0].t, m[4] = {0}, c = INFINITY, dq = 0;
    tr->speed = n * max_step(tr, knot_position, 0) / span;
    for (int i = 0; i <= n; i++)
        for (int j = 0; j < 4; j++)
            m[j] += tr->knots[i].q[j];
    double mn = quat_norm(m);
    for (int i = 0; i <= n; i++) {
        const double *q = tr->knots[i].q;
        c = fmin(c, quat_dot(q, m) / mn);
        if (i)
            for (int j = 0; j < 4; j++)
                dq = fmax(dq, fabs(q[j] - tr->knots[i - 1].q[j]));
    }
    if (!(c > 1e-3))
        return rr_fail(err, "%s: the Bezier's control rotations span more than a hemisphere of quaternions (signs "
                            "aligned): per-component blending has no meaning there; use bezier-se3 or cubic", name);
    tr->turn_rate = 2.0 * n * 2.0 * dq / (c * span); /* |dq| <= 2 max component step (4 components) */
    return 0;
}

/* f'(x) for f(x) = (e^x - 1)/x = sum x^k/(k+1)!: bounds how fast V(phi)
 * changes with phi, |dV| <= f'(|phi|) |dphi| (each power of phi^ has norm
 * |phi|^k). */
static double v_rate(double x) { return x < 1e-6 ? 0.5 : ((x - 1.0) * exp(x) + 1.0) / (x * x); }

/* Bezier on se(3): phi(u) and rho(u) are Bezier curves of the knots'
 * twists (|phi(u)| <= max |phi_i|, a convex combination); the rotation
 * Exp(phi) turns at |J_l(phi) phi'| <= |phi'| (J_l's singular values are
 * 1 and 2 |sin(th/2)| / th), and the translation V(phi) rho moves at most
 * at |rho'| + f'(max|phi_i|) |phi'| max |rho_i|. */
static void bezier_se3_bounds(trajectory *tr)
{
    int n = tr->count - 1;
    double span = tr->knots[n].t - tr->knots[0].t, phi_max = 0, rho_max = 0;
    for (int i = 0; i <= n; i++)
        phi_max = fmax(phi_max, v3_len(knot_twist(tr, i, 0))), rho_max = fmax(rho_max, v3_len(knot_twist(tr, i, 1)));
    double dphi = n * max_step(tr, knot_twist, 0) / span, drho = n * max_step(tr, knot_twist, 1) / span;
    tr->turn_rate = dphi;
    tr->speed = drho + v_rate(phi_max) * dphi * rho_max;
}

/* Knot k's place in its file: "line L" (a TUM file) or "frames[k]" (a
 * transforms.json, whose knot k is its frames[k]). */
static const char *knot_place(const trajectory *tr, int k, char buf[32])
{
    if (tr->lines)
        snprintf(buf, 32, "line %ld", tr->lines[k]);
    else
        snprintf(buf, 32, "frames[%d]", k);
    return buf;
}

/* A message's start naming knot k: "name:L: " or "name: frames[k]: ". */
static const char *knot_where(const trajectory *tr, const char *name, int k, char *buf, size_t size)
{
    char place[32];
    if (tr->lines)
        snprintf(buf, size, "%s:%ld: ", name, tr->lines[k]);
    else
        snprintf(buf, size, "%s: %s: ", name, knot_place(tr, k, place));
    return buf;
}

/* A uniform B-spline's times are evenly spaced: each spacing equals the
 * first within 1e-4 of it, plus what binary64 holds the times to (each
 * within half an ulp, 2^-53 |t|; four of them 2^-51 max |t|). The slack
 * is the spacing's, not |t|'s: at Unix times (1.7e9) a slack of 1e-9 |t|
 * let a segment 10x short pass. 1e-4 holds times written to the
 * microsecond, as TUM RGB-D writes them, up to 100 Hz; a spacing off by
 * that moves the path by 1e-4 of a segment's motion, and cubic_bounds
 * takes the shortest spacing, so no segment outruns the bounds. */
static int check_spacing(const trajectory *tr, const char *name, rr_error *err)
{
    double dt = tr->knots[1].t - tr->knots[0].t;
    for (int k = 1; k + 1 < tr->count; k++) {
        double d = tr->knots[k + 1].t - tr->knots[k].t;
        double rounding = 0x1p-51 * fmax(fabs(tr->knots[0].t), fabs(tr->knots[k + 1].t)); /* times increase */
        if (fabs(d - dt) > 1e-4 * dt + rounding) {
            char where[sizeof err->msg], place[32];
            return rr_fail(err, "%sa cubic B-spline needs evenly spaced times: this pose is %.17g after the one "
                                "before (%s), the first two %.17g apart", knot_where(tr, name, k + 1, where,
                           sizeof where), d, knot_place(tr, k, place), dt);
        }
    }
    return 0;
}

/* Log is ambiguous at half a turn: neighbours (the relative forms) or the
 * poses themselves (bezier-se3 takes Log of each) must turn by less. */
static int check_turns(const trajectory *tr, const char *name, rr_error *err)
{
    const double limit = 179.0 * M_PI / 180.0;
    for (int k = 0; k < tr->count; k++) {
        int absolute = tr->interp == TRAJECTORY_BEZIER_SE3;
        if (!absolute && k + 1 == tr->count)
            break;
        double a = absolute ? v3_len(quat_log(tr->knots[k].q)) : rel_angle(&tr->knots[k], &tr->knots[k + 1]);
        if (a > limit)
            return rr_fail(err, absolute ? "%s: pose %d turns by %.2f degrees from the axes: bezier-se3 takes the "
                                           "logarithm of each pose, ambiguous beyond 179"
                                         : "%s: poses %d and the next turn by %.2f degrees: beyond 179 the "
                                           "logarithm between them is ambiguous (add poses in between)",
                           name, k + 1, a * 180.0 / M_PI);
    }
    return 0;
}

/* The bounds overflowed: the times the interpolation divides by are too
 * close for the motion. A Bezier divides by its whole span (its inner
 * times only order the poses); a cubic by its shortest spacing (the
 * spacings are even to a slack); the others by each segment's own time: the
 * first segment whose rate overflows is named, by the line of the pose
 * that ends it (the shortest segment may not move at all). */
static int overflowing_segment(const trajectory *tr)
{
    int shortest = shortest_segment(tr);
    if (tr->interp == TRAJECTORY_CUBIC)
        return shortest;
    for (int k = 0; k + 1 < tr->count; k++) {
        double speed, turn_rate;
        segment_rates(tr, k, &speed, &turn_rate);
        if (!isfinite(speed) || !isfinite(turn_rate))
            return k;
    }
    return shortest;
}

static int fail_too_close(const trajectory *tr, const char *name, rr_error *err)
{
    int bezier = tr->interp == TRAJECTORY_BEZIER || tr->interp == TRAJECTORY_BEZIER_SE3;
    int k = bezier ? 0 : overflowing_segment(tr);
    int from = bezier ? 0 : k;
    k = bezier ? tr->count - 2 : k;
    char where[sizeof err->msg], place[32];
    return rr_fail(err, "%sposes too close in time for their motion: this pose is %.3g after %s's (the motion "
                        "bound overflows)%s", knot_where(tr, name, k + 1, where, sizeof where),
                   tr->knots[k + 1].t - tr->knots[from].t, knot_place(tr, from, place),
                   bezier ? "; a Bezier spans its first pose to its last" : "");
}

int trajectory_prepare(trajectory *tr, const char *name, rr_error *err)
{
    int need = trajectory_min_knots(tr->interp);
    if (tr->count < need)
        return rr_fail(err, "%s: %d pose%s; %s interpolation needs at least %d", name, tr->count,
                       tr->count == 1 ? "" : "s", trajectory_interp_name(tr->interp), need);
    int bezier = tr->interp == TRAJECTORY_BEZIER || tr->interp == TRAJECTORY_BEZIER_SE3;
    if (bezier && tr->count > TRAJECTORY_MAX_BEZIER)
        return rr_fail(err, "%s: %d poses: a Bezier of more than %d control poses (degree %d) is not supported (its "
                            "weights lose all precision): use cubic", name, tr->count, TRAJECTORY_MAX_BEZIER,
                       TRAJECTORY_MAX_BEZIER - 1);
    if ((tr->interp == TRAJECTORY_CUBIC && check_spacing(tr, name, err)) || check_turns(tr, name, err))
        return -1;
    tr->speed = tr->turn_rate = 0;
    if (tr->interp == TRAJECTORY_CUBIC)
        cubic_bounds(tr);
    else if (tr->interp == TRAJECTORY_BEZIER_SE3)
        bezier_se3_bounds(tr);
    else if (tr->interp != TRAJECTORY_BEZIER)
        segment_bounds(tr);
    else if (bezier_bounds(tr, name, err))
        return -1;
    if (!isfinite(tr->speed) || !isfinite(tr->turn_rate))
        return fail_too_close(tr, name, err);
    return 0;
}

/* ---- evaluation ------------------------------------------------------------ */

void trajectory_domain(const trajectory *tr, double *t0, double *t1)
{
    int inner = tr->interp == TRAJECTORY_CUBIC;
    *t0 = tr->knots[inner].t, *t1 = tr->knots[tr->count - 1 - inner].t;
}

/* The segment [t_k, t_k+1] holding t (first..last-1) and its fraction. */
static int segment_of(const trajectory *tr, double t, int first, int last, double *u)
{
    int lo = first, hi = last; /* t_lo <= t <= t_hi */
    while (hi - lo > 1) {
        int mid = lo + (hi - lo) / 2;
        if (tr->knots[mid].t <= t)
            lo = mid;
        else
            hi = mid;
    }
    *u = (t - tr->knots[lo].t) / (tr->knots[lo + 1].t - tr->knots[lo].t);
    return lo;
}

static void pose_linear(const trajectory *tr, double t, vec3 *p, double q[4])
{
    double u;
    int k = segment_of(tr, t, 0, tr->count - 1, &u);
    const trajectory_knot *a = &tr->knots[k], *b = &tr->knots[k + 1];
    *p = v3_add(v3_scale(a->p, 1.0 - u), v3_scale(b->p, u));
    quat_slerp(a->q, b->q, u, q);
}

/* gsplat's rolling-shutter pose between a start and an end pose (v1.5.3
 * 937e299 gsplat/cuda/include/Cameras.cuh:276-288, interpolate_shutter_pose,
 * on the world-to-camera matrices it is given, Cameras.cuh:40-61): t_rs =
 * (1 - u) t_start + u t_end of the world-to-camera translations, and q_rs =
 * normalize(glm::slerp(q_start, q_end, u)), the short arc (glm 33b4a62,
 * the submodule v1.5.3 pins: ext/quaternion_common.inl:41-73; it
 * normalises a lerp below a float epsilon of cos, within 1e-9 of this). The
 * slerp of the world-to-camera quaternions is the inverse of the
 * camera-to-world ones' (q_a^-1 (q_a q_b^-1)^u = (q_a (q_a^-1 q_b)^u)^-1: x^u
 * conjugated is (q x q^-1)^u), so q is linear's; the centre is -R(u) t_rs.
 * It bends off the line between the centres when the camera turns (linear
 * lerps the centre). */
static void pose_gsplat(const trajectory *tr, double t, vec3 *p, double q[4])
{
    double u;
    int k = segment_of(tr, t, 0, tr->count - 1, &u);
    const trajectory_knot *a = &tr->knots[k], *b = &tr->knots[k + 1];
    vec3 ta = world_to_camera_translation(a), tb = world_to_camera_translation(b);
    vec3 tu = v3_add(v3_scale(ta, 1.0 - u), v3_scale(tb, u));
    quat_slerp(a->q, b->q, u, q);
    *p = v3_scale(quat_rotate(q, tu), -1.0);
}

static void pose_se3(const trajectory *tr, double t, vec3 *p, double q[4])
{
    double u, rq[4], eq[4];
    int k = segment_of(tr, t, 0, tr->count - 1, &u);
    const trajectory_knot *a = &tr->knots[k];
    vec3 rp, ep;
    relative_pose(a, &tr->knots[k + 1], &rp, rq);
    se3_twist x = se3_log(rp, rq);
    x.phi = v3_scale(x.phi, u), x.rho = v3_scale(x.rho, u);
    se3_exp(x, &ep, eq);
    *p = v3_add(a->p, quat_rotate(a->q, ep));
    quat_mul(a->q, eq, q);
}

static void pose_cubic(const trajectory *tr, double t, vec3 *p, double q[4])
{
    double u;
    int k = segment_of(tr, t, 1, tr->count - 2, &u);
    const trajectory_knot *c = &tr->knots[k - 1];
    double u2 = u * u, u3 = u2 * u;
    const double b[4] = {(1 - u) * (1 - u) * (1 - u) / 6.0, (3 * u3 - 6 * u2 + 4) / 6.0,
                         (-3 * u3 + 3 * u2 + 3 * u + 1) / 6.0, u3 / 6.0};
    const double cum[3] = {(5 + 3 * u - 3 * u2 + u3) / 6.0, (1 + 3 * u + 3 * u2 - 2 * u3) / 6.0, u3 / 6.0};
    *p = v3(0, 0, 0);
    for (int j = 0; j < 4; j++)
        *p = v3_add(*p, v3_scale(c[j].p, b[j]));
    memcpy(q, c[0].q, 4 * sizeof *q);
    for (int j = 0; j < 3; j++) { /* products on the right, in knot order */
        double e[4];
        quat_between(c[j].q, c[j + 1].q, cum[j], e);
        quat_mul(q, e, q);
    }
}

/* Bernstein weights b_i(u) of degree n into w[0..n]. */
static void bernstein(int n, double u, double *w)
{
    w[0] = 1.0;
    for (int d = 1; d <= n; d++) { /* de Casteljau's recurrence on the weights */
        w[d] = u * w[d - 1];
        for (int i = d - 1; i > 0; i--)
            w[i] = (1.0 - u) * w[i] + u * w[i - 1];
        w[0] *= 1.0 - u;
    }
}

static void pose_bezier(const trajectory *tr, double t, vec3 *p, double q[4])
{
    int n = tr->count - 1, se3 = tr->interp == TRAJECTORY_BEZIER_SE3;
    double w[TRAJECTORY_MAX_BEZIER], s[4] = {0, 0, 0, 0};
    bernstein(n, (t - tr->knots[0].t) / (tr->knots[n].t - tr->knots[0].t), w);
    vec3 a = v3(0, 0, 0), b = v3(0, 0, 0);
    for (int i = 0; i <= n; i++) {
        const trajectory_knot *k = &tr->knots[i];
        if (se3) {
            se3_twist x = se3_log(k->p, k->q);
            a = v3_add(a, v3_scale(x.phi, w[i])), b = v3_add(b, v3_scale(x.rho, w[i]));
            continue;
        }
        a = v3_add(a, v3_scale(k->p, w[i])); /* (signs aligned by trajectory_prepare) */
        for (int j = 0; j < 4; j++)
            s[j] += w[i] * k->q[j];
    }
    if (se3) {
        se3_exp((se3_twist){a, b}, p, q);
        return;
    }
    double len = quat_norm(s);
    *p = a;
    for (int j = 0; j < 4; j++)
        q[j] = s[j] / len;
}

/* The file's axes to OpenCV's: R D with D = diag(1, -1, -1) for OpenGL,
 * a half turn about x: q (x) (0, 1, 0, 0), exact (signs and order only). */
static void to_opencv(const double q[4], double out[4], int opengl)
{
    if (!opengl) {
        memcpy(out, q, 4 * sizeof *q);
        return;
    }
    double r[4] = {-q[1], q[0], q[3], -q[2]};
    memcpy(out, r, sizeof r);
}

void trajectory_pose(const trajectory *tr, double t, vec3 *p, double q[4])
{
    double t0, t1, fq[4];
    trajectory_domain(tr, &t0, &t1);
    t = fmin(fmax(t, t0), t1);
    int through_knots = tr->interp == TRAJECTORY_LINEAR || tr->interp == TRAJECTORY_SE3 ||
                        tr->interp == TRAJECTORY_GSPLAT;
    if (through_knots && t == tr->knots[tr->count - 1].t) { /* u = 1 of the last segment: the knot itself */
        *p = tr->knots[tr->count - 1].p;
        to_opencv(tr->knots[tr->count - 1].q, q, tr->opengl_axes);
        return;
    }
    if (tr->interp == TRAJECTORY_LINEAR) {
        pose_linear(tr, t, p, fq);
    } else if (tr->interp == TRAJECTORY_SE3) {
        pose_se3(tr, t, p, fq);
    } else if (tr->interp == TRAJECTORY_GSPLAT) {
        pose_gsplat(tr, t, p, fq);
    } else if (tr->interp == TRAJECTORY_CUBIC) {
        pose_cubic(tr, t, p, fq);
    } else {
        pose_bezier(tr, t, p, fq);
    }
    to_opencv(fq, q, tr->opengl_axes);
}

void trajectory_quat_to_axes(const double q[4], double out[4], int opengl_axes)
{
    /* back from OpenCV: R D^-1, q (x) (0, -1, 0, 0), exact */
    double w[4] = {q[0], q[1], q[2], q[3]};
    if (opengl_axes)
        w[0] = q[1], w[1] = -q[0], w[2] = -q[3], w[3] = q[2];
    memcpy(out, w, sizeof w);
}

void trajectory_free(trajectory *tr)
{
    free(tr->knots);
    free(tr->lines);
    free(tr->name);
    tr->knots = NULL, tr->lines = NULL, tr->name = NULL;
    tr->count = 0;
}

