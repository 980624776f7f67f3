/* PLY reader on good files in all three encodings and on each bad-input
 * case; every error must name the problem. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "core/inputfile.h"
#include "formats/gaussian_ply.h"
#include "formats/ply.h"
#include "scenexml/scene_xml.h"

static const char *tmp_path(const char *name)
{
    static char buf[256];
    snprintf(buf, sizeof buf, "/tmp/refrender-test-%d-%s", (int)getpid(), name);
    return buf;
}

static const char *write_text(const char *name, const char *text)
{
    const char *p = tmp_path(name);
    FILE *f = fopen(p, "wb");
    fputs(text, f);
    fclose(f);
    return p;
}

/* Reads path; returns the error message ("" on success). */
static const char *read_result(const char *path, pointmodel *m)
{
    static rr_error e;
    e.msg[0] = 0;
    pointmodel_init(m);
    if (ply_read(path, v3(0.5, 0.5, 0.5), m, NULL, NULL, &e) == 0)
        e.msg[0] = 0;
    unlink(path);
    return e.msg;
}

static int reads_ok(const char *path, size_t expect_count)
{
    pointmodel m;
    const char *msg = read_result(path, &m);
    int ok = msg[0] == 0 && m.count == expect_count;
    if (!ok)
        printf("    got: '%s', count %zu\n", msg, m.count);
    pointmodel_free(&m);
    return ok;
}

static int fails_with(const char *path, const char *needle)
{
    pointmodel m;
    const char *msg = read_result(path, &m);
    int ok = msg[0] && strstr(msg, needle) != NULL;
    if (!ok)
        printf("    expected error containing '%s', got '%s'\n", needle, msg);
    pointmodel_free(&m);
    return ok;
}

#define HEADER_XYZNR "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n" \
                     "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"    \
                     "property float radius\n"

TEST(ply_ascii_circular_with_uchar_colors)
{
    const char *p = write_text("a.ply", HEADER_XYZNR
        "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
        "0 0 0 0 0 1 0.5 255 0 51\n1 0 0 0 0 2 0.25 0 255 0\n");
    pointmodel m;
    const char *msg = read_result(p, &m);
    CHECK(msg[0] == 0);
    CHECK(m.count == 2);
    CHECK_NEAR(pointmodel_color(&m, 0)[2], 0.2, 1e-6); /* 51 / 255 */
    CHECK_NEAR(pointmodel_normal(&m, 1)[2], 1.0, 1e-6); /* normalised */
    CHECK_NEAR(m.bounds.hi.x, 1.25, 1e-6);
    pointmodel_free(&m);
}

TEST(ply_elliptical_axes_and_faces_element_are_accepted)
{
    const char *p = write_text("e.ply",
        "ply\nformat ascii 1.0\ncomment axes\nelement vertex 1\nproperty double x\nproperty double y\n"
        "property double z\nproperty float ux\nproperty float uy\nproperty float uz\nproperty float vx\n"
        "property float vy\nproperty float vz\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n0 0 0 2 0 0 0 0.5 0\n3 0 0 0\n");
    CHECK(reads_ok(p, 1));
}

static void put32(unsigned char *b, float v, int big)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    for (int i = 0; i < 4; i++)
        b[i] = (unsigned char)(big ? u >> (24 - 8 * i) : u >> (8 * i));
}

static const char *write_binary(const char *name, int big, int count_declared, int count_written)
{
    const char *p = tmp_path(name);
    FILE *f = fopen(p, "wb");
    fprintf(f, "ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
               "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
               "property float radius\nend_header\n",
            big ? "binary_big_endian" : "binary_little_endian", count_declared);
    for (int i = 0; i < count_written; i++) {
        float v[7] = {(float)i, 2, 3, 0, 0, 1, 0.5f};
        unsigned char b[28];
        for (int k = 0; k < 7; k++)
            put32(b + 4 * k, v[k], big);
        fwrite(b, 28, 1, f);
    }
    fclose(f);
    return p;
}

TEST(ply_binary_both_endians_decode_the_same_values)
{
    for (int big = 0; big <= 1; big++) {
        pointmodel m;
        const char *msg = read_result(write_binary("b.ply", big, 3, 3), &m);
        CHECK(msg[0] == 0 && m.count == 3);
        if (m.count == 3) {
            CHECK_NEAR(m.geom[2].center[0], 2.0, 0);
            CHECK_NEAR(m.geom[2].center[2], 3.0, 0);
            CHECK_NEAR(m.extent[0], 0.5, 1e-6);
        }
        pointmodel_free(&m);
    }
}

