/* Dynamic Gaussian kinds are table rows (gaussians/gaussian_dynamic.h):
 * a third kind, defined here and nowhere in src/, goes through the same
 * calls as SpacetimeGaussians' and 4DGS's. The toy kind: each Gaussian at
 * constant velocity v from its mean x at time c, its opacity, scale,
 * rotation and colour constant. Independent expectations: its instants at
 * exactly representable times equal x + v (t - c) worked by hand; its
 * bounds hold the exact path (long double) at 20,000 times; the renderer's
 * BVH lists it wherever it is during the shutter; and a sharp render at an
 * instant equals, bit for bit, the render of the static 3DGS model whose
 * means are the instant's (the renderer cannot tell them apart but
 * through the row). Planted: a row whose bounds return the rest mean
 * fails the bounds, the BVH and the render checks. */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "accel/accel.h"
#include "formats/gaussian_ply.h"
#include "gaussians/gaussian_dynamic.h"
#include "scenexml/scene_xml.h"
#include "render/render.h"
#include "gaussian_test_util.h"
#include "harness.h"

/* ---- the toy kind: its struct and its row ------------------------------- */

typedef struct {
    gaussian_dynamic base; /* first: m->dynamic points at it */
    float *t_ref;          /* 1 per Gaussian: c, the time the mean is x */
    float *velocity;       /* 3 per Gaussian */
} toy_kind;

static const toy_kind *toy_of(const gaussian_model *m) { return (const toy_kind *)m->dynamic; }

static void toy_mean(const gaussian_model *m, size_t i, double t, double mean[3])
{
    double D = t - toy_of(m)->t_ref[i];
    for (int k = 0; k < 3; k++) /* as gaussian_dynamic_linear_bounds bounds it: x + vel * D */
        mean[k] = m->mean[3 * i + k] + toy_of(m)->velocity[3 * i + k] * D;
}

static void toy_at(const gaussian_model *m, size_t i, double t, gaussian_dynamic_state *out)
{
    toy_mean(m, i, t, out->mean);
    for (int k = 0; k < 3; k++)
        out->scale[k] = m->scale[3 * i + k], out->rgb[k] = 0;
    for (int k = 0; k < 4; k++)
        out->q[k] = m->rotation[4 * i + k];
    out->opacity = m->opacity[i];
}

static vec3 toy_color(const gaussian_model *m, size_t i, double t, vec3 dir)
{
    (void)t;
    return gaussian_sh_color(&m->sh[(size_t)3 * m->sh_coeffs * i], m->sh_degree, dir);
}

static int toy_bounds(const gaussian_model *m, size_t i, double t0, double t1, double lo[3], double hi[3],
                      double *opacity_max)
{
    interval D = gaussian_dynamic_offset_interval(t0, t1, toy_of(m)->t_ref[i]), box[3];
    for (int k = 0; k < 3; k++)
        if (gaussian_dynamic_linear_bounds(m->mean[3 * i + k], toy_of(m)->velocity[3 * i + k], D, &box[k]))
            return -1;
    gaussian_dynamic_store_box(box, lo, hi);
    *opacity_max = m->opacity[i];
    return 0;
}

static void toy_cull(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j)
{
    double mean[3];
    toy_mean(m, i, t, mean);
    for (int k = 0; k < 3; k++)
        out->mean[3 * j + k] = (float)mean[k], out->scale[3 * j + k] = m->scale[3 * i + k];
}

static void toy_rest(const gaussian_model *m, size_t i, double t, gaussian_model *out, size_t j)
{
    (void)t;
    for (int k = 0; k < 4; k++)
        out->rotation[4 * j + k] = m->rotation[4 * i + k];
    out->opacity[j] = m->opacity[i];
}

static void toy_prefetch(const gaussian_model *m, size_t i) { (void)m, (void)i; }

static const gaussian_dynamic_ops toy_ops = {
    "toy-linear", toy_at, toy_color, NULL, toy_bounds, toy_cull, toy_rest, toy_prefetch, toy_prefetch,
    gaussian_dynamic_free,
};

