/* gaussian_dynamic.c's 4DGS kind and gaussian_fdgs_ply.c: real-time 4DGS
 * models (fudan-zvg/4d-gaussian-splatting at 63725f21) as
 * scripts/convert_4dgs.py writes them, at a time t against values worked
 * by hand from the rasterizer's rules (forward.cu:279-352 the conditional
 * mean, opacity and its 0.05 cut; :73-195 and :476-483 the 4D SH from the
 * canonical mean), their bounds against 20,000 steps of the path, and the
 * reader's refusals by name. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gaussians/gaussian.h"
#include "gaussians/gaussian_fdgs.h"
#include "formats/gaussian_ply.h"
#include "gaussian_test_util.h"
#include "harness.h"

/* ---- models written as ascii PLY in the converter's order ----------------- */

static const char *const FIXED[] = {"x", "y", "z", "t_center", "vel_0", "vel_1", "vel_2", "t_var", "opacity",
                                    "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
                                    "time_duration", "sh_degree", "sh_degree_t"};
enum { N_FIXED = 19, MAX_SH = 144 };

typedef struct {
    double v[N_FIXED];
    double sh[MAX_SH];
    int n_sh;
} fdgs_row;

/* x = (1, 2, 3), t_center 0.5, vel (0.5, -1, 0.25), t_var 0.25 (marginal
 * exp(-2 D^2)), sigmoid(opacity) = 1/2, scales exp(0, -1, 1), rot (2, 0,
 * 0, 0) (unit after normalising), T = 2, degree 0 (3 coefficients). */
static fdgs_row hand_row(void)
{
    fdgs_row r = {{1, 2, 3, 0.5, 0.5, -1, 0.25, 0.25, 0, 0, -1, 1, 2, 0, 0, 0, 2, 0, 0}, {0.25, -0.5, 1.5}, 3};
    return r;
}

/* skip: a property to leave out (NULL: none); extra: one to add (value 0). */
static size_t write_ply(char *buf, size_t size, const fdgs_row *rows, int n, const char *skip, const char *extra)
{
    static char store[N_FIXED + MAX_SH][32];
    const char *names[N_FIXED + MAX_SH];
    for (int k = 0; k < N_FIXED + MAX_SH; k++) {
        if (k < N_FIXED)
            snprintf(store[k], sizeof store[k], "%s", FIXED[k]);
        else
            snprintf(store[k], sizeof store[k], "sh4d_%d", k - N_FIXED);
        names[k] = store[k];
    }
    size_t len = ply_ascii_header(buf, size, n, names, N_FIXED + rows[0].n_sh, skip, extra);
    for (int i = 0; i < n; i++) {
        double v[N_FIXED + MAX_SH];
        memcpy(v, rows[i].v, sizeof rows[i].v);
        memcpy(&v[N_FIXED], rows[i].sh, sizeof rows[i].sh);
        len = ply_ascii_row(buf, size, len, names, v, N_FIXED + rows[i].n_sh, 17, skip, extra);
    }
    return len;
}

static int parse_rows(const fdgs_row *rows, int n, gaussian_model *m, rr_error *e)
{
    static char buf[1 << 16];
    size_t len = write_ply(buf, sizeof buf, rows, n, NULL, NULL);
    return parse_gaussian_text("fdgs.ply", buf, len, m, e);
}

/* ---- evaluation ------------------------------------------------------------ */

/* mean x + vel D (forward.cu:347-350), opacity sigmoid(0) exp(-0.5 D^2 /
 * 0.25) (:333-336), the scales exp(scale) and the quaternion normalised,
 * constant; at D = 0.25 and -0.5 (exact in binary). */
