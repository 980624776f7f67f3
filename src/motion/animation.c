#include "motion/animation.h"

#include <stdlib.h>

#include "motion/trajectory.h"

double keyframes_clamp_flat(int ch) { return ch <= CH_TZ ? 0.05 * 0.01 : 0.05; }

void animation_init_static(animation *a)
{
    a->offset = v3(0, 0, 0);
    a->velocity = v3(0, 0, 0);
    a->has_rotation = 0;
    a->axis = v3(0, 0, 1);
    a->center = v3(0, 0, 0);
    a->degrees_per_time = 0;
    a->keys = NULL;
    a->path = NULL;
}

void animation_free(animation *a)
{
    if (a->keys)
        for (int i = 0; i < CH_COUNT; i++)
            curve_free(&a->keys->ch[i]);
    free(a->keys);
    a->keys = NULL;
    if (a->path)
        trajectory_free(a->path);
    free(a->path);
    a->path = NULL;
}

static int curve_is_constant(const curve *c)
{
    for (int i = 1; i < c->count; i++)
        if (c->keys[i].value != c->keys[0].value)
            return 0;
    return curve_max_slope(c) == 0;
}

int animation_is_static(const animation *a)
{
    if (a->path)
        return 0;
    if (a->keys) {
        for (int i = 0; i < CH_COUNT; i++)
            if (!curve_is_constant(&a->keys->ch[i]))
                return 0;
        return 1;
    }
    int moves = v3_len(a->velocity) > 0;
    int turns = a->has_rotation && a->degrees_per_time != 0;
    return !moves && !turns;
}

int animation_turns_continuously(const animation *a)
{
    if (a->keys)
        for (int ch = CH_RX; ch <= CH_RZ; ch++)
            if (!curve_is_continuous(&a->keys->ch[ch]))
                return 0;
    return 1;
}

int animation_between_poses(vec3 pa, const double ra[3][3], vec3 pb, const double rb[3][3], double t0, double t1,
                            animation *out, vec3 *rest_position, double rest_rotation[3][3], rr_error *err)
{
    if (!(t1 > t0))
        return rr_fail(err, "the second pose's time (%g) must follow the first's (%g)", t1, t0);
    double rel[3][3]; /* rb ra^T: the turn from a to b, in world */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            rel[i][j] = rb[i][0] * ra[j][0] + rb[i][1] * ra[j][1] + rb[i][2] * ra[j][2];
    vec3 axis;
    double angle = rotation_axis_angle(rel, &axis);
    if (angle > 170.0 * M_PI / 180.0)
        return rr_fail(err, "the poses turn by %.1f degrees: beyond 170 the slerp between them is ambiguous",
                       angle * 180.0 / M_PI);
    /* a velocity or turn rate beyond the double range (poses at 0 and 1e-310)
     * would make the camera NaN: refuse it with the poses' times */
    vec3 velocity = v3_scale(v3_sub(pb, pa), 1.0 / (t1 - t0));
    if (!v3_finite(velocity) || !isfinite(angle / (t1 - t0)) || !isfinite(t0 / (t1 - t0)))
        return rr_fail(err, "the poses' times %g and %g are too close for their motion (the velocity or turn "
                            "rate between them overflows)", t0, t1);
    animation_init_static(out);
    out->velocity = velocity;
    out->has_rotation = angle > 0;
    out->axis = axis;
    out->degrees_per_time = angle * 180.0 / M_PI / (t1 - t0);
    /* at time 0 the pose is a moved back by t0: its position (the turn's
     * centre, so that the turn leaves the position linear) and frame */
    *rest_position = out->center = v3_sub(pa, v3_scale(out->velocity, t0));
    double back[3][3];
    rotation_matrix(axis, -angle * t0 / (t1 - t0), back);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            rest_rotation[i][j] = back[i][0] * ra[0][j] + back[i][1] * ra[1][j] + back[i][2] * ra[2][j];
    return 0;
}

/* ---- linear and rotation -------------------------------------------------- */