/* m made a toy model: Gaussian i moves at velocity vel[i] from its mean at
 * time c[i]. */
static void make_toy(gaussian_model *m, const double (*vel)[3], const double *c)
{
    static const gaussian_dynamic_array arrays[] = {{offsetof(toy_kind, t_ref), 1}, {offsetof(toy_kind, velocity), 3}};
    toy_kind *d = (toy_kind *)gaussian_dynamic_alloc(m->count, sizeof *d, &toy_ops, arrays, 2);
    CHECK(d != NULL);
    for (size_t i = 0; d && i < m->count; i++) {
        d->t_ref[i] = (float)c[i];
        for (int k = 0; k < 3; k++)
            d->velocity[3 * i + k] = (float)vel[i][k];
    }
    m->dynamic = &d->base;
}

/* ---- instants and bounds, in memory ---------------------------------------- */

static void one_model(gaussian_model *m, size_t n)
{
    gaussian_model_init(m);
    m->kind = GAUSSIAN_3D, m->sh_degree = 0, m->sh_coeffs = 1;
    CHECK(gaussian_model_alloc(m, n) == 0);
    m->count = n;
    for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++)
            m->mean[3 * i + k] = (float)(k + 1), m->scale[3 * i + k] = 0.25f, m->sh[3 * i + k] = 0.5f;
        m->rotation[4 * i] = 1, m->rotation[4 * i + 1] = m->rotation[4 * i + 2] = m->rotation[4 * i + 3] = 0;
        m->opacity[i] = 0.75f;
    }
}

/* At t = 0.75 with c = 0.25 (D = 0.5) the mean is x + v / 2, exact in
 * binary: (1 + 0.5 * 2, 2 - 0.5 * 4, 3 + 0.5 * 0.5) = (2, 0, 3.25); the
 * rest is the model's. The generic calls (at, instant_cull/_rest, color,
 * view_dir, the export name) reach the row. */
TEST(a_third_dynamic_kind_is_its_row_alone)
{
    gaussian_model m, out;
    one_model(&m, 1);
    one_model(&out, 1);
    const double vel[1][3] = {{2, -4, 0.5}}, c[1] = {0.25};
    make_toy(&m, vel, c);
    gaussian_dynamic_state st;
    gaussian_dynamic_at(&m, 0, 0.75, &st);
    CHECK(st.mean[0] == 2 && st.mean[1] == 0 && st.mean[2] == 3.25 && st.opacity == 0.75f && st.scale[1] == 0.25f);
    gaussian_dynamic_instant_cull(&m, 0, 0.75, &out, 0);
    gaussian_dynamic_instant_rest(&m, 0, 0.75, &out, 0);
    CHECK(out.mean[0] == 2 && out.mean[1] == 0 && out.mean[2] == 3.25f && out.opacity[0] == 0.75f);
    CHECK(out.rotation[0] == 1 && out.scale[2] == 0.25f);
    float dir[3] = {0, 0, -1};
    gaussian_dynamic_view_dir(&m, 0, v3(5, 5, 5), dir); /* no view_dir in the row: the instant's kept */
    CHECK(dir[0] == 0 && dir[1] == 0 && dir[2] == -1);
    vec3 col = gaussian_dynamic_color(&m, 0, 0.75, v3(0, 0, -1));
    CHECK(fabs(col.x - (0.28209479177387814 * 0.5 + 0.5)) < 1e-7); /* SH degree 0: C0 dc + 0.5 */
    CHECK(!strcmp(gaussian_dynamic_name(&m), "toy-linear"));
    gaussian_model_free(&m);
    gaussian_model_free(&out);
}

/* The bounds over [t0, t1] hold the exact path x + v (t - c) (long
 * double) at 20,000 times, and the computed instant too, for slow and fast
 * movers far from and near the origin. */
