/* gaussian_dynamic.c and gaussian_stg_ply.c: SpacetimeGaussians-lite
 * models at a time t against values worked by hand from the official rules
 * (SpacetimeGaussians 427abfc5: forward_lite forward.cu:186-204 and
 * 127-138, scene/ourslite.py:40 and 123-126, renderer/__init__.py:318-343),
 * their motion bounds against 20,000 steps of the path, the reader's
 * refusals, and the renderer's bounds of a moving Gaussian (its reach at
 * 20,000 times, and the BVH listing it there). */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <unistd.h>

#include "accel/accel.h"
#include "core/inputfile.h"
#include "gaussians/gaussian.h"
#include "core/rotation.h"
#include "gaussians/gaussian_stg.h"
#include "formats/gaussian_ply.h"
#include "formats/gaussian_dynamic_ply.h"
#include "scenexml/scene_xml.h"
#include "gaussian_test_util.h"
#include "harness.h"

/* ---- models written as ascii PLY in the save_ply order ------------------ */

static const char *const STG_ORDER[] = {
    "x", "y", "z", "trbf_center", "trbf_scale", "nx", "ny", "nz", "motion_0", "motion_1", "motion_2", "motion_3",
    "motion_4", "motion_5", "motion_6", "motion_7", "motion_8", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0",
    "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3", "omega_0", "omega_1", "omega_2", "omega_3"};
enum { N_PROPS = 32 };

/* One Gaussian's 32 values by name, in save_ply's order. */
typedef struct {
    double x[3], center, tscale, motion[9], dc[3], opacity, scale[3], rot[4], omega[4];
} stg_row;

static void row_values(const stg_row *r, double v[N_PROPS])
{
    double tmp[N_PROPS] = {r->x[0], r->x[1], r->x[2], r->center, r->tscale, 0, 0, 0};
    memcpy(&tmp[8], r->motion, sizeof r->motion);
    memcpy(&tmp[17], r->dc, sizeof r->dc);
    tmp[20] = r->opacity;
    memcpy(&tmp[21], r->scale, sizeof r->scale);
    memcpy(&tmp[24], r->rot, sizeof r->rot);
    memcpy(&tmp[28], r->omega, sizeof r->omega);
    memcpy(v, tmp, sizeof tmp);
}

/* An ascii PLY of the rows; skip names a property to leave out (NULL:
 * none), extra one to add (value 0). */
static size_t write_ply(char *buf, size_t size, const stg_row *rows, int n, const char *skip, const char *extra)
{
    size_t len = ply_ascii_header(buf, size, n, STG_ORDER, N_PROPS, skip, extra);
    for (int i = 0; i < n; i++) {
        double v[N_PROPS];
        row_values(&rows[i], v);
        len = ply_ascii_row(buf, size, len, STG_ORDER, v, N_PROPS, 9, skip, extra);
    }
    return len;
}

static int parse_rows(const stg_row *rows, int n, gaussian_model *m, rr_error *e)
{
    static char buf[1 << 16];
    size_t len = write_ply(buf, sizeof buf, rows, n, NULL, NULL);
    return parse_gaussian_text("stg.ply", buf, len, m, e);
}

/* x = (1, 2, 3), trbf_center 0.25, exp(trbf_scale) = 1, motion in
 * eighths (exact in floats), sigmoid(opacity) = 1/2. */
static stg_row hand_row(void)
{
    stg_row r = {{1, 2, 3}, 0.25, 0, {0.5, -1, 2, 0.25, 0.125, -0.5, 1, 0, -2}, {0.25, -0.125, 1.5}, 0, {0, -1, 1},
                 {1, 0, 0, 0}, {0, 0, 0, 1}};
    return r;
}

/* ---- evaluation ---------------------------------------------------------- */

/* mean = x + v D + a D^2 + j D^3 (forward.cu:196-198) at D = 1, -1, 2; the
 * opacity sigmoid(0) exp(-D^2) (forward.cu:202-204: no 1/2); the scales
 * exp(scale), constant; f_dc as the colour, not SH (no +0.5, no clamp of
 * -0.125). */