static xform rigid_at(const animation *a, double t)
{
    xform x;
    double angle = a->has_rotation ? a->degrees_per_time * t * (M_PI / 180.0) : 0.0;
    rotation_matrix(a->axis, angle, x.r);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            x.ri[i][j] = x.r[j][i];
    x.scaled = 0;
    /* p' = R (p + offset - c) + c + v t  =>  T = R (offset - c) + c + v t */
    x.t = v3(0, 0, 0);
    vec3 rotated = xform_vector(&x, v3_sub(a->offset, a->center));
    x.t = v3_add(v3_add(rotated, a->center), v3_scale(a->velocity, t));
    return x;
}

/* ---- keyframes ------------------------------------------------------------ */

/* Smallest scale used: keys must be positive, but a spline may dip below. */
#define MIN_SCALE 1e-9

static double channel(const keyframes *k, int ch, double t, int left)
{
    const curve *c = &k->ch[ch];
    if (c->count == 0)
        return ch >= CH_SX ? 1.0 : 0.0;
    return left ? curve_eval_left(c, t) : curve_eval(c, t);
}

/* R = Rz Ry Rx: x first, then y, then z (Maya's xyz rotate order). */
static void euler_xyz(double rx, double ry, double rz, double r[3][3])
{
    double X[3][3], Y[3][3], Z[3][3], zy[3][3];
    rotation_matrix(v3(1, 0, 0), rx, X);
    rotation_matrix(v3(0, 1, 0), ry, Y);
    rotation_matrix(v3(0, 0, 1), rz, Z);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            zy[i][j] = Z[i][0] * Y[0][j] + Z[i][1] * Y[1][j] + Z[i][2] * Y[2][j];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[i][j] = zy[i][0] * X[0][j] + zy[i][1] * X[1][j] + zy[i][2] * X[2][j];
}

/* With `left`, the limit from the left (differs at the end of a step). */
static xform keyed_at(const animation *a, double t, int left)
{
    const keyframes *k = a->keys;
    double rot[3][3], sc[3];
    euler_xyz(channel(k, CH_RX, t, left), channel(k, CH_RY, t, left), channel(k, CH_RZ, t, left), rot);
    xform x;
    x.scaled = 0;
    for (int j = 0; j < 3; j++) {
        sc[j] = fmax(channel(k, CH_SX + j, t, left), MIN_SCALE);
        x.scaled |= sc[j] != 1.0;
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            x.r[i][j] = rot[i][j] * sc[j];  /* R S */
            x.ri[i][j] = rot[j][i] / sc[i]; /* S^-1 R^T */
        }
    /* p' = pivot + T + R S (p + offset - pivot) */
    vec3 tr = v3(channel(k, CH_TX, t, left), channel(k, CH_TY, t, left), channel(k, CH_TZ, t, left));
    x.t = v3(0, 0, 0);
    x.t = v3_add(v3_add(k->pivot, tr), xform_vector(&x, v3_sub(a->offset, k->pivot)));
    return x;
}

/* ---- trajectory files ---------------------------------------------------- */

static xform path_at(const animation *a, double t)
{
    xform x;
    vec3 p;
    double q[4];
    trajectory_pose(a->path, t, &p, q);
    quat_matrix(q, x.r);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            x.ri[i][j] = x.r[j][i];
    x.scaled = 0;
    x.t = v3_add(xform_vector(&x, a->offset), p);
    return x;
}

xform animation_pose_at(const animation *a, double t, double q[4])
{
    xform x = animation_at(a, t);
    vec3 p;
    if (a->path) /* the interpolated quaternion itself, not one recovered from x.r */
        trajectory_pose(a->path, t, &p, q);
    else
        quat_of_matrix(x.r, q);
    return x;
}

xform animation_at(const animation *a, double t)
{
    return a->path ? path_at(a, t) : a->keys ? keyed_at(a, t, 0) : rigid_at(a, t);
}

/* ---- bounds over an interval ---------------------------------------------- */

#define GRID_STEPS 64

static void add_sample(double *s, int *n, double t, double t0, double t1)
{
    if (t >= t0 && t <= t1)
        s[(*n)++] = t;
}

