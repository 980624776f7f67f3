/* gaussian.c: trained 3DGS/2DGS models read by property name with the
 * official activations, every bad input refused naming the property, and
 * the SH colour checked against its defining properties (orthonormal real
 * harmonics over the sphere; the published degree-1 signs by hand). */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "gaussians/gaussian.h"
#include "formats/gaussian_ply.h"
#include "core/inputfile.h"
#include "core/lanes.h"
#include "formats/ply.h"
#include "harness.h"

/* A PLY of one Gaussian per row of vals, with the given property names, in
 * binary little endian (or ascii); returns its length (buffer is malloc'ed). */
static size_t make_ply(char **out, const char *const *names, int nprops, const double *vals, int rows, int ascii,
                       long declared)
{
    size_t cap = 4096 + (size_t)rows * (size_t)nprops * 32, len = 0;
    char *b = malloc(cap);
    len += (size_t)sprintf(b + len, "ply\nformat %s 1.0\nelement vertex %ld\n",
                           ascii ? "ascii" : "binary_little_endian", declared >= 0 ? declared : (long)rows);
    for (int k = 0; k < nprops; k++)
        len += (size_t)sprintf(b + len, "property float %s\n", names[k]);
    len += (size_t)sprintf(b + len, "end_header\n");
    for (int r = 0; r < rows; r++) {
        for (int k = 0; k < nprops; k++) {
            float f = (float)vals[r * nprops + k];
            if (ascii)
                len += (size_t)sprintf(b + len, "%.9g%c", vals[r * nprops + k], k + 1 < nprops ? ' ' : '\n');
            else
                memcpy(b + len, &f, 4), len += 4;
        }
    }
    *out = b;
    return len;
}

/* The property names of a model with `rest` f_rest properties, 2 or 3
 * scales, in reverse order (the reader must find them by name). */
static int names_for(char names[][16], const char **ptr, int rest, int scales)
{
    int n = 0;
    const char *fixed[] = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
    for (int k = 0; k < 9; k++)
        snprintf(names[n++], 16, "%s", fixed[k]);
    for (int k = 0; k < rest; k++)
        snprintf(names[n++], 16, "f_rest_%d", k);
    snprintf(names[n++], 16, "opacity");
    for (int k = 0; k < scales; k++)
        snprintf(names[n++], 16, "scale_%d", k);
    for (int k = 0; k < 4; k++)
        snprintf(names[n++], 16, "rot_%d", k);
    for (int k = 0; k < n; k++)
        ptr[n - 1 - k] = names[k];
    return n;
}

/* Values in the same reverse order: the value of property name[k] is
 * value_of(name) below. */
static double value_of(const char *name)
{
    if (!strcmp(name, "x")) return 1;
    if (!strcmp(name, "y")) return 2;
    if (!strcmp(name, "z")) return 3;
    if (!strncmp(name, "f_dc_", 5)) return 0.1 * (1 + atoi(name + 5));
    if (!strncmp(name, "f_rest_", 7)) return atoi(name + 7);
    if (!strcmp(name, "opacity")) return 0; /* sigmoid: 0.5 */
    if (!strcmp(name, "scale_0")) return log(2);
    if (!strcmp(name, "scale_1")) return log(3);
    if (!strcmp(name, "scale_2")) return log(0.5);
    if (!strcmp(name, "rot_0")) return 2; /* normalised: (1, 0, 0, 0) */
    return 0; /* nx ny nz, rot_1..3 */
}

static int parse_model(int rest, int scales, int ascii, gaussian_kind kind, gaussian_model *m, rr_error *e)
{
    char names[80][16];
    const char *ptr[80];
    double vals[80];
    int n = names_for(names, ptr, rest, scales);
    for (int k = 0; k < n; k++)
        vals[k] = value_of(ptr[k]);
    char *buf;
    size_t len = make_ply(&buf, ptr, n, vals, 1, ascii, -1);
    gaussian_model_init(m);
    int rc = gaussian_parse("g.ply", buf, len, kind, m, e);
    free(buf);
    return rc;
}