TEST(a_third_kinds_bounds_hold_20000_times_of_its_path)
{
    enum { N = 24 };
    gaussian_model m;
    one_model(&m, N);
    double vel[N][3], c[N];
    uint64_t seed = 7;
    for (int i = 0; i < N; i++) {
        double speed = i % 3 == 1 ? 60 : 1, off = i % 3 == 2 ? 1000 : 3;
        for (int k = 0; k < 3; k++)
            vel[i][k] = lcg_uniform(&seed, -speed, speed), m.mean[3 * i + k] = (float)lcg_uniform(&seed, -off, off);
        c[i] = lcg_uniform(&seed, -1, 1);
    }
    make_toy(&m, vel, c);
    int outside = 0;
    for (int i = 0; i < N; i++) {
        double t0 = lcg_uniform(&seed, -2, 1), t1 = t0 + lcg_uniform(&seed, 0, 2), lo[3], hi[3], omax;
        CHECK(gaussian_dynamic_bounds(&m, (size_t)i, t0, t1, lo, hi, &omax) == 0 && omax == m.opacity[i]);
        const toy_kind *d = toy_of(&m);
        for (int j = 0; j <= 20000; j++) {
            double t = t0 + (t1 - t0) * j / 20000, got[3];
            gaussian_dynamic_state st;
            gaussian_dynamic_at(&m, (size_t)i, t, &st);
            for (int k = 0; k < 3; k++) {
                long double x = m.mean[3 * i + k] + ((long double)t - d->t_ref[i]) * d->velocity[3 * i + k];
                got[k] = st.mean[k];
                outside += !(x >= lo[k] && x <= hi[k]) + !(got[k] >= lo[k] && got[k] <= hi[k]);
            }
        }
    }
    CHECK(outside == 0);
    gaussian_model_free(&m);
}

/* ---- through the renderer --------------------------------------------------- */

/* Three 3DGS Gaussians in front of the camera at the origin, written to
 * ply; their means are the toy's x. */
static void write_three(const char *ply)
{
    gaussian_model m;
    one_model(&m, 3);
    const float mean[9] = {-1.5f, 0.1f, -5, 0.2f, -0.8f, -4, 1.2f, 0.9f, -6};
    memcpy(m.mean, mean, sizeof mean);
    for (int k = 0; k < 9; k++)
        m.scale[k] = 0.08f;
    for (int i = 0; i < 3; i++)
        m.sh[3 * i] = 0.9f - 0.4f * (float)i, m.sh[3 * i + 1] = 0.2f * (float)i, m.sh[3 * i + 2] = -0.3f;
    rr_error e;
    CHECK(gaussian_write_ply(ply, &m, &e) == 0);
    gaussian_model_free(&m);
}

static const double three_vel[3][3] = {{4, 0, 0}, {0, 3, 1}, {-3, -2, 0}};
static const double three_c[3] = {0.5, 0.25, 0};

static int load_scene(const char *ply, double open, double close, int toy, scene *s, accel **a)
{
    char xml[1024];
    snprintf(xml, sizeof xml,
             "<scene><camera position='0 0 0' lookat='0 0 -1' up='0 1 0' fov='40' width='32' height='32'/>"
             "<object name='toy'><gaussianModel file='%s' kind='3dgs'/></object></scene>", ply);
    rr_error e;
    int rc = scene_load_memory(xml, strlen(xml), "mem.xml", ".", s, &e);
    if (!rc && open == close)
        shutter_at_instant(&s->shut, open);
    else if (!rc)
        s->shut.open = open, s->shut.close = close;
    if (!rc && toy)
        make_toy(&s->objects[0].gaussians, three_vel, three_c);
    accel_settings set = {s->epsilon, s->kernel_sigma, 1};
    if (!rc && (rc = accel_build(s, &set, a, &e)))
        scene_free(s);
    if (rc)
        printf("    %s\n", e.msg);
    CHECK(rc == 0);
    return rc;
}

static void note_listed(void *user, unsigned prim) { ((int *)user)[prim] = 1; }

/* The BVH built over the shutter [0, 1] through the row's bounds: the ray
 * from the camera through each Gaussian's instant mean lists it at 20,000
 * times. Planted: a row whose bounds return the mean at c for the whole
 * interval (x, x) missed 8,660 of the 60,003 rays (and moved 84 values of
 * the render below). */