TEST(a_4dgs_gaussian_at_t_is_the_official_rules_worked_by_hand)
{
    fdgs_row r = hand_row();
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(&r, 1, &m, &e) == 0 && m.dynamic && m.count == 1 && m.kind == GAUSSIAN_3D);
    if (!m.dynamic)
        return;
    CHECK(m.dynamic->ops == &gaussian_fdgs_ops && gaussian_fdgs_of(&m)->time_duration == 2 && m.sh_coeffs == 1);
    const double Ds[2] = {0.25, -0.5};
    for (int s = 0; s < 2; s++) {
        double D = Ds[s];
        gaussian_dynamic_state st;
        gaussian_dynamic_at(&m, 0, 0.5 + D, &st);
        for (int k = 0; k < 3; k++) {
            CHECK(st.mean[k] == r.v[k] + r.v[4 + k] * D);
            CHECK_NEAR(st.scale[k], exp(r.v[9 + k]), 1e-6 * exp(r.v[9 + k]));
        }
        CHECK(st.q[0] == 1 && st.q[1] == 0 && st.q[2] == 0 && st.q[3] == 0);
        CHECK_NEAR(st.opacity, 0.5 * exp(-2 * D * D), 1e-15);
    }
    gaussian_model_free(&m);
}

/* The cut: drawn only where exp(-2 D^2) > 0.05 (forward.cu:334), |D| <
 * sqrt(ln 20 / 2) = 1.22387: at D = 1.2 the opacity is 0.5 exp(-2.88), at
 * 1.25 and -1.25 it is 0; and the bound over an interval wholly past the
 * cut is 0 (the Gaussian is never drawn), one reaching 1.2 is not. */
TEST(a_4dgs_gaussian_is_cut_where_its_marginal_is_at_most_005)
{
    fdgs_row r = hand_row();
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(&r, 1, &m, &e) == 0);
    if (!m.dynamic)
        return;
    gaussian_dynamic_state st;
    gaussian_dynamic_at(&m, 0, 0.5 + 1.2, &st);
    CHECK_NEAR(st.opacity, 0.5 * exp(-2.88), 1e-15);
    CHECK(st.opacity > 0.5 * 0.05);
    gaussian_dynamic_at(&m, 0, 0.5 + 1.25, &st);
    CHECK(st.opacity == 0);
    gaussian_dynamic_at(&m, 0, 0.5 - 1.25, &st);
    CHECK(st.opacity == 0);
    double lo[3], hi[3], om;
    CHECK(gaussian_dynamic_bounds(&m, 0, 0.5 + 1.25, 0.5 + 3, lo, hi, &om) == 0 && om == 0);
    CHECK(gaussian_dynamic_bounds(&m, 0, 0.5 - 3, 0.5 - 1.25, lo, hi, &om) == 0 && om == 0);
    CHECK(gaussian_dynamic_bounds(&m, 0, 0.5 + 1.2, 0.5 + 3, lo, hi, &om) == 0);
    CHECK(om >= 0.5 * exp(-2.88) && om <= 0.5 * exp(-2.88) * (1 + 1e-14));
    CHECK(gaussian_dynamic_bounds(&m, 0, 0, 1, lo, hi, &om) == 0);
    CHECK(om >= 0.5 && om <= 0.5 * (1 + 1e-14));
    gaussian_model_free(&m);
}

/* A degree-3 model with two time harmonics whose coefficients are 0 but
 * for the constants of each block (sh4d index 3 (16 k) + c) and block 1's
 * l1p1 (coefficient 16 + 3: -C1 x of the unit direction): at t_center - t
 * = T / 6 the harmonics are cos(pi / 3) = 1/2 and cos(2 pi / 3) = -1/2
 * (forward.cu:143, 163), so colour = 0.5 + C0 (a + b/2 - c/2) - C1 x w/2,
 * clamped at 0; the direction from the eye to the canonical mean x y z
 * (forward.cu:79-81, 480-482), not the moved one. */