TEST(gaussian_3dgs_is_read_by_name_with_the_official_activations)
{
    gaussian_model m;
    rr_error e;
    CHECK(parse_model(45, 3, 0, GAUSSIAN_AUTO, &m, &e) == 0);
    CHECK(m.count == 1 && m.kind == GAUSSIAN_3D && m.sh_degree == 3 && m.sh_coeffs == 16);
    CHECK_NEAR(m.mean[0], 1, 0), CHECK_NEAR(m.mean[1], 2, 0), CHECK_NEAR(m.mean[2], 3, 0);
    CHECK_NEAR(m.scale[0], 2, 1e-6), CHECK_NEAR(m.scale[1], 3, 1e-6), CHECK_NEAR(m.scale[2], 0.5, 1e-7);
    CHECK_NEAR(m.rotation[0], 1, 0), CHECK_NEAR(m.rotation[1], 0, 0);
    CHECK_NEAR(m.opacity[0], 0.5, 0);
    /* DC: coefficient 0; rest channel-major: f_rest_(c 15 + k - 1) is
     * coefficient k of channel c */
    for (int c = 0; c < 3; c++) {
        CHECK_NEAR(m.sh[c], 0.1 * (c + 1), 1e-7);
        for (int k = 1; k < 16; k++)
            CHECK_NEAR(m.sh[3 * k + c], c * 15 + k - 1, 0);
    }
    gaussian_model_free(&m);
}

TEST(gaussian_2dgs_is_detected_and_kinds_can_be_forced)
{
    gaussian_model m;
    rr_error e;
    CHECK(parse_model(9, 2, 1, GAUSSIAN_AUTO, &m, &e) == 0); /* ascii, degree 1 */
    CHECK(m.kind == GAUSSIAN_2D && m.sh_degree == 1 && m.scale[2] == 0);
    CHECK_NEAR(m.sh[3 * 3 + 2], 2 * 3 + 2, 0); /* coefficient 3 of B: f_rest_8 */
    gaussian_model_free(&m);
    CHECK(parse_model(9, 2, 0, GAUSSIAN_3D, &m, &e) == -1 && strstr(e.msg, "'scale_2'"));
    CHECK(parse_model(0, 3, 0, GAUSSIAN_2D, &m, &e) == 0 && m.kind == GAUSSIAN_2D && m.scale[2] == 0);
    CHECK(m.sh_degree == 0);
    gaussian_model_free(&m);
    CHECK(parse_model(24, 3, 0, GAUSSIAN_AUTO, &m, &e) == 0 && m.sh_degree == 2);
    gaussian_model_free(&m);
}

/* Bad inputs: each refused with the file and the property. */
static int refused(const char *const *names, int n, const double *vals, long declared, const char *expect)
{
    char *buf;
    size_t len = make_ply(&buf, names, n, vals, 1, 0, declared);
    gaussian_model m;
    rr_error e;
    gaussian_model_init(&m);
    int rc = gaussian_parse("bad.ply", buf, len, GAUSSIAN_AUTO, &m, &e);
    free(buf);
    int ok = rc == -1 && strstr(e.msg, "bad.ply") && strstr(e.msg, expect) && m.count == 0 && !m.mean;
    if (!ok)
        printf("    expected '%s', got: %s\n", expect, rc ? e.msg : "success");
    gaussian_model_free(&m);
    return ok;
}