/* The spans of a curve's key range that [t0, t1] meets through cycling
 * infinities, as [m_lo, m_hi] in whole spans (0 for none). */
static double cycle_spans(const curve *c, double t0, double t1, double *m_lo)
{
    double k0 = c->keys[0].time, kn = c->keys[c->count - 1].time, span = kn - k0;
    int cycles = c->pre >= INF_CYCLE || c->post >= INF_CYCLE;
    *m_lo = cycles ? floor((t0 - kn) / span) : 0;
    return cycles ? ceil((t1 - k0) / span) - *m_lo : 0;
}

/* How many sample times sample_times lists (before it keeps only those
 * inside [t0, t1]): a double, as a long shutter over a cycling curve can
 * ask for more than any integer holds. */
static double sample_count(const animation *a, double t0, double t1)
{
    double n = GRID_STEPS + 1 + (a->path ? a->path->count : 0), m_lo;
    for (int ch = 0; a->keys && ch < CH_COUNT; ch++) {
        const curve *c = &a->keys->ch[ch];
        if (c->count >= 2)
            n += (cycle_spans(c, t0, t1, &m_lo) + 1) * 2.0 * c->count;
    }
    return n;
}

double animation_key_times(const animation *a, double t0, double t1)
{
    return animation_is_static(a) ? 0 : sample_count(a, t0, t1);
}

/* Key times of a curve inside [t0, t1], repeated (and mirrored) through
 * cycling infinities, where a step may jump: every one, or the swept
 * bounds miss a jump (a cap of 65,536 once dropped the later ones). The
 * spans are counted with an integer: far from the keys (a shutter at
 * 1e18 s) m + 1 == m in doubles and a loop over m would never end. */
static void add_key_times(const curve *c, double *s, int *n, double t0, double t1)
{
    if (c->count < 2)
        return;
    double k0 = c->keys[0].time, kn = c->keys[c->count - 1].time, span = kn - k0, m_lo;
    long spans = (long)cycle_spans(c, t0, t1, &m_lo);
    for (long j = 0; j <= spans; j++) {
        double m = m_lo + (double)j;
        for (int i = 0; i < c->count; i++) {
            add_sample(s, n, c->keys[i].time + m * span, t0, t1);
            add_sample(s, n, k0 + kn - c->keys[i].time + m * span, t0, t1);
        }
    }
}

/* Sorted sample times over [t0, t1]: a grid plus every key time. NULL when
 * there are more than ANIMATION_MAX_KEY_TIMES (accel refuses such a
 * shutter, naming the object) or out of memory: callers take no bound. */
static double *sample_times(const animation *a, double t0, double t1, int *n)
{
    double count = sample_count(a, t0, t1);
    if (!(count <= ANIMATION_MAX_KEY_TIMES))
        return NULL;
    double *s = malloc((size_t)count * sizeof *s);
    if (!s)
        return NULL;
    *n = 0;
    for (int i = 0; i <= GRID_STEPS; i++)
        s[(*n)++] = t0 + (t1 - t0) * i / GRID_STEPS;
    if (a->keys)
        for (int c = 0; c < CH_COUNT; c++)
            add_key_times(&a->keys->ch[c], s, n, t0, t1);
    for (int k = 0; a->path && k < a->path->count; k++) /* where the interpolation changes segment */
        add_sample(s, n, a->path->knots[k].t, t0, t1);
    RR_DCHECK_LE(*n, count);
    qsort(s, (size_t)*n, sizeof *s, cmp_double);
    return s;
}

static double largest_gap(const double *s, int n)
{
    double g = 0;
    for (int i = 1; i < n; i++)
        g = fmax(g, s[i] - s[i - 1]);
    return g;
}

static double max_slope_of(const keyframes *k, int first, int count)
{
    double m = 0;
    for (int c = first; c < first + count; c++)
        m = fmax(m, curve_max_slope(&k->ch[c]));
    return m;
}

/* Largest scale at the samples s (both sides of each), plus what the
 * scale's slope allows between them. */