TEST(a_moving_gaussian_at_t_is_the_official_rules_worked_by_hand)
{
    stg_row r = hand_row();
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(&r, 1, &m, &e) == 0 && m.dynamic && m.count == 1 && m.kind == GAUSSIAN_3D);
    if (!m.dynamic)
        return;
    const double Ds[3] = {1, -1, 2};
    for (int s = 0; s < 3; s++) {
        double D = Ds[s], t = 0.25 + D;
        gaussian_dynamic_state st;
        gaussian_dynamic_at(&m, 0, t, &st);
        for (int k = 0; k < 3; k++) {
            double want = r.x[k] + r.motion[k] * D + r.motion[3 + k] * D * D + r.motion[6 + k] * D * D * D;
            CHECK(st.mean[k] == want);
            CHECK_NEAR(st.scale[k], exp(r.scale[k]), 1e-6 * exp(r.scale[k]));
            CHECK(st.rgb[k] == r.dc[k]);
        }
        CHECK_NEAR(st.opacity, 0.5 * exp(-D * D), 1e-15);
    }
    gaussian_dynamic_state st;
    gaussian_dynamic_at(&m, 0, 0.25, &st); /* D = 0: the peak */
    CHECK(st.opacity == 0.5 && st.mean[0] == 1 && st.mean[1] == 2 && st.mean[2] == 3);
    gaussian_model_free(&m);
}

/* The temporal scale divides D: exp(trbf_scale) = 2 halves the decay's
 * exponent's root: opacity at D = 2 is sigmoid exp(-1). */
TEST(the_temporal_scale_is_exp_of_trbf_scale)
{
    stg_row r = hand_row();
    r.tscale = log(2.0), r.opacity = log(3.0); /* sigmoid(log 3) = 3/4 */
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(&r, 1, &m, &e) == 0 && m.dynamic && m.count == 1);
    if (!m.dynamic || m.count != 1) /* a failed read fails this test, not the harness */
        return;
    gaussian_dynamic_state st;
    gaussian_dynamic_at(&m, 0, 0.25 + 2, &st);
    CHECK_NEAR(st.opacity, 0.75 * exp(-1.0), 1e-7);
    gaussian_model_free(&m);
}

/* rot + omega D normalised once (F.normalize): (1,0,0,0) + (0,0,0,1) D at
 * D = 1 is a quarter turn about z; a non-unit rot (2,0,0,0) with omega
 * (0,0,0,2) gives the same (normalising rot first would give
 * (1,0,0,2)/sqrt 5). */
TEST(the_rotation_is_rot_plus_omega_d_normalised_once)
{
    stg_row r[2] = {hand_row(), hand_row()};
    r[1].rot[0] = 2, r[1].omega[3] = 2;
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(r, 2, &m, &e) == 0 && m.dynamic && m.count == 2);
    if (!m.dynamic || m.count != 2)
        return;
    for (size_t i = 0; i < 2; i++) {
        gaussian_dynamic_state st;
        gaussian_dynamic_at(&m, i, 1.25, &st);
        double R[3][3], s = sqrt(0.5);
        CHECK_NEAR(st.q[0], s, 1e-15);
        CHECK(st.q[1] == 0 && st.q[2] == 0);
        CHECK_NEAR(st.q[3], s, 1e-15);
        quat_unit_matrix(st.q[0], st.q[1], st.q[2], st.q[3], R); /* forward.cu:134-138: q as it is */
        const double want[3][3] = {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}};
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                CHECK_NEAR(R[a][b], want[a][b], 1e-15);
    }
    gaussian_model_free(&m);
}

/* rot 0 (STG adds Gaussians so: ourslite.py:1235) is read, stays 0 where
 * rot + omega D is 0 (F.normalize divides by max(|v|, 1e-12)), and the
 * CUDA's matrix of q = 0 is the identity (forward.cu:134-138: 1 - 2(...)
 * on the diagonal, 2(...) off it); with omega (0,2,0,0), at D = 1/2 it is
 * the half turn about x. Below |v| = 1e-12 the quaternion is v / 1e-12, a
 * short one, whose matrix the CUDA takes as it is: (0, 0.1, 0, 0) gives
 * diag(1, 0.98, 0.98), no rotation. */