TEST(gaussian_bad_inputs_name_the_property)
{
    const char *base[] = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "rot_0",
                          "rot_1", "rot_2", "rot_3"};
    double ok[13] = {0, 0, 0, 0.1, 0.1, 0.1, 0, 0, 0, 1, 0, 0, 0};
    CHECK(refused(base, 12, ok, -1, "lacks the vertex property 'rot_3'"));
    const char *dup[] = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "rot_0",
                         "rot_1", "rot_2", "rot_3", "opacity"};
    double dupv[14] = {0, 0, 0, 0.1, 0.1, 0.1, 0, 0, 0, 1, 0, 0, 0, 0};
    CHECK(refused(dup, 14, dupv, -1, "duplicate vertex property 'opacity'"));
    double nan[13] = {0, 0, 0, 0.1, 0.1, 0.1, NAN, 0, 0, 1, 0, 0, 0};
    CHECK(refused(base, 13, nan, -1, "property 'opacity' is nan"));
    double zero_q[13] = {0, 0, 0, 0.1, 0.1, 0.1, 0, 0, 0, 0, 0, 0, 0};
    CHECK(refused(base, 13, zero_q, -1, "zero-length quaternion"));
    double huge[13] = {0, 0, 0, 0.1, 0.1, 0.1, 0, 80, 0, 1, 0, 0, 0};
    CHECK(refused(base, 13, huge, -1, "'scale_0' = 80"));
    CHECK(refused(base, 13, ok, 1000000000L, "declares 1000000000 'vertex' elements"));
    /* ten f_rest properties are no degree; a gap in the run */
    const char *rest10[23];
    char names[10][16];
    for (int k = 0; k < 13; k++)
        rest10[k] = base[k];
    for (int k = 0; k < 10; k++)
        snprintf(names[k], 16, "f_rest_%d", k), rest10[13 + k] = names[k];
    double v23[23] = {0, 0, 0, 0.1, 0.1, 0.1, 0, 0, 0, 1, 0, 0, 0};
    CHECK(refused(rest10, 23, v23, -1, "10 f_rest properties are no SH degree"));
    snprintf(names[4], 16, "f_rest_12");
    CHECK(refused(rest10, 23, v23, -1, "'f_rest_5' is present but 'f_rest_4' is not"));
}

/* Embree drops boxes beyond about 1.8e18, so a Gaussian far
 * out vanished from the image with exit 0: a mean coordinate beyond
 * RR_MAX_REACH (a float's 1e38 too) is refused, naming the vertex. */
TEST(gaussian_means_beyond_the_reach_limit_are_refused)
{
    const char *base[] = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "rot_0",
                          "rot_1", "rot_2", "rot_3"};
    double far[13] = {0, 0, 1e19, 0.1, 0.1, 0.1, 0, 0, 0, 1, 0, 0, 0};
    CHECK(refused(base, 13, far, -1, "vertex 0"));
    CHECK(refused(base, 13, far, -1, "property 'z' = 1e+19 is beyond 1e+15"));
    double flt_max[13] = {1e38, 0, 0, 0.1, 0.1, 0.1, 0, 0, 0, 1, 0, 0, 0};
    CHECK(refused(base, 13, flt_max, -1, "property 'x' = 1e+38 is beyond 1e+15"));
    double edge[13] = {1e15, -1e15, 0, 0.1, 0.1, 0.1, 0, 0, 0, 1, 0, 0, 0}; /* the limit itself is fine */
    char *buf;
    size_t len = make_ply(&buf, base, 13, edge, 1, 0, -1);
    gaussian_model m;
    rr_error e;
    gaussian_model_init(&m);
    CHECK(gaussian_parse("edge.ply", buf, len, GAUSSIAN_AUTO, &m, &e) == 0 && m.count == 1);
    free(buf);
    gaussian_model_free(&m);
}

/* An ascii model of one Gaussian: the header's property lines (type and
 * name) and the values' line; parsed into m. */
static int parse_ascii(const char *props, const char *values, gaussian_model *m, rr_error *e)
{
    char text[4096];
    snprintf(text, sizeof text, "ply\nformat ascii 1.0\nelement vertex 1\n%send_header\n%s\n", props, values);
    gaussian_model_init(m);
    return gaussian_parse("a.ply", text, strlen(text), GAUSSIAN_AUTO, m, e);
}