TEST(ply_binary_count_that_cannot_fit_is_rejected)
{
    CHECK(fails_with(write_binary("c.ply", 0, 1000000, 3), "only 84 bytes remain"));
}

TEST(ply_truncated_ascii_data)
{
    CHECK(fails_with(write_text("t.ply", HEADER_XYZNR "end_header\n0 0 0 0 0 1 0.5\n1 0 0\n"), "truncated"));
}

TEST(ply_missing_position_property)
{
    CHECK(fails_with(write_text("m.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
        "property float y\nproperty float radius\nend_header\n0 0 1\n"), "x y z"));
}

TEST(ply_missing_splat_size)
{
    CHECK(fails_with(write_text("s.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n0 0 1\n"), "no splat size"));
}

/* A trained Gaussian-splat PLY (the official save_ply's x y z, opacity,
 * scale_*, rot_*) named as a surfel model says where it belongs; a file
 * with only some of those properties gets the surfel advice. */
TEST(ply_gaussian_model_as_surfels_names_gaussianModel)
{
    const char *gs = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                     "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\nproperty float opacity\n"
                     "property float scale_0\nproperty float scale_1\nproperty float scale_2\nproperty float rot_0\n"
                     "property float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n"
                     "0 0 0 0 0 0 1 -3 -3 -3 1 0 0 0\n";
    CHECK(fails_with(write_text("g.ply", gs), "no splat size, but scale_0, rot_0 and opacity"));
    CHECK(fails_with(write_text("g.ply", gs), "<gaussianModel file="));
    const char *partial = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                          "property float z\nproperty float opacity\nproperty float scale_0\nend_header\n0 0 1 1 1\n";
    pointmodel m;
    const char *msg = read_result(write_text("p.ply", partial), &m);
    CHECK(strstr(msg, "add a 'radius' property") && !strstr(msg, "gaussianModel"));
    pointmodel_free(&m);
}

TEST(ply_nan_value)
{
    CHECK(fails_with(write_text("n.ply", HEADER_XYZNR "end_header\n0 nan 0 0 0 1 0.5\n1 0 0 0 0 1 1\n"), "NaN"));
}

TEST(ply_zero_normal)
{
    CHECK(fails_with(write_text("z.ply", HEADER_XYZNR "end_header\n0 0 0 0 0 1 0.5\n1 0 0 0 0 0 1\n"),
                     "zero-length normal"));
}

TEST(ply_negative_radius_names_the_line)
{
    /* 11 header lines, so the second vertex is on line 13 */
    CHECK(fails_with(write_text("r.ply", HEADER_XYZNR "end_header\n0 0 0 0 0 1 0.5\n1 0 0 0 0 1 -1\n"),
                     ":13: vertex 1: negative radius"));
}

TEST(ply_not_a_ply_file_and_bad_header)
{
    CHECK(fails_with(write_text("x.ply", "hello\n"), "not a PLY file"));
    CHECK(fails_with(write_text("f.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n"),
                     ":2: unknown PLY format"));
    CHECK(fails_with(write_text("h.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"), "inside the header"));
    CHECK(fails_with(tmp_path("does-not-exist.ply"), "cannot open"));
}

TEST(ply_writer_output_reads_back)
{
    surfel s[2] = {{v3(1, 2, 3), v3(0, 1, 0), 0.25, v3(1, 0, 0)},
                   {v3(-1, 0, 0), v3(1, 0, 0), 0.5, v3(0, 0, 1)}};
    rr_error e;
    const char *p = tmp_path("w.ply");
    CHECK(ply_write_surfels(p, s, 2, &e) == 0);
    pointmodel m;
    const char *msg = read_result(p, &m);
    CHECK(msg[0] == 0 && m.count == 2);
    if (m.count == 2) {
        CHECK_NEAR(m.geom[0].center[1], 2.0, 0);
        CHECK_NEAR(pointmodel_normal(&m, 0)[1], 1.0, 1e-6);
        CHECK_NEAR(pointmodel_color(&m, 1)[2], 1.0, 1e-6);
        CHECK_NEAR(m.extent[3], 0.0, 1e-6); /* normal +x: no extent along x */
    }
    pointmodel_free(&m);
}

/* ---- hostile input: each a clear error naming file and line ---- */

TEST(ply_huge_count_of_an_element_without_properties_fails_at_once)
{
    CHECK(fails_with(write_text("huge.ply", "ply\nformat ascii 1.0\nelement junk 1000000000000000\n"
        "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\n"
        "property float ny\nproperty float nz\nproperty float radius\nend_header\n0 0 0 0 0 1 1\n"),
        "element 'junk' declares 1000000000000000 instances but no properties"));
    CHECK(fails_with(write_text("huge2.ply", "ply\nformat ascii 1.0\nelement face 99999999999\n"
                                "property list uchar int vertex_indices\nelement vertex 1\nproperty float x\n"
                                "end_header\n3 0 1 2\n0\n"), "file truncated or count wrong"));
}