TEST(a_zero_or_tiny_rotation_is_what_the_cuda_computes)
{
    stg_row r[3] = {hand_row(), hand_row(), hand_row()};
    memset(r[0].rot, 0, sizeof r[0].rot), memset(r[0].omega, 0, sizeof r[0].omega);
    memset(r[1].rot, 0, sizeof r[1].rot), memset(r[1].omega, 0, sizeof r[1].omega), r[1].omega[1] = 2;
    memset(r[2].rot, 0, sizeof r[2].rot), memset(r[2].omega, 0, sizeof r[2].omega), r[2].rot[1] = 1e-13;
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(r, 3, &m, &e) == 0 && m.count == 3);
    if (m.count != 3)
        return;
    gaussian_dynamic_state st;
    double R[3][3];
    gaussian_dynamic_at(&m, 0, 0.9, &st);
    CHECK(st.q[0] == 0 && st.q[1] == 0 && st.q[2] == 0 && st.q[3] == 0);
    quat_unit_matrix(st.q[0], st.q[1], st.q[2], st.q[3], R); /* forward.cu:134-138: q as it is */
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            CHECK(R[a][b] == (a == b));
    gaussian_dynamic_at(&m, 1, 0.25, &st); /* D = 0: v = 0 */
    CHECK(st.q[0] == 0 && st.q[1] == 0 && st.q[2] == 0 && st.q[3] == 0);
    gaussian_dynamic_at(&m, 1, 0.75, &st); /* D = 1/2: v = (0, 1, 0, 0) */
    quat_unit_matrix(st.q[0], st.q[1], st.q[2], st.q[3], R); /* forward.cu:134-138: q as it is */
    CHECK(R[0][0] == 1 && R[1][1] == -1 && R[2][2] == -1 && R[0][1] == 0 && R[1][2] == 0);
    gaussian_dynamic_at(&m, 2, 0.25, &st);
    CHECK_NEAR(st.q[1], 0.1, 1e-8);
    quat_unit_matrix(st.q[0], st.q[1], st.q[2], st.q[3], R); /* forward.cu:134-138: q as it is */
    CHECK(R[0][0] == 1);
    CHECK_NEAR(R[1][1], 0.98, 1e-8);
    CHECK_NEAR(R[2][2], 0.98, 1e-8);
    gaussian_model_free(&m);
}

/* ---- bounds over [t0, t1] ----------------------------------------------- */

/* A model of n Gaussians built in memory (no file). */
static void alloc_model(gaussian_model *m, size_t n)
{
    gaussian_model_init(m);
    m->kind = GAUSSIAN_3D, m->sh_degree = 0, m->sh_coeffs = 1;
    CHECK(gaussian_model_alloc(m, n) == 0 && (m->dynamic = gaussian_stg_alloc(n)) != NULL);
    m->count = n;
}

/* Gaussian i of the given kind: 0 roots of the velocity r1, r2 (g = p' =
 * A (D - r1)(D - r2): extrema inside the interval), 1 random coefficients
 * up to 60 (fast movers), 2 a path a few ulps long at an offset of 1000,
 * 3 a double root, 4 a parabola with its vertex inside. */
static void random_gaussian(gaussian_model *m, size_t i, uint64_t *s, int kind)
{
    gaussian_stg *d = gaussian_stg_of(m);
    d->trbf_center[i] = (float)lcg_uniform(s, 0, 1);
    d->trbf_scale[i] = (float)lcg_uniform(s, -3, 1);
    m->opacity[i] = (float)lcg_uniform(s, 0.01, 0.99);
    for (int k = 0; k < 3; k++) {
        double off = kind == 2 ? lcg_uniform(s, 500, 2000) : lcg_uniform(s, -3, 3), size = kind == 1 ? 60 : 1;
        double *c = NULL, co[3];
        if (kind == 0 || kind == 3) { /* roots of p' in [-1.2, 1.2]; kind 3: a double root */
            double A = lcg_uniform(s, -20, 20), r1 = lcg_uniform(s, -1.2, 1.2), r2 = kind == 3 ? r1 : lcg_uniform(s, -1.2, 1.2);
            co[0] = A * r1 * r2, co[1] = -A * (r1 + r2) / 2, co[2] = A / 3, c = co;
        } else if (kind == 4) { /* a parabola (no D^3): p' linear, its root inside */
            double a = lcg_uniform(s, -30, 30), r = lcg_uniform(s, -1.2, 1.2);
            co[0] = -2 * a * r, co[1] = a, co[2] = 0, c = co;
        } else if (kind == 2) { /* a path of a few ulps of its offset: rounding decides */
            for (int j = 0; j < 3; j++)
                co[j] = lcg_uniform(s, -1, 1) * 4e-13;
            c = co;
        } else {
            for (int j = 0; j < 3; j++)
                co[j] = lcg_uniform(s, -size, size);
            c = co;
        }
        m->mean[3 * i + k] = (float)off;
        for (int j = 0; j < 3; j++)
            d->motion[9 * i + 3 * j + k] = (float)c[j];
    }
}