static double max_scale_over(const animation *a, const double *s, int n)
{
    double m = 0;
    for (int i = 0; i < n; i++)
        for (int c = CH_SX; c <= CH_SZ; c++)
            m = fmax(m, fmax(channel(a->keys, c, s[i], 0), channel(a->keys, c, s[i], 1)));
    return m + max_slope_of(a->keys, CH_SX, 3) * largest_gap(s, n) * 0.5;
}

/* Smallest scale at the samples (both sides of each), less what the
 * scale's slope allows between them, never below the clamp keyed_at uses. */
static double min_scale_over(const animation *a, const double *s, int n)
{
    double m = INFINITY;
    for (int i = 0; i < n; i++)
        for (int c = CH_SX; c <= CH_SZ; c++)
            m = fmin(m, fmin(channel(a->keys, c, s[i], 0), channel(a->keys, c, s[i], 1)));
    return fmax(m - max_slope_of(a->keys, CH_SX, 3) * largest_gap(s, n) * 0.5, MIN_SCALE);
}

/* Whether channel ch reaches MIN_SCALE on (a, b), an interval holding no
 * key time, where it is va just after a and vb just before b: its slope is
 * at most L there, so its minimum is at least (va + vb - L (b - a)) / 2;
 * where that does not decide, halve. A spline between positive keys can
 * overshoot below zero between the sample times. Past the budget of
 * evaluations the answer is yes: a scale that close to zero so long is
 * already vanishing. */
static int reaches_min_scale(const keyframes *k, int ch, double a, double va, double b, double vb, double L,
                             int *budget)
{
    if (!(va > MIN_SCALE) || !(vb > MIN_SCALE))
        return 1;
    if ((va + vb - L * (b - a)) * 0.5 > MIN_SCALE)
        return 0;
    double m = 0.5 * (a + b);
    if (!(m > a && m < b)) /* no time in between */
        return 0;
    if (--*budget < 0)
        return 1;
    double vm = channel(k, ch, m, 0);
    return reaches_min_scale(k, ch, a, va, m, vm, L, budget) || reaches_min_scale(k, ch, m, vm, b, vb, L, budget);
}

int animation_scale_clamped(const animation *a, double t0, double t1)
{
    if (!a->keys)
        return 0;
    int n, clamped = 0, budget = 1 << 16;
    double *s = sample_times(a, t0, t1, &n);
    for (int c = CH_SX; s && c <= CH_SZ && !clamped; c++) {
        double L = curve_max_slope(&a->keys->ch[c]);
        clamped = !(channel(a->keys, c, s[0], 1) > MIN_SCALE) || !(channel(a->keys, c, s[n - 1], 0) > MIN_SCALE);
        for (int i = 0; i + 1 < n && !clamped; i++) /* between samples, and on both sides of each */
            clamped = reaches_min_scale(a->keys, c, s[i], channel(a->keys, c, s[i], 0), s[i + 1],
                                        channel(a->keys, c, s[i + 1], 1), L, &budget);
    }
    free(s);
    return clamped;
}

/* The largest (or smallest) scale over [t0, t1]; out of memory: no bound. */
static double scale_extreme(const animation *a, double t0, double t1, int largest)
{
    if (!a->keys)
        return 1.0;
    int n;
    double *s = sample_times(a, t0, t1, &n);
    if (!s)
        return largest ? INFINITY : MIN_SCALE;
    double m = largest ? max_scale_over(a, s, n) : min_scale_over(a, s, n);
    free(s);
    return m;
}

double animation_max_scale(const animation *a, double t0, double t1) { return scale_extreme(a, t0, t1, 1); }

double animation_min_scale(const animation *a, double t0, double t1) { return scale_extreme(a, t0, t1, 0); }

static void add_transformed_box(aabb *out, const xform *x, aabb b)
{
    for (int i = 0; i < 8; i++) {
        vec3 p = v3(i & 1 ? b.hi.x : b.lo.x, i & 2 ? b.hi.y : b.lo.y, i & 4 ? b.hi.z : b.lo.z);
        aabb_add_point(out, xform_point(x, p));
    }
}