TEST(ply_long_ascii_token_is_read_whole)
{
    /* 1 followed by 126 zeros and e-116 is 1e10; cut at 127 characters it
     * would read as 1e126 */
    char text[1024], token[160] = "1";
    memset(token + 1, '0', 126);
    strcpy(token + 127, "e-116");
    snprintf(text, sizeof text, HEADER_XYZNR "end_header\n%s 0 0 0 0 1 0.5\n1 0 0 0 0 1 1\n", token);
    pointmodel m;
    const char *msg = read_result(write_text("long.ply", text), &m);
    CHECK(msg[0] == 0 && m.count == 2);
    if (m.count == 2)
        CHECK_NEAR(m.geom[0].center[0], 1e10, 1e3);
    pointmodel_free(&m);
}

TEST(ply_ascii_instance_is_one_line)
{
    /* a short line must not borrow the next line's values */
    CHECK(fails_with(write_text("short.ply", HEADER_XYZNR "end_header\n0.0 0.0 0.0 0.0 0.0 1.0\n1.0 0.0 0.0 0.0 0.0 1.0 1.0\n"),
                     ":12: vertex 0: the line ends after 6 values"));
    /* 8 + 6 values are not two vertices of 7 */
    CHECK(fails_with(write_text("wrap.ply", HEADER_XYZNR "end_header\n0 0 0 0 0 1 0.5 1\n0 0 0 0 1 1\n"),
                     ":12: vertex 0: more values on the line than the 7"));
}

TEST(ply_out_of_range_radius_says_so)
{
    CHECK(fails_with(write_text("big.ply", HEADER_XYZNR "end_header\n0 0 0 0 0 1 1e300\n1 0 0 0 0 1 1\n"),
                     ":12: vertex 0: splat radius must be positive and at most 1e+15, got 1e+300"));
    CHECK(fails_with(write_text("far.ply", HEADER_XYZNR "end_header\n1e200 0 0 0 0 1 1\n1 0 0 0 0 1 1\n"),
                     ":12: vertex 0: splat value 1e+200 is out of range"));
}

TEST(ply_refuses_what_is_not_a_regular_file)
{
    /* not through fails_with: it deletes the file it read */
    pointmodel m;
    rr_error e;
    pointmodel_init(&m);
    CHECK(ply_read("/dev/zero", v3(1, 1, 1), &m, NULL, NULL, &e) != 0 && strstr(e.msg, "/dev/zero: not a regular file"));
    pointmodel_free(&m);
}

TEST(ply_content_hash_covers_the_bytes)
{
    uint64_t h1 = INPUT_HASH_INIT, h2 = INPUT_HASH_INIT;
    pointmodel m;
    rr_error e;
    pointmodel_init(&m);
    CHECK(ply_read(write_text("h1.ply", HEADER_XYZNR "end_header\n0 0 0 0 0 1 0.5\n1 0 0 0 0 1 1\n"),
                   v3(1, 1, 1), &m, &h1, NULL, &e) == 0);
    CHECK(ply_read(write_text("h2.ply", HEADER_XYZNR "end_header\n0 0 0 0 0 1 0.5\n1 0 0 0 0 1 2\n"),
                   v3(1, 1, 1), &m, &h2, NULL, &e) == 0);
    CHECK(h1 != h2 && h1 != INPUT_HASH_INIT);
    const char *text = HEADER_XYZNR "end_header\n0 0 0 0 0 1 0.5\n1 0 0 0 0 1 1\n";
    CHECK(h1 == input_hash(INPUT_HASH_INIT, text, strlen(text)));
    unlink(tmp_path("h1.ply")), unlink(tmp_path("h2.ply"));
    pointmodel_free(&m);
}

/* Regression: data the header does not account for was taken silently:
 * trailing bytes after a binary file's declared elements (two vertices'
 * data under 'element vertex 1'), a second 'element vertex', and ascii
 * values their declared type cannot hold (2.5 as int, 300 as uchar). */