TEST(a_4dgs_colour_is_the_4d_sh_from_the_canonical_mean)
{
    const double C0 = 0.28209479177387814, C1 = 0.4886025119029199;
    fdgs_row r = hand_row();
    r.v[17] = 3, r.v[18] = 2, r.n_sh = 144;
    memset(r.sh, 0, sizeof r.sh);
    const double a[3] = {0.5, -0.25, -3}, b[3] = {0.25, 1, 0}, c[3] = {-0.5, 0.5, 0}, w[3] = {1, 0.5, -0.25};
    for (int ch = 0; ch < 3; ch++) {
        r.sh[ch] = a[ch], r.sh[3 * 16 + ch] = b[ch], r.sh[3 * 32 + ch] = c[ch];
        r.sh[3 * (16 + 3) + ch] = w[ch];
    }
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(&r, 1, &m, &e) == 0);
    if (!m.dynamic)
        return;
    CHECK(m.sh_degree == 3 && m.sh_coeffs == 48 && gaussian_fdgs_of(&m)->sh_degree_t == 2);
    vec3 eye = v3(1 - 0.6, 2 - 0.8, 3); /* the canonical mean from it: (0.6, 0.8, 0), unit */
    float dir[3];
    gaussian_dynamic_view_dir(&m, 0, eye, dir);
    CHECK(dir[0] == 0.6f && dir[1] == 0.8f && dir[2] == 0.0f);
    double t = 0.5 - 2.0 / 6; /* t_center - t = T / 6 */
    vec3 got = gaussian_dynamic_color(&m, 0, t, v3(dir[0], dir[1], dir[2]));
    double want[3], g[3] = {got.x, got.y, got.z};
    for (int ch = 0; ch < 3; ch++) {
        want[ch] = fmax(0.5 + C0 * (a[ch] + b[ch] / 2 - c[ch] / 2) - C1 * 0.6 * w[ch] / 2, 0);
        CHECK_NEAR(g[ch], want[ch], 1e-6);
    }
    CHECK(want[2] == 0); /* the clamp is exercised */
    /* the time blocks count only at degree 3 (forward.cu:142) */
    float sh[3 * 8] = {0};
    sh[0] = 1, sh[3 * 4] = 5;
    vec3 low = gaussian_sh4d_color(sh, 1, 1, 0, 2, v3(1, 0, 0));
    CHECK_NEAR(low.x, 0.5 + C0, 1e-7);
    gaussian_model_free(&m);
}

/* ---- bounds over [t0, t1] ---------------------------------------------------- */

/* n random 4DGS Gaussians (slow and fast movers, offsets far from the
 * origin, short and long marginals) with degree 0. */
static void random_model(gaussian_model *m, size_t n, uint64_t *s)
{
    gaussian_model_init(m);
    m->kind = GAUSSIAN_3D, m->sh_degree = 0, m->sh_coeffs = 1;
    CHECK(gaussian_model_alloc(m, n) == 0 && (m->dynamic = gaussian_fdgs_alloc(n)) != NULL);
    gaussian_fdgs_of(m)->time_duration = 1, gaussian_fdgs_of(m)->sh_degree_t = 0;
    for (size_t i = 0; i < n; i++) {
        double off = i % 3 == 2 ? 1000 : 3, speed = i % 3 == 1 ? 60 : 1;
        for (int k = 0; k < 3; k++) {
            m->mean[3 * i + k] = (float)lcg_uniform(s, -off, off);
            gaussian_fdgs_of(m)->velocity[3 * i + k] = (float)lcg_uniform(s, -speed, speed);
            m->scale[3 * i + k] = 0.1f, m->sh[3 * i + (size_t)k] = 0;
        }
        m->rotation[4 * i] = 1, m->rotation[4 * i + 1] = m->rotation[4 * i + 2] = m->rotation[4 * i + 3] = 0;
        m->opacity[i] = (float)lcg_uniform(s, 0.01, 0.99);
        gaussian_fdgs_of(m)->t_center[i] = (float)lcg_uniform(s, -1, 1);
        gaussian_fdgs_of(m)->t_var[i] = (float)exp(lcg_uniform(s, -8, 1));
    }
    m->count = n;
}

/* Gaussian i's box and opacity bound over [t0, t1] against 20,000 steps:
 * each step's mean as computed and exactly (long double) inside, its
 * opacity under the bound, a bound of 0 only where every step is cut; and
 * the box no wider than the sampled hull plus a step's travel and the
 * padding (*slack: the largest excess). */