TEST(a_third_kind_is_listed_by_the_bvh_wherever_it_is)
{
    char dir[] = "/tmp/refrender-kinds-XXXXXX", ply[160];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(ply, sizeof ply, "%s/three.ply", dir);
    write_three(ply);
    scene s;
    accel *a;
    int missed = 0;
    if (!load_scene(ply, 0, 1, 1, &s, &a)) {
        const gaussian_model *m = &s.objects[0].gaussians;
        for (int j = 0; j <= 20000; j++)
            for (size_t i = 0; i < 3; i++) {
                gaussian_dynamic_state st;
                gaussian_dynamic_at(m, i, j / 20000.0, &st);
                int found[3] = {0, 0, 0};
                vec3 to = v3_normalize(v3(st.mean[0], st.mean[1], st.mean[2]));
                accel_gaussian_candidates(a, 0, v3(0, 0, 0), to, 0.0, 1e3, note_listed, found);
                missed += !found[i];
            }
        accel_free(a);
        scene_free(&s);
    }
    printf("    rays that did not list the Gaussian they aim at: %d of %d\n", missed, 3 * 20001);
    CHECK(missed == 0);
    unlink(ply);
    rmdir(dir);
}

/* A sharp render (shutter [T, T] as --time T makes it, point filter) of `toy` or of the static
 * model, resolved to RGBA. */
static int render_at(const char *ply, double T, int toy, float *rgba)
{
    scene s;
    accel *a;
    if (load_scene(ply, T, T, toy, &s, &a))
        return -1;
    render_settings rs = render_settings_default();
    rs.filter = PIXEL_FILTER_POINT;
    image img;
    rr_error e;
    volatile sig_atomic_t cancel = 0;
    int rc = image_alloc(&img, 32, 32) || render_image(a, &rs, &img, NULL, &cancel, &e);
    image_planes p;
    if (!rc && !(rc = image_planes_resolve(&img, 1, &p))) {
        memcpy(rgba, p.rgba, sizeof(float) * 4 * 32 * 32);
        image_planes_free(&p);
    }
    CHECK(rc == 0);
    image_free(&img);
    accel_free(a);
    scene_free(&s);
    return rc;
}

/* At T = 0.75 the toy's render equals, bit for bit, the render of the
 * static model whose means are its instants' (the floats instant_cull
 * writes): the renderer draws the third kind through its row as it draws
 * the static model, and its colour through the row's. */
TEST(a_third_kind_renders_as_the_static_model_of_its_instant)
{
    char dir[] = "/tmp/refrender-kinds-XXXXXX", ply[160], moved_ply[160];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(ply, sizeof ply, "%s/three.ply", dir);
    snprintf(moved_ply, sizeof moved_ply, "%s/moved.ply", dir);
    write_three(ply);
    const double T = 0.75;
    gaussian_model m;
    gaussian_model_init(&m);
    rr_error e;
    CHECK(gaussian_read(ply, GAUSSIAN_3D, &m, NULL, NULL, &e) == 0);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            m.mean[3 * i + k] = (float)(m.mean[3 * i + k] + (float)three_vel[i][k] * (T - (float)three_c[i]));
    CHECK(gaussian_write_ply(moved_ply, &m, &e) == 0);
    gaussian_model_free(&m);
    static float a[32 * 32 * 4], b[32 * 32 * 4];
    CHECK(render_at(ply, T, 1, a) == 0 && render_at(moved_ply, T, 0, b) == 0);
    int differ = 0, drawn = 0;
    for (int k = 0; k < 32 * 32 * 4; k++)
        differ += a[k] != b[k], drawn += k % 4 == 3 && b[k] > 0.1f;
    printf("    pixels drawn: %d, values that differ: %d\n", drawn, differ);
    CHECK(drawn > 20 && differ == 0);
    unlink(ply);
    unlink(moved_ply);
    rmdir(dir);
}