#define ASCII_PROPS(rest_type, x_type, rot_type)                                                                \
    "property " x_type " x\nproperty float y\nproperty float z\nproperty float f_dc_0\nproperty float f_dc_1\n" \
    "property float f_dc_2\nproperty " rest_type " f_rest_0\nproperty float f_rest_1\nproperty float f_rest_2\n"  \
    "property float f_rest_3\nproperty float f_rest_4\nproperty float f_rest_5\nproperty float f_rest_6\n"       \
    "property float f_rest_7\nproperty float f_rest_8\nproperty float opacity\nproperty float scale_0\n"        \
    "property float scale_1\nproperty " rot_type " rot_0\nproperty " rot_type " rot_1\nproperty " rot_type       \
    " rot_2\nproperty " rot_type " rot_3\n"

/* Values finite as doubles but not as floats (a double
 * f_rest_0 of 1e300, ascii 1e39 for a float x) were stored as inf; they
 * are refused naming the property, the value and the vertex's line. */
TEST(gaussian_values_beyond_float_range_are_refused)
{
    gaussian_model m;
    rr_error e;
    int rc = parse_ascii(ASCII_PROPS("double", "float", "float"), "0 0 0 0.1 0.1 0.1 1e300 0 0 0 0 0 0 0 0 0 0 0 1 0 0 0",
                         &m, &e);
    CHECK(rc == -1 && strstr(e.msg, "a.ply:27: vertex 0") && strstr(e.msg, "'f_rest_0' = 1e+300") &&
          strstr(e.msg, "float"));
    gaussian_model_free(&m);
    rc = parse_ascii(ASCII_PROPS("float", "float", "float"), "0 0 0 0.1 0.1 0.1 3.5e38 0 0 0 0 0 0 0 0 0 0 0 1 0 0 0",
                     &m, &e);
    CHECK(rc == -1 && strstr(e.msg, "'f_rest_0' = 3.5e+38"));
    gaussian_model_free(&m);
}

/* The quaternion is normalised by its largest component first:
 * components of 1e200 overflowed q.q (the rotation came out zero, later
 * taken as the identity) and a lone 1e-170 underflowed it (refused as zero
 * length though it is not). Only a zero quaternion is refused. */
TEST(gaussian_quaternions_of_any_finite_size_are_normalised)
{
    gaussian_model m;
    rr_error e;
    const char *props = ASCII_PROPS("float", "float", "double");
    CHECK(parse_ascii(props, "0 0 0 0.1 0.1 0.1 0 0 0 0 0 0 0 0 0 0 0 0 1e200 1e200 0 0", &m, &e) == 0);
    if (m.count)
        CHECK_NEAR(m.rotation[0], sqrt(0.5), 1e-7), CHECK_NEAR(m.rotation[1], sqrt(0.5), 1e-7);
    gaussian_model_free(&m);
    CHECK(parse_ascii(props, "0 0 0 0.1 0.1 0.1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 -1e-170 0", &m, &e) == 0);
    if (m.count)
        CHECK(m.rotation[0] == 0 && m.rotation[1] == 0 && m.rotation[2] == -1 && m.rotation[3] == 0);
    gaussian_model_free(&m);
    CHECK(parse_ascii(props, "0 0 0 0.1 0.1 0.1 0 0 0 0 0 0 0 0 0 0 0 0 0 -0 0 0", &m, &e) == -1 &&
          strstr(e.msg, "zero-length quaternion"));
    gaussian_model_free(&m);
}

/* A model with the 13 base properties and n f_rest properties f_rest_0..,
 * or with extra (a name) after them, refused with expect. */
static int refused_rest(int n, const char *extra, const char *expect)
{
    static char names[300][16];
    const char *ptr[300] = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "rot_0",
                            "rot_1", "rot_2", "rot_3"};
    double vals[300] = {0, 0, 0, 0.1, 0.1, 0.1, 0, 0, 0, 1, 0, 0, 0};
    for (int k = 0; k < n; k++)
        snprintf(names[k], 16, "f_rest_%d", k), ptr[13 + k] = names[k];
    if (extra)
        ptr[13 + n++] = extra;
    return refused(ptr, 13 + n, vals, -1, expect);
}