static int fdgs_bounds_hold(const gaussian_model *m, size_t i, double t0, double t1, double *slack, int *cut_all)
{
    double lo[3], hi[3], omax, smin[3] = {INFINITY, INFINITY, INFINITY}, smax[3] = {-INFINITY, -INFINITY, -INFINITY};
    if (gaussian_dynamic_bounds(m, i, t0, t1, lo, hi, &omax))
        return 0;
    int ok = 1, drawn = 0;
    const int steps = 20000;
    for (int j = 0; j <= steps; j++) {
        double t = j == steps ? t1 : t0 + (t1 - t0) * j / steps;
        gaussian_dynamic_state st;
        gaussian_dynamic_at(m, i, t, &st);
        ok &= st.opacity <= omax;
        drawn |= st.opacity > 0;
        for (int k = 0; k < 3; k++) {
            long double x = m->mean[3 * i + k] + ((long double)t - gaussian_fdgs_of(m)->t_center[i]) * gaussian_fdgs_of(m)->velocity[3 * i + k];
            ok &= st.mean[k] >= lo[k] && st.mean[k] <= hi[k] && x >= lo[k] && x <= hi[k];
            smin[k] = fmin(smin[k], st.mean[k]), smax[k] = fmax(smax[k], st.mean[k]);
        }
    }
    *cut_all += omax == 0;
    ok &= omax > 0 || !drawn;
    double R = fmax(fabs(t0 - gaussian_fdgs_of(m)->t_center[i]), fabs(t1 - gaussian_fdgs_of(m)->t_center[i]));
    for (int k = 0; k < 3; k++) {
        double vel = fabs(gaussian_fdgs_of(m)->velocity[3 * i + k]);
        double explained = 16 * DBL_EPSILON * (fabs(m->mean[3 * i + k]) + vel * R);
        *slack = fmax(*slack, fmax(smin[k] - lo[k], hi[k] - smax[k]) - explained);
    }
    return ok;
}

TEST(fdgs_bounds_hold_20000_steps_of_the_path)
{
    const size_t n = 300;
    uint64_t seed = 777;
    gaussian_model m;
    random_model(&m, n, &seed);
    int failures = 0, cut_all = 0;
    double slack = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        double c = gaussian_fdgs_of(&m)->t_center[i], t0 = c + lcg_uniform(&seed, -3, 1), t1 = t0 + lcg_uniform(&seed, 0, 2);
        if (i % 50 == 7)
            t1 = t0; /* an instant */
        failures += !fdgs_bounds_hold(&m, i, t0, t1, &slack, &cut_all);
    }
    printf("    %d of %zu Gaussians left the box; box beyond the samples by %.3g; %d never drawn\n", failures, n,
           slack, cut_all);
    CHECK(failures == 0);
    CHECK(slack <= 0);
    CHECK(cut_all > 10 && cut_all < (int)n - 10); /* both cases are exercised */
    gaussian_model_free(&m);
}

/* ---- the reader -------------------------------------------------------------- */

static int refused_rows(const fdgs_row *rows, int n, const char *skip, const char *extra, gaussian_kind kind,
                        const char *needle)
{
    static char buf[1 << 16];
    size_t len = write_ply(buf, sizeof buf, rows, n, skip, extra);
    return gaussian_text_refused("fdgs.ply", buf, len, kind, needle);
}

static int refused(fdgs_row r, const char *skip, const char *extra, const char *needle)
{
    return refused_rows(&r, 1, skip, extra, GAUSSIAN_AUTO, needle);
}