/* The path exactly (in long double, 64-bit significand: its rounding is
 * 2^11 times below the bound's padding). */
static long double exact_coordinate(const gaussian_model *m, size_t i, int k, double t)
{
    const float *mo = &gaussian_stg_of(m)->motion[9 * i];
    long double D = (long double)t - gaussian_stg_of(m)->trbf_center[i];
    return m->mean[3 * i + k] + D * (mo[k] + D * (mo[3 + k] + D * (long double)mo[6 + k]));
}

/* Checks the box and opacity bound of Gaussian i over [t0, t1] against
 * 20,000 steps; *slack gets the largest gap between the box and the
 * sampled hull beyond what the step size explains (so a loose box shows). */
static int bounds_hold(const gaussian_model *m, size_t i, double t0, double t1, double *slack)
{
    double lo[3], hi[3], omax, smin[3], smax[3];
    if (gaussian_dynamic_bounds(m, i, t0, t1, lo, hi, &omax))
        return 0;
    int ok = 1;
    const int steps = 20000;
    for (int k = 0; k < 3; k++)
        smin[k] = INFINITY, smax[k] = -INFINITY;
    for (int j = 0; j <= steps; j++) {
        double t = j == steps ? t1 : t0 + (t1 - t0) * j / steps;
        gaussian_dynamic_state st;
        gaussian_dynamic_at(m, i, t, &st);
        ok &= st.opacity <= omax;
        for (int k = 0; k < 3; k++) {
            long double x = exact_coordinate(m, i, k, t);
            ok &= st.mean[k] >= lo[k] && st.mean[k] <= hi[k] && x >= lo[k] && x <= hi[k];
            smin[k] = fmin(smin[k], st.mean[k]), smax[k] = fmax(smax[k], st.mean[k]);
        }
    }
    /* tightness: the nearest step to an interior extremum is dt/2 away,
     * where p falls by at most max|p''| dt^2 / 8; plus the padding */
    const float *mo = &gaussian_stg_of(m)->motion[9 * i];
    double R = fmax(fabs(t0 - gaussian_stg_of(m)->trbf_center[i]), fabs(t1 - gaussian_stg_of(m)->trbf_center[i])), dt = (t1 - t0) / steps;
    for (int k = 0; k < 3; k++) {
        double curv = 2 * fabs(mo[3 + k]) + 6 * fabs(mo[6 + k]) * R;
        double M = fabs(m->mean[3 * i + k]) + fabs(mo[k]) * R + fabs(mo[3 + k]) * R * R + fabs(mo[6 + k]) * R * R * R;
        double explained = curv * dt * dt / 8 + 64 * DBL_EPSILON * M;
        *slack = fmax(*slack, fmax(smin[k] - lo[k], hi[k] - smax[k]) - explained);
    }
    return ok;
}

/* Random Gaussians (extrema inside the interval, double roots, parabolas,
 * fast movers of 60 units a time unit, paths a few ulps long at offsets of
 * 1000) over random
 * intervals: every step's mean (as computed and exact) lies in the box and
 * its opacity under the bound, and the box is no wider than the samples
 * plus what the step size and the padding explain. */
TEST(motion_bounds_hold_20000_steps_of_the_path)
{
    const size_t n = 400;
    gaussian_model m;
    alloc_model(&m, n);
    uint64_t seed = 12345;
    int failures = 0;
    double slack = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        random_gaussian(&m, i, &seed, (int)(i % 5));
        double c = gaussian_stg_of(&m)->trbf_center[i], t0 = c + lcg_uniform(&seed, -1.2, 0.2), t1 = t0 + lcg_uniform(&seed, 0, 1.4);
        if (i % 50 == 7)
            t1 = t0; /* an instant */
        failures += !bounds_hold(&m, i, t0, t1, &slack);
    }
    printf("    %d of %zu Gaussians left the box; box beyond the samples by %.3g\n", failures, n, slack);
    CHECK(failures == 0);
    CHECK(slack <= 0);
    double lo[3], hi[3], om;
    CHECK(gaussian_dynamic_bounds(&m, 0, -1e300, 0, lo, hi, &om) == -1); /* D^3 overflows: no box */
    gaussian_model_free(&m);
}