/* f_rest_* past f_rest_44 were once ignored, so degree 4's 72 read
 * as degree 3 with the wrong offsets and 46 or 48 as degree 3 with extras
 * unread; every count but 0, 9, 24 and 45 is refused, naming the degree. */
TEST(gaussian_sh_layouts_past_degree_3_are_refused)
{
    CHECK(refused_rest(72, NULL, "72 f_rest properties make SH degree 4"));
    CHECK(refused_rest(72, NULL, "degrees above 3 are not supported"));
    CHECK(refused_rest(46, NULL, "46 f_rest properties are no SH degree"));
    CHECK(refused_rest(46, NULL, "between degree 3's 45 and degree 4's 72"));
    CHECK(refused_rest(48, NULL, "48 f_rest properties are no SH degree"));
    CHECK(refused_rest(45, "f_rest_50", "'f_rest_50' is present but 'f_rest_45' is not"));
    CHECK(refused_rest(45, "f_rest_45", "degrees above 3 are not supported"));
}

/* Mip-Splatting's models carry a 3D smoothing filter (vertex
 * property filter_3D) that changes every Gaussian's extent and opacity;
 * rendering them without it would be silently wrong, so they are refused. */
TEST(gaussian_mip_splatting_filter_3d_is_refused)
{
    CHECK(refused_rest(0, "filter_3D", "bad.ply:17: vertex property 'filter_3D'"));
    CHECK(refused_rest(9, "filter_3D", "Mip-Splatting's 3D filter is not supported"));
}

/* The SH sums in AVX2 lanes (where the CPU has them) are the scalar sums
 * bit for bit: random coefficients of every degree, random directions
 * (the DCHECKS build, make test's, compares the doubles themselves through
 * its hook; skipped elsewhere, and without the lanes). */
TEST(sh_sums_in_lanes_are_the_scalar_sums)
{
#ifndef RR_DCHECKS
    harness_skip("the lanes' hook is in the DCHECKS build only");
    return;
#endif
    SKIP_UNLESS(rr_lanes_available(), "no AVX2 lanes on this CPU (or RR_NO_LANES is set)");
    unsigned st = 29;
    float sh[3 * GAUSSIAN_MAX_SH_COEFFS];
    int differ = 0, trials = 0;
    for (int trial = 0; trial < 20000; trial++) {
        int degree = trial % (GAUSSIAN_MAX_SH_DEGREE + 1);
        for (int k = 0; k < 3 * GAUSSIAN_MAX_SH_COEFFS; k++)
            sh[k] = (float)((rand_r(&st) / (double)RAND_MAX - 0.5) * pow(10.0, rand_r(&st) % 7 - 3));
        vec3 dir = v3(rand_r(&st) / (double)RAND_MAX - 0.5, rand_r(&st) / (double)RAND_MAX - 0.5,
                      rand_r(&st) / (double)RAND_MAX - 0.5);
#ifdef RR_DCHECKS
        differ += gaussian_sh_lanes_differ(sh, degree, dir);
#endif
        trials++;
        (void)degree, (void)dir;
    }
    printf("    %d colours, %d differing\n", trials, differ);
    CHECK(differ == 0);
}

/* The basis function k at dir, read through gaussian_sh_color: coefficient
 * 0.1 on basis k of the red channel (small enough that 0.5 + it is never
 * clamped), so Y_k = (R - 0.5) / 0.1. */
static double basis(int k, vec3 dir)
{
    float sh[3 * 16] = {0};
    sh[3 * k] = 0.1f;
    return (gaussian_sh_color(sh, 3, dir).x - 0.5) / 0.1;
}

/* Real SH are orthonormal over the sphere: the integral of Y_i Y_j is
 * delta_ij (midpoint rule in z = cos theta, uniform in phi: both exact to
 * well below 1e-4 for these polynomials of degree <= 6). */