TEST(ply_data_the_header_does_not_declare_is_refused)
{
    CHECK(fails_with(write_binary("tr.ply", 0, 1, 2), "28 bytes after the declared elements"));
    CHECK(fails_with(write_binary("tr.ply", 1, 2, 3), "28 bytes after the declared elements"));
    CHECK(reads_ok(write_binary("ok.ply", 0, 3, 3), 3));
    CHECK(fails_with(write_text("dup.ply", HEADER_XYZNR "element vertex 1\nproperty float x\nend_header\n"
                                "0 0 0 0 0 1 0.5\n1 0 0 0 0 1 0.5\n2\n"),
                     "dup.ply:11: duplicate element 'vertex'"));
    const char *ints = HEADER_XYZNR "property uchar red\nproperty uchar green\nproperty int blue\nend_header\n";
    char text[1024];
    snprintf(text, sizeof text, "%s0 0 0 0 0 1 0.5 255 0 7\n1 0 0 0 0 1 0.5 300 0 7\n", ints);
    CHECK(fails_with(write_text("u8.ply", text), "u8.ply:16: vertex 1: property 'red' = 300"));
    CHECK(fails_with(write_text("u8.ply", text), "300 is not a uchar"));
    snprintf(text, sizeof text, "%s0 0 0 0 0 1 0.5 255 0 2.5\n1 0 0 0 0 1 0.5 3 0 7\n", ints);
    CHECK(fails_with(write_text("i.ply", text), "i.ply:15: vertex 0: property 'blue' = 2.5"));
    CHECK(fails_with(write_text("i.ply", text), "2.5 is not an int"));
    snprintf(text, sizeof text, "%s0 0 0 0 0 1 0.5 255 0 -2147483648\n1 0 0 0 0 1 0.5 0 0 2147483647\n", ints);
    CHECK(reads_ok(write_text("i.ply", text), 2));
}

/* The cancel flag is a parameter (issue 57: no global read by the reader):
 * set before the read, the surfel reader, the Gaussian reader and the
 * scene loader that reaches them each stop at vertex 0 with the message a
 * signal during a long load gives, naming the file; unset (or NULL), the
 * same files load whole. */
TEST(a_set_cancel_flag_stops_every_model_read_it_is_handed)
{
    char surfels[256], gaussians[256], scene_path[256], xml[1024]; /* (write_text's path is one buffer) */
    snprintf(surfels, sizeof surfels, "%s",
             write_text("cancel.ply", HEADER_XYZNR "end_header\n0 0 0 0 0 1 0.5\n1 0 0 0 0 1 1\n"));
    snprintf(gaussians, sizeof gaussians, "%s", write_text("cancel_g.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
        "property float y\nproperty float z\nproperty float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n"
        "property float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float rot_0\n"
        "property float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n0 0 0 0.1 0.1 0.1 0 0 0 1 0 0 0\n"));
    snprintf(xml, sizeof xml, "<scene><camera position='0 0 5' lookat='0 0 0' width='4' height='4'/><object>"
             "<pointModel file='%s'/></object></scene>", surfels);
    snprintf(scene_path, sizeof scene_path, "%s", write_text("cancel.xml", xml));
    volatile sig_atomic_t stop = 1;
    pointmodel m;
    gaussian_model g;
    scene s;
    rr_error e;
    pointmodel_init(&m), gaussian_model_init(&g);
    CHECK(ply_read(surfels, v3(1, 1, 1), &m, NULL, &stop, &e) == -1 && m.count == 0);
    printf("    %s\n", e.msg);
    CHECK(strstr(e.msg, "cancel.ply: interrupted while reading vertex 0 of 2") != NULL);
    CHECK(gaussian_read(gaussians, GAUSSIAN_AUTO, &g, NULL, &stop, &e) == -1);
    CHECK(strstr(e.msg, "cancel_g.ply: interrupted while reading vertex 0 of 1") != NULL);
    CHECK(scene_load_file_params(scene_path, &(scene_load_options){NULL, &stop}, &s, &e) == -1);
    printf("    %s\n", e.msg);
    CHECK(strstr(e.msg, "cancel.ply: interrupted while reading vertex 0 of 2") != NULL);
    stop = 0;
    CHECK(ply_read(surfels, v3(1, 1, 1), &m, NULL, &stop, &e) == 0 && m.count == 2);
    CHECK(gaussian_read(gaussians, GAUSSIAN_AUTO, &g, NULL, &stop, &e) == 0 && g.count == 1);
    CHECK(scene_load_file_params(scene_path, &(scene_load_options){NULL, &stop}, &s, &e) == 0);
    CHECK(s.nobjects == 1 && s.objects[0].model.count == 2);
    scene_free(&s), pointmodel_free(&m), gaussian_model_free(&g);
    CHECK(ply_read(surfels, v3(1, 1, 1), &m, NULL, NULL, &e) == 0 && m.count == 2);
    pointmodel_free(&m);
    unlink(surfels), unlink(gaussians), unlink(scene_path);
}