/* The opacity bound is the RBF at trbf_center clamped into [t0, t1]:
 * sigmoid(o) inside, sigmoid(o) exp(-(t0 - c)^2) after it. */
TEST(the_opacity_bound_is_the_rbf_at_the_clamped_centre)
{
    stg_row r = hand_row();
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(&r, 1, &m, &e) == 0 && m.dynamic && m.count == 1);
    if (!m.dynamic || m.count != 1)
        return;
    double lo[3], hi[3], om;
    CHECK(gaussian_dynamic_bounds(&m, 0, 0, 1, lo, hi, &om) == 0);
    CHECK(om >= 0.5 && om <= 0.5 * (1 + 1e-14));
    CHECK(gaussian_dynamic_bounds(&m, 0, 1.25, 2, lo, hi, &om) == 0);
    CHECK(om >= 0.5 * exp(-1.0) && om <= 0.5 * exp(-1.0) * (1 + 1e-14));
    CHECK(gaussian_dynamic_bounds(&m, 0, -2.75, -0.75, lo, hi, &om) == 0);
    CHECK(om >= 0.5 * exp(-1.0) && om <= 0.5 * exp(-1.0) * (1 + 1e-14));
    gaussian_model_free(&m);
}

/* ---- the reader --------------------------------------------------------- */

static int refused(const char *skip, const char *extra, gaussian_kind kind, const char *needle)
{
    static char buf[1 << 14];
    stg_row r = hand_row();
    size_t len = write_ply(buf, sizeof buf, &r, 1, skip, extra);
    return gaussian_text_refused("stg.ply", buf, len, kind, needle);
}

TEST(stg_files_that_are_not_whole_lite_models_are_refused_by_name)
{
    CHECK(refused("omega_2", NULL, GAUSSIAN_AUTO, "lacks the vertex properties 'omega_2'"));
    CHECK(refused("trbf_center", NULL, GAUSSIAN_AUTO, "lacks the vertex properties 'trbf_center'"));
    CHECK(refused(NULL, "f_t_0", GAUSSIAN_AUTO, "'f_t_0': a SpacetimeGaussians \"full\" model"));
    CHECK(refused(NULL, "f_dc_3", GAUSSIAN_AUTO, "needs STG's per-pixel MLP, not supported"));
    CHECK(refused(NULL, "f_rest_0", GAUSSIAN_AUTO, "'f_rest_0'"));
    CHECK(refused(NULL, NULL, GAUSSIAN_2D, "kind 2dgs cannot read it"));
    /* a static model with one STG property is no static model either */
    const char *lone = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                       "property float motion_0\nend_header\n0 0 0 1\n";
    gaussian_model m;
    rr_error e;
    gaussian_model_init(&m);
    CHECK(gaussian_parse("lone.ply", lone, strlen(lone), GAUSSIAN_AUTO, &m, &e) == -1 && strstr(e.msg, "lone.ply") &&
          strstr(e.msg, "'trbf_center'") && strstr(e.msg, "'omega_3'"));
}

TEST(stg_values_beyond_what_the_official_code_holds_are_refused)
{
    static char buf[1 << 14];
    stg_row r = hand_row();
    r.tscale = -100; /* exp(-100) is no normal float */
    size_t len = write_ply(buf, sizeof buf, &r, 1, NULL, NULL);
    CHECK(gaussian_text_refused("s.ply", buf, len, GAUSSIAN_AUTO, "'trbf_scale' = -100"));
    r = hand_row(), r.x[1] = 1e16;
    len = write_ply(buf, sizeof buf, &r, 1, NULL, NULL);
    CHECK(gaussian_text_refused("s.ply", buf, len, GAUSSIAN_AUTO, "'y'"));
}

/* Opens of `path` the kernel saw (inotify's IN_OPEN) while gaussian_read
 * read it: an independent count of how often the file is read. */