TEST(gaussian_sh_basis_is_orthonormal_with_the_published_degree_1_signs)
{
    enum { NZ = 400, NPHI = 32 };
    static double y[16][NZ * NPHI];
    for (int a = 0; a < NZ; a++)
        for (int b = 0; b < NPHI; b++) {
            double z = -1 + (a + 0.5) * 2.0 / NZ, phi = b * 2 * M_PI / NPHI, s = sqrt(1 - z * z);
            for (int k = 0; k < 16; k++)
                y[k][a * NPHI + b] = basis(k, v3(s * cos(phi), s * sin(phi), z));
        }
    double worst = 0, dA = (2.0 / NZ) * (2 * M_PI / NPHI);
    for (int i = 0; i < 16; i++)
        for (int j = 0; j < 16; j++) {
            double sum = 0;
            for (int p = 0; p < NZ * NPHI; p++)
                sum += y[i][p] * y[j][p] * dA;
            worst = fmax(worst, fabs(sum - (i == j)));
        }
    CHECK(worst < 2e-4);
    /* sh_utils.py: degree 1 is -C1 y sh1 + C1 z sh2 - C1 x sh3 (C1 = sqrt(3 / (4 pi))) */
    double c1 = sqrt(3 / (4 * M_PI));
    CHECK_NEAR(basis(1, v3(0, 2, 0)), -c1, 1e-6);
    CHECK_NEAR(basis(2, v3(0, 0, 1)), c1, 1e-6);
    CHECK_NEAR(basis(3, v3(1, 0, 0)), -c1, 1e-6);
    /* + 0.5, clamped below at 0 only */
    float dc[3] = {-10, 0, 10};
    vec3 c = gaussian_sh_color(dc, 0, v3(0, 0, 1));
    CHECK(c.x == 0 && c.y == 0.5 && c.z > 3);
}

TEST(gaussian_read_takes_a_file_and_hashes_its_bytes)
{
    const char *names[] = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "rot_0",
                           "rot_1", "rot_2", "rot_3"};
    double vals[13] = {0, 0, 0, 0.1, 0.1, 0.1, 0, 0, 0, 1, 0, 0, 0};
    char *buf, path[] = "/tmp/rr_gaussian_XXXXXX";
    size_t len = make_ply(&buf, names, 13, vals, 1, 0, -1);
    int fd = mkstemp(path);
    CHECK(fd >= 0 && write(fd, buf, len) == (ssize_t)len);
    close(fd);
    gaussian_model m;
    rr_error e;
    uint64_t h1 = 1, h2 = 1;
    gaussian_model_init(&m);
    CHECK(gaussian_read(path, GAUSSIAN_AUTO, &m, &h1, NULL, &e) == 0 && m.count == 1 && m.kind == GAUSSIAN_2D);
    CHECK(gaussian_read(path, GAUSSIAN_AUTO, &m, &h2, NULL, &e) == 0 && h1 == h2 && h1 != 1);
    gaussian_model_free(&m);
    unlink(path);
    free(buf);
    CHECK(gaussian_read(path, GAUSSIAN_AUTO, &m, NULL, NULL, &e) == -1 && strstr(e.msg, path));
}

/* The 3x3 rotation of a unit quaternion (w, x, y, z), as the official
 * build_rotation writes it: the test's own formula, not the writer's. */