/* Farthest corner of the box b (shifted by offset) from the point c. */
static double box_reach(aabb b, vec3 offset, vec3 c)
{
    double reach = 0;
    for (int i = 0; i < 8; i++) {
        vec3 p = v3(i & 1 ? b.hi.x : b.lo.x, i & 2 ? b.hi.y : b.lo.y, i & 4 ? b.hi.z : b.lo.z);
        reach = fmax(reach, v3_len(v3_sub(v3_add(p, offset), c)));
    }
    return reach;
}

/* Speed of a point p (model coordinates): at most linear + angular *
 * |p - center|. Rigid: |v| + |omega| |p + offset - c|. Keyframes,
 * p' = pivot + T + R S q with q = p + offset - pivot:
 * |dp'/dt| <= |T'| + |R'| |S q| + |S' q| with |R'| <= |rx'| + |ry'| + |rz'|
 * (each Euler factor is a rotation at that rate). */
static motion_bound motion_bound_over(const animation *a, const double *s, int n) /* s: the sample times */
{
    motion_bound m = {0, 0, v3(0, 0, 0), 0, 0};
    if (a->path) { /* trajectory_prepare's bounds over the whole path; it turns about its origin */
        m = (motion_bound){a->path->speed, a->path->turn_rate, v3_scale(a->offset, -1.0), a->path->turn_rate, 0.0};
        return m;
    }
    if (!a->keys) {
        double omega = a->has_rotation ? fabs(a->degrees_per_time) * M_PI / 180.0 : 0.0;
        m = (motion_bound){v3_len(a->velocity), omega, v3_sub(a->center, a->offset), omega, 0.0};
        return m;
    }
    const keyframes *k = a->keys;
    double dt = 0, dr = 0, ds = max_slope_of(k, CH_SX, 3);
    for (int c = CH_TX; c <= CH_TZ; c++)
        dt += pow(curve_max_slope(&k->ch[c]), 2);
    for (int c = CH_RX; c <= CH_RZ; c++)
        dr += curve_max_slope(&k->ch[c]);
    m = (motion_bound){sqrt(dt), dr * max_scale_over(a, s, n) + ds, v3_sub(k->pivot, a->offset), dr, ds};
    return m;
}

static double speed_bound(const animation *a, aabb b, const double *s, int n)
{
    motion_bound m = motion_bound_over(a, s, n);
    return m.linear + m.angular * box_reach(b, v3(0, 0, 0), m.center);
}

motion_bound animation_motion_bound(const animation *a, double t0, double t1)
{
    motion_bound none = {0, 0, v3(0, 0, 0), 0, 0};
    if (animation_is_static(a))
        return none;
    int n;
    double *s = sample_times(a, t0, t1, &n);
    if (!s) { /* out of memory: no bound */
        none.linear = none.angular = none.turn = none.scale_rate = INFINITY;
        return none;
    }
    motion_bound m = motion_bound_over(a, s, n);
    free(s);
    return m;
}

aabb animation_swept_bounds(const animation *a, aabb b, double t0, double t1)
{
    aabb out = aabb_empty();
    if (animation_is_static(a)) {
        xform x = animation_at(a, t0);
        add_transformed_box(&out, &x, b);
        return out;
    }
    int n;
    double *s = sample_times(a, t0, t1, &n);
    if (!s) { /* out of memory: the whole space is conservative */
        out.lo = v3(-INFINITY, -INFINITY, -INFINITY), out.hi = v3(INFINITY, INFINITY, INFINITY);
        return out;
    }
    for (int i = 0; i < n; i++) {
        xform x = animation_at(a, s[i]);
        add_transformed_box(&out, &x, b);
        if (a->keys) { /* both sides of a possible jump */
            x = keyed_at(a, s[i], 1);
            add_transformed_box(&out, &x, b);
        }
    }
    /* Between two samples the motion is continuous, and a point is at most
     * speed * gap / 2 from where it was at the nearer sample. */
    double pad = speed_bound(a, b, s, n) * largest_gap(s, n) * 0.5;
    free(s);
    out.lo = v3_sub(out.lo, v3(pad, pad, pad));
    out.hi = v3_add(out.hi, v3(pad, pad, pad));
    return out;
}