static int opens_while_reading(const char *path, gaussian_model *m, uint64_t *h, int *rc)
{
    rr_error e;
    int fd = inotify_init1(IN_NONBLOCK);
    /* closes watched too: inotify merges an event with an identical unread one
     * before it, so two opens in a row would count as one */
    int wd = fd >= 0 ? inotify_add_watch(fd, path, IN_OPEN | IN_CLOSE) : -1;
    *rc = gaussian_read(path, GAUSSIAN_AUTO, m, h, NULL, &e);
    int opens = 0;
    char events[4096] __attribute__((aligned(__alignof__(struct inotify_event))));
    ssize_t n;
    while (wd >= 0 && (n = read(fd, events, sizeof events)) > 0)
        for (char *p = events; p < events + n; p += sizeof(struct inotify_event) + ((struct inotify_event *)p)->len)
            opens += (((struct inotify_event *)p)->mask & IN_OPEN) != 0;
    if (fd >= 0)
        close(fd);
    return wd >= 0 ? opens : -1;
}

/* From a file: the static reader sees the layout in the header and hands
 * the bytes it holds over, so the file is opened once (counted by the
 * kernel) and its bytes hashed once (the hash of one pass over them). It
 * was read twice, the failed static pass hashing every byte it had not
 * parsed. */
TEST(an_stg_file_is_read_and_hashed_once)
{
    static char buf[1 << 14];
    stg_row r = hand_row();
    size_t len = write_ply(buf, sizeof buf, &r, 1, NULL, NULL);
    char path[] = "/tmp/refrender-stg-XXXXXX";
    int fd = mkstemp(path);
    FILE *f = fd >= 0 ? fdopen(fd, "wb") : NULL;
    CHECK(f && fwrite(buf, 1, len, f) == len);
    if (f)
        fclose(f);
    gaussian_model m;
    rr_error e;
    gaussian_model_init(&m);
    uint64_t h = 777;
    int rc, opens = opens_while_reading(path, &m, &h, &rc);
    CHECK(opens == 1);
    CHECK(rc == 0 && m.dynamic && m.count == 1);
    CHECK(h == input_hash(777, buf, len));
    CHECK(gaussian_write_ply(path, &m, &e) == -1 && strstr(e.msg, "SpacetimeGaussians")); /* motion would be lost */
    gaussian_model_free(&m);
    CHECK(m.dynamic == NULL);
    remove(path);
}

/* ---- what the renderer draws, and its bounds ------------------------------ */

/* Gaussian i of m at time t as the one static Gaussian `one` (m's kind and
 * formation over the arrays in `store`), as the renderer draws it
 * (gaussian_dynamic_instant_cull and _rest). */
typedef struct {
    float mean[3], scale[3], rotation[4], opacity;
} one_gaussian;

static void instant_model(const gaussian_model *m, size_t i, double t, gaussian_model *one, one_gaussian *store)
{
    *one = *m;
    one->count = 1, one->dynamic = NULL, one->sh = NULL;
    one->mean = store->mean, one->scale = store->scale, one->rotation = store->rotation, one->opacity = &store->opacity;
    gaussian_dynamic_instant_cull(m, i, t, one, 0);
    gaussian_dynamic_instant_rest(m, i, t, one, 0);
}

static int box_holds(aabb outer, aabb inner)
{
    return outer.lo.x <= inner.lo.x && outer.lo.y <= inner.lo.y && outer.lo.z <= inner.lo.z &&
           inner.hi.x <= outer.hi.x && inner.hi.y <= outer.hi.y && inner.hi.z <= outer.hi.z;
}

/* Random rotations that turn (omega up to 3 a time unit, some rot 0 as
 * error-guided sampling adds them, some below torch's eps), uneven scales
 * and opacities, on the paths of random_gaussian (fast movers of 60 units a
 * time unit among them). */
static void random_turning_gaussian(gaussian_model *m, size_t i, uint64_t *s)
{
    random_gaussian(m, i, s, (int)(i % 5));
    gaussian_stg *d = gaussian_stg_of(m);
    double size = i % 7 == 3 ? 0 : i % 7 == 5 ? 3e-13 : 1;
    for (int k = 0; k < 4; k++)
        d->rot[4 * i + k] = (float)(size * lcg_uniform(s, -1, 1)), d->omega[4 * i + k] = (float)lcg_uniform(s, -3, 3);
    for (int k = 0; k < 3; k++)
        m->scale[3 * i + k] = (float)exp(lcg_uniform(s, -5, 0));
    m->opacity[i] = (float)lcg_uniform(s, 0.05, 0.99);
    d->trbf_scale[i] = (float)lcg_uniform(s, -1, 1);
}