static void rotation_of(const float *q, double r[3][3])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    double m[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                      {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                      {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
    memcpy(r, m, sizeof m);
}

/* Surfels to Gaussians, written in the official layout and read back: the
 * normal is the third axis of the rotation, the tangent scales half the
 * radius, the DC colour the surfel's, and everything survives the file
 * (activations undone on writing, redone on reading). */
TEST(gaussians_from_surfels_round_trip_through_the_official_layout)
{
    surfel s[4] = {{{0, 0, 0}, {0, 0, 1}, 0.2, {0.9, 0.1, 0.5}},
                   {{1, 2, 3}, {1, 1, 0}, 0.4, {0.2, 0.7, 0.3}},
                   {{-1, 0, 2}, {0, -1, 0}, 0.1, {0.5, 0.5, 0.5}},
                   {{0, 1, 0}, {0.3, -0.2, 0.9}, 0.3, {0.1, 0.2, 0.3}}}; /* every branch of the conversion */
    for (int kind = 2; kind <= 3; kind++) {
        gaussian_model m, back;
        rr_error e;
        gaussian_model_init(&m), gaussian_model_init(&back);
        CHECK(gaussian_from_surfels(s, 4, (gaussian_kind)kind, 3, &m, &e) == 0);
        char path[] = "/tmp/rr_gauss_rt_XXXXXX";
        int fd = mkstemp(path);
        close(fd);
        CHECK(gaussian_write_ply(path, &m, &e) == 0);
        CHECK(gaussian_read(path, GAUSSIAN_AUTO, &back, NULL, NULL, &e) == 0);
        unlink(path);
        CHECK(back.count == 4 && (int)back.kind == kind && back.sh_degree == 3);
        for (int i = 0; i < 4 && back.count == 4; i++) {
            double r[3][3];
            rotation_of(back.rotation + 4 * i, r);
            vec3 n = v3_normalize(s[i].normal);
            CHECK_NEAR(r[0][2], n.x, 1e-6), CHECK_NEAR(r[1][2], n.y, 1e-6), CHECK_NEAR(r[2][2], n.z, 1e-6);
            CHECK_NEAR(r[0][0] * r[0][1] + r[1][0] * r[1][1] + r[2][0] * r[2][1], 0, 1e-6);
            CHECK_NEAR(back.scale[3 * i], 0.5 * s[i].radius, 1e-7);
            CHECK_NEAR(back.scale[3 * i + 1], 0.5 * s[i].radius, 1e-7);
            CHECK(kind == 2 ? back.scale[3 * i + 2] == 0 : back.scale[3 * i + 2] > 0);
            CHECK_NEAR(back.opacity[i], 0.95, 1e-6);
            float dc[3];
            memcpy(dc, back.sh + 48 * i, sizeof dc);
            vec3 c = gaussian_sh_color(dc, 0, v3(0.3, -0.2, 1));
            CHECK_NEAR(c.x, s[i].color.x, 1e-6), CHECK_NEAR(c.y, s[i].color.y, 1e-6);
            CHECK_NEAR(c.z, s[i].color.z, 1e-6);
            CHECK(!memcmp(back.sh + 48 * i, m.sh + 48 * i, 48 * sizeof(float))); /* every coefficient exact */
            CHECK(!memcmp(back.mean + 3 * i, m.mean + 3 * i, 3 * sizeof(float)));
        }
        gaussian_model_free(&m), gaussian_model_free(&back);
    }
}

/* A model larger than the streaming threshold (64 MiB) is read from a
 * mapping released as it is parsed (the whole file and the model were
 * once held at once): the same model and the same content hash as
 * reading the bytes from memory. */
TEST(gaussian_a_large_model_is_streamed_to_the_same_model_and_hash)
{
    gaussian_model m, back, ref;
    rr_error err;
    gaussian_model_init(&m), gaussian_model_init(&back), gaussian_model_init(&ref);
    m.kind = GAUSSIAN_3D, m.sh_degree = 3, m.sh_coeffs = 16;
    size_t n = 300000; /* 248 bytes each: 74 MB */
    CHECK(gaussian_model_alloc(&m, n) == 0);
    m.count = n;
    for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++)
            m.mean[3 * i + k] = (float)(i % 1000) * 0.001f + (float)k, m.scale[3 * i + k] = 0.01f * (float)(k + 1);
        m.rotation[4 * i] = 1, m.rotation[4 * i + 1] = m.rotation[4 * i + 2] = m.rotation[4 * i + 3] = 0;
        m.opacity[i] = 0.5f;
        for (int k = 0; k < 48; k++)
            m.sh[48 * i + k] = (float)((i * 48 + (size_t)k) % 997) * 1e-3f;
    }
    char path[] = "/tmp/refrender-test-XXXXXX.ply";
    int fd = mkstemps(path, 4);
    CHECK(fd >= 0);
    close(fd);
    CHECK(gaussian_write_ply(path, &m, &err) == 0);
    uint64_t streamed = INPUT_HASH_INIT;
    CHECK(gaussian_read(path, GAUSSIAN_AUTO, &back, &streamed, NULL, &err) == 0);
    input_file whole;
    CHECK(input_file_read(path, (size_t)1 << 30, &whole, &err) == 0);
    CHECK(whole.len > ((size_t)64 << 20));
    CHECK(streamed == input_hash(INPUT_HASH_INIT, whole.data, whole.len));
    CHECK(gaussian_parse(path, whole.data, whole.len, GAUSSIAN_AUTO, &ref, &err) == 0);
    CHECK(back.count == n && ref.count == n);
    CHECK(!memcmp(back.mean, ref.mean, 3 * n * sizeof(float)) && !memcmp(back.sh, ref.sh, 48 * n * sizeof(float)));
    CHECK(!memcmp(back.scale, ref.scale, 3 * n * sizeof(float)) && !memcmp(back.opacity, ref.opacity, n * sizeof(float)));
    input_file_free(&whole);
    unlink(path);
    gaussian_model_free(&m), gaussian_model_free(&back), gaussian_model_free(&ref);
}