TEST(fdgs_reader_refuses_partial_mixed_and_inconsistent_layouts_by_name)
{
    fdgs_row r = hand_row(), two[2];
    CHECK(refused(r, "t_var", NULL, "'t_var'"));         /* partial */
    CHECK(refused(r, "sh4d_0", NULL, "'sh4d_0'"));
    CHECK(refused(r, "sh_degree_t", NULL, "'sh_degree_t'"));
    CHECK(refused(r, NULL, "trbf_center", "'trbf_center'")); /* mixed with STG */
    CHECK(refused(r, NULL, "motion_0", "mixing"));
    CHECK(refused(r, NULL, "f_dc_0", "'f_dc_0'"));            /* mixed with 3DGS */
    CHECK(refused(r, NULL, "sh4d_4", "'sh4d_3'"));            /* a gap */
    CHECK(refused(r, NULL, "sh4d_144", "'sh4d_144'"));
    fdgs_row d = r;
    d.v[17] = 1; /* degree 1 needs 12 coefficients, the header has 3 */
    CHECK(refused(d, NULL, NULL, "need 12 sh4d_*"));
    d = r, d.v[18] = 1; /* time harmonics below degree 3 */
    CHECK(refused(d, NULL, NULL, "sh_degree_t = 1 with sh_degree = 0"));
    d = r, d.v[17] = 1.5;
    CHECK(refused(d, NULL, NULL, "'sh_degree' = 1.5"));
    d = r, d.v[18] = 3;
    CHECK(refused(d, NULL, NULL, "'sh_degree_t' = 3"));
    d = r, d.v[7] = 0;
    CHECK(refused(d, NULL, NULL, "'t_var' = 0"));
    d = r, d.v[7] = -1;
    CHECK(refused(d, NULL, NULL, "'t_var' = -1"));
    d = r, d.v[16] = 0;
    CHECK(refused(d, NULL, NULL, "'time_duration' = 0"));
    d = r, d.v[4] = NAN;
    CHECK(refused(d, NULL, NULL, "'vel_0' is nan"));
    d = r, d.v[3] = INFINITY;
    CHECK(refused(d, NULL, NULL, "'t_center' is inf"));
    d = r, d.v[12] = 0;
    CHECK(refused(d, NULL, NULL, "zero-length quaternion"));
    two[0] = two[1] = r, two[1].v[16] = 3; /* T differs between vertices */
    CHECK(refused_rows(two, 2, NULL, NULL, GAUSSIAN_AUTO, "'time_duration' = 3 differs"));
    two[1] = r, two[1].v[17] = 3;
    CHECK(refused_rows(two, 2, NULL, NULL, GAUSSIAN_AUTO, "'sh_degree' = 3 differs"));
    CHECK(refused_rows(&r, 1, NULL, NULL, GAUSSIAN_2D, "2dgs"));
}

/* A SpacetimeGaussians file with a 4DGS property is refused by STG's
 * reader too, naming it (whichever property the header declares first
 * decides the reader). */
TEST(stg_reader_refuses_a_4dgs_property)
{
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float trbf_center\n"
                      "property float t_center\nend_header\n0 0 0\n";
    gaussian_model m;
    rr_error e = {{0}};
    gaussian_model_init(&m);
    CHECK(gaussian_parse("mix.ply", ply, strlen(ply), GAUSSIAN_AUTO, &m, &e) == -1);
    CHECK(strstr(e.msg, "mix.ply") && strstr(e.msg, "'t_center'") && strstr(e.msg, "mixing"));
    CHECK(!m.mean && !m.dynamic);
}

/* The sh4d run lands in the model's order (coefficient S k + j of channel
 * c at [3 (S k + j) + c]: the converter's) and a binary-exact value stays. */
TEST(fdgs_reader_keeps_the_sh4d_order)
{
    fdgs_row r = hand_row();
    r.v[17] = 3, r.v[18] = 2, r.n_sh = 144;
    for (int k = 0; k < 144; k++)
        r.sh[k] = k * 0.25 - 18;
    gaussian_model m;
    rr_error e;
    CHECK(parse_rows(&r, 1, &m, &e) == 0);
    if (!m.mean)
        return;
    int same = 1;
    for (int k = 0; k < 144; k++)
        same &= m.sh[k] == (float)(k * 0.25 - 18);
    CHECK(same);
    gaussian_model_free(&m);
}