/* The box a dynamic Gaussian gets over [t0, t1] (gaussian_dynamic_bounds
 * and gaussian_dynamic_reach_bounds) holds, at 20,000 times, the box of
 * the static Gaussian of its instant under the same view bound
 * (gaussian_view_bounds: its kernel's and its screen footprint's reach,
 * as for any static Gaussian), with the view axis known to within a cone
 * as the BVH of a still camera has it. Planted: the box of the path
 * without the reach (120 of 120 fail), or the Gaussian's own scales
 * turned by its rest rotation instead of the largest in every direction
 * (95 of 120) each fail it. */
TEST(a_moving_gaussians_box_holds_its_reach_at_20000_times_of_the_shutter)
{
    const size_t n = 60;
    gaussian_model m;
    alloc_model(&m, n);
    uint64_t seed = 99;
    int failures = 0, kinds[2] = {GAUSSIAN_FORMATION_3DGS, GAUSSIAN_FORMATION_3DGRT};
    for (int f = 0; f < 2; f++) {
        m.formation = (gaussian_formation)kinds[f];
        for (size_t i = 0; i < n; i++) {
            random_turning_gaussian(&m, i, &seed);
            double c = gaussian_stg_of(&m)->trbf_center[i], t0 = c + lcg_uniform(&seed, -1.2, 0.2), t1 = t0 + lcg_uniform(&seed, 0, 1.4);
            double lo[3], hi[3], omax;
            CHECK(gaussian_dynamic_bounds(&m, i, t0, t1, lo, hi, &omax) == 0);
            /* the camera 40 units from the origin: the distance is its farthest from the box */
            vec3 far = v3(fmax(fabs(lo[0]), fabs(hi[0])), fmax(fabs(lo[1]), fabs(hi[1])),
                          fmax(fabs(lo[2] - 40), fabs(hi[2] - 40)));
            gaussian_view_bound v = {v3_len(far), 300.0, 1.3, 0.0, v3(0, 0, -1), 0.05};
            aabb box = gaussian_dynamic_reach_bounds(&m, i, lo, hi, omax, &v);
            int held = 1;
            for (int j = 0; j <= 20000; j++) {
                gaussian_model one;
                one_gaussian store;
                instant_model(&m, i, j == 20000 ? t1 : t0 + (t1 - t0) * j / 20000, &one, &store);
                held &= box_holds(box, gaussian_view_bounds(&one, 0, &v));
            }
            failures += !held;
        }
    }
    printf("    %d of %zu moving Gaussians' instants left their box\n", failures, 2 * n);
    CHECK(failures == 0);
    gaussian_model_free(&m);
}

/* An STG-lite model's file with the rows, in a fresh directory. */
static void write_stg_file(const char *path, const stg_row *rows, int n)
{
    static char buf[1 << 14];
    size_t len = write_ply(buf, sizeof buf, rows, n, NULL, NULL);
    FILE *f = fopen(path, "wb");
    CHECK(f && fwrite(buf, 1, len, f) == len);
    if (f)
        fclose(f);
}

typedef struct {
    unsigned want;
    int found;
} listed;

static void note_listed(void *user, unsigned prim)
{
    listed *l = user;
    l->found |= prim == l->want;
}

/* Whether every ray from the camera (the origin: object space is the
 * world's) through the instant's mean and through the middles of the faces
 * of its reach's box (gaussian_view_bounds of the instant, shrunk by
 * 0.1%) lists Gaussian i at time t. */
static int listed_at(const accel *a, const scene *s, size_t i, double t)
{
    const gaussian_model *m = &s->objects[0].gaussians;
    gaussian_model one;
    one_gaussian store;
    instant_model(m, i, t, &one, &store);
    if (!(store.opacity >= GAUSSIAN_ALPHA_MIN)) /* nothing to draw */
        return 1;
    vec3 mu = v3(store.mean[0], store.mean[1], store.mean[2]);
    camera_view view;
    scene_camera_view(s, t, &view);
    gaussian_view_bound v = {v3_len(mu), fmin(view.fx, view.fy), gaussian_view_stretch(&view), 0.0, v3(0, 0, -1), 1e-9};
    aabb b = gaussian_view_bounds(&one, 0, &v);
    vec3 half = v3_scale(v3_sub(b.hi, b.lo), 0.4995), centre = v3_scale(v3_add(b.lo, b.hi), 0.5);
    vec3 points[7] = {mu};
    for (int k = 0; k < 6; k++) {
        double d[3] = {0, 0, 0}, h[3] = {half.x, half.y, half.z};
        d[k / 2] = k % 2 ? h[k / 2] : -h[k / 2];
        points[k + 1] = v3_add(centre, v3(d[0], d[1], d[2]));
    }
    int all = 1;
    for (int k = 0; k < 7; k++) {
        listed l = {(unsigned)i, 0};
        accel_gaussian_candidates(a, 0, v3(0, 0, 0), v3_normalize(points[k]), 0.0, 1e3, note_listed, &l);
        all &= l.found;
    }
    return all;
}