#define RGB_GEOMETRY                                                                                              \
    "property float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float scale_2\n"          \
    "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\n"

/* nerfstudio's RGB export (v1.1.5 scripts/exporter.py:588-593: uchar red/green/blue, no f_dc_*, no
 * f_rest_*) is SH degree 0 with DC = (u/255 - 0.5)/C0, the RGB2SH of the colour splatfacto draws
 * (models/splatfacto.py:95-108), C0 = 1/(2 sqrt(pi)); f_dc_*, when present, are the colour. */
TEST(gaussian_rgb_colours_without_f_dc_become_the_sh_dc)
{
    const double c0 = 0.5 / sqrt(acos(-1.0));
    gaussian_model m;
    rr_error e;
    int rc = parse_ascii("property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
                         "property uchar green\nproperty uchar blue\n" RGB_GEOMETRY,
                         "0 0 0 255 0 128 0 0 0 0 1 0 0 0", &m, &e);
    CHECK(rc == 0 && m.sh_degree == 0 && m.sh_coeffs == 1);
    if (rc == 0) {
        CHECK(m.sh[0] == (float)(0.5 / c0) && m.sh[1] == (float)(-0.5 / c0));
        CHECK(m.sh[2] == (float)((128 / 255.0 - 0.5) / c0));
    }
    gaussian_model_free(&m);
    rc = parse_ascii("property float x\nproperty float y\nproperty float z\nproperty float f_dc_0\n"
                     "property float f_dc_1\nproperty float f_dc_2\nproperty uchar red\nproperty uchar green\n"
                     "property uchar blue\n" RGB_GEOMETRY,
                     "0 0 0 0.25 0.5 0.75 255 0 128 0 0 0 0 1 0 0 0", &m, &e);
    CHECK(rc == 0 && m.sh[0] == 0.25f && m.sh[1] == 0.5f && m.sh[2] == 0.75f);
    gaussian_model_free(&m);
    rc = parse_ascii("property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
                     "property uchar green\n" RGB_GEOMETRY,
                     "0 0 0 255 0 0 0 0 0 1 0 0 0", &m, &e);
    CHECK(rc == -1 && strstr(e.msg, "a.ply") && strstr(e.msg, "lacks the vertex property 'blue'"));
    gaussian_model_free(&m);
}