/* The renderer's BVH over the shutter: rays at 20,000 times of it, through
 * a fast mover's mean and the faces of its reach at that time, list it;
 * and after the shutter moves on (the next frame's scene: accel_retime) at
 * times of the new one, where the movers are far from where they were.
 * The movers: 4 units a time unit across the view (half the distance),
 * turning with omega from rot 0, and a cubic path; a still one for
 * contrast. Planted: the BVH built from the static means (the bounds of
 * a static 3DGS Gaussian) fails it (86,473 of 1,120,056 rays). */
TEST(the_bvh_lists_a_fast_mover_wherever_it_is_during_the_shutter)
{
    char dir[] = "/tmp/refrender-stg-bvh-XXXXXX", ply[160], xml[1024];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(ply, sizeof ply, "%s/movers.ply", dir);
    /* stored values: logit(0.9) = 2.197, log(0.05) = -3, exp(trbf_scale) = 3 */
    stg_row rows[4] = {
        {{-1, 0, -8}, 0.5, 1.0986, {4, 0, 0, 0, 0, 0, 0, 0, 0}, {1, 0, 0}, 2.197, {-3, -3, -3}, {1, 0, 0, 0}, {0}},
        {{0, 1, -6}, 0.2, 1.0986, {-3, 0.5, 0, 0, -2, 0, 0, 0, 1}, {0, 1, 0}, 2.197, {-2, -4, -3.5}, {0, 0, 0, 0},
         {0.5, -2, 1, 3}},
        {{1, -1, -10}, 0.7, 1.0986, {0, 3, 0.2, 2, 0, 0, -5, 1, 0}, {0, 0, 1}, 2.197, {-1.5, -3, -5}, {1, 2, 0, 0},
         {0, 0, 4, 0}},
        {{0, 0, -9}, 0.5, 1.0986, {0}, {1, 1, 1}, 2.197, {-3, -3, -3}, {1, 0, 0, 0}, {0}},
    };
    write_stg_file(ply, rows, 4);
    snprintf(xml, sizeof xml,
             "<scene><camera position='0 0 0' lookat='0 0 -1' up='0 1 0' fov='40' width='64' height='64'/>"
             "<shutter open='0' close='1'/><object name='movers'><gaussianModel file='%s'/></object></scene>", ply);
    scene s;
    accel *a = NULL;
    rr_error e;
    int rc = scene_load_memory(xml, strlen(xml), "mem.xml", ".", &s, &e);
    accel_settings set = {0.0, 1.0, 1};
    scene next; /* the next frame's scene: the same objects, another shutter (as scene_for_shutter's) */
    if (!rc)
        rc = accel_build(&s, &set, &a, &e);
    if (rc)
        printf("    %s\n", e.msg);
    CHECK(rc == 0);
    int missed = 0;
    for (int frame = 0; !rc && frame < 2; frame++) {
        double t0 = frame ? 2.0 : 0.0, t1 = t0 + 1.0;
        if (frame) {
            next = s, next.shut.open = t0, next.shut.close = t1;
            CHECK(accel_retime(a, &next, &e) == 0);
        }
        for (int j = 0; j <= 20000; j++)
            for (size_t i = 0; i < 4; i++)
                missed += !listed_at(a, &s, i, t0 + (t1 - t0) * j / 20000);
    }
    printf("    rays that did not list the Gaussian they aim at: %d of %d\n", missed, 2 * 20001 * 4 * 7);
    CHECK(missed == 0);
    if (!rc) {
        accel_free(a);
        scene_free(&s);
    }
    unlink(ply);
    rmdir(dir);
}
