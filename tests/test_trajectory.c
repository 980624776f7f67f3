/* trajectory.c and tum.c: the TUM reader names every mistake (file, line, field),
 * a file it wrote reads back bit for bit, and the motion bounds hold the
 * interpolated path (the poses themselves are checked against an
 * independent reference in tests/test_trajectory.py). */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/camera.h"
#include "core/rotation.h"
#include "motion/trajectory.h"
#include "formats/tum.h"
#include "harness.h"

static int parse(const char *text, trajectory *tr, rr_error *e)
{
    return tum_parse(text, strlen(text), "p.tum", tr, e);
}

static int fails_with(const char *text, const char *needle)
{
    trajectory tr;
    rr_error e = {{0}};
    int ok = parse(text, &tr, &e) != 0 && strstr(e.msg, needle) != NULL;
    if (!ok)
        printf("    expected an error with '%s', got '%s'\n", needle, e.msg);
    return ok;
}

#define L0 "0 0 0 0 0 0 0 1\n"

TEST(tum_reader_names_file_line_and_field)
{
    CHECK(fails_with(L0 "1 0 0\n", "p.tum:2: field 'tz' is missing"));
    CHECK(fails_with(L0 "1 0 0 nan 0 0 0 1\n", "p.tum:2: field 'tz' is not a finite number ('nan')"));
    CHECK(fails_with(L0 "1 0 0 0 0 0 0 inf\n", "field 'qw' is not a finite number"));
    CHECK(fails_with(L0 "1 0 0 0 0 0 0 x1\n", "field 'qw' is not a finite number ('x1')"));
    CHECK(fails_with(L0 "1 0 0 0 0 0 0 1 7\n", "p.tum:2: more than the 8 fields"));
    CHECK(fails_with(L0 "1 0 0 0 0 0 0 0\n", "p.tum:2: the quaternion (qx qy qz qw) = (0 0 0 0) has no direction"));
    CHECK(fails_with(L0 "1 0 0 0 0 0 0 2\n", "p.tum:2: the quaternion (qx qy qz qw) has length 2"));
    CHECK(fails_with(L0 "# c\n\n0 0 0 0 0 0 0 1\n", "p.tum:4: time 0 does not follow the previous line's 0"));
    CHECK(fails_with(L0 "-1 0 0 0 0 0 0 1\n", "time -1 does not follow"));
    CHECK(fails_with("0 0 0 1e309 0 0 0 1\n", "field 'tz' is not a finite number"));
    CHECK(fails_with("0 01e308 0 0 0 1 0 0\n", "p.tum:1: field 'tx' is 1e+308, beyond the 1e+15")); /* fuzz finding */
    CHECK(fails_with("-1e308 0 0 0 0 0 0 1\n1e308 0 0 0 0 0 0 1\n", "p.tum:2: time 1e+308 is too far"));
    const char nul[] = "0 0 0 0\0 0 0 0 1\n";
    trajectory tr;
    rr_error e;
    CHECK(tum_parse(nul, sizeof nul - 1, "p.tum", &tr, &e) != 0 && strstr(e.msg, "NUL"));
}

TEST(tum_reader_skips_comments_and_normalises_short_quaternions)
{
    trajectory tr;
    rr_error e;
    CHECK(parse("# t tx ty tz qx qy qz qw\n\n  \t\r\n" L0 "2\t1 2 3  0 0 0.7071 0.7071\r\n", &tr, &e) == 0);
    CHECK(tr.count == 2);
    CHECK(tr.knots[1].t == 2 && tr.knots[1].p.z == 3);
    double n = 0;
    for (int i = 0; i < 4; i++)
        n += tr.knots[1].q[i] * tr.knots[1].q[i];
    CHECK_NEAR(n, 1.0, 1e-15);                  /* written with 4 digits: normalised */
    CHECK(tr.knots[0].q[0] == 1 && tr.knots[0].q[3] == 0); /* w first inside */
    trajectory_free(&tr);
}

/* Each interpolation's own checks, with the file named. */
TEST(prepare_refuses_what_the_interpolation_cannot_use)
{
    trajectory tr;
    rr_error e;
    CHECK(parse(L0 "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n", &tr, &e) == 0);
    tr.interp = TRAJECTORY_CUBIC, tr.opengl_axes = 0;
    CHECK(trajectory_prepare(&tr, "p.tum", &e) != 0 && strstr(e.msg, "p.tum: 3 poses; cubic interpolation needs "
                                                                    "at least 4"));
    trajectory_free(&tr);
    CHECK(parse(L0 "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n4 0 0 0 0 0 0 1\n", &tr, &e) == 0);
    tr.interp = TRAJECTORY_CUBIC;
    CHECK(trajectory_prepare(&tr, "p.tum", &e) != 0 && strstr(e.msg, "evenly spaced"));
    tr.interp = TRAJECTORY_LINEAR;
    CHECK(trajectory_prepare(&tr, "p.tum", &e) == 0);
    trajectory_free(&tr);
    /* half a turn between neighbours: Log is ambiguous */
    CHECK(parse(L0 "1 0 0 0 0 0 1 0\n", &tr, &e) == 0);
    tr.interp = TRAJECTORY_LINEAR;
    CHECK(trajectory_prepare(&tr, "p.tum", &e) != 0 && strstr(e.msg, "poses 1 and the next turn by 180.00"));
    trajectory_free(&tr);
}

/* Editors on Windows start a text file with the UTF-8 byte order mark: it is
 * no part of the first line; anywhere else it is named, byte by byte (it
 * prints as nothing). */
TEST(tum_reader_skips_a_leading_byte_order_mark_and_names_one_elsewhere)
{
    trajectory tr;
    rr_error e;
    CHECK(parse("\xEF\xBB\xBF" L0 "1 0 0 0 0 0 0 1\n", &tr, &e) == 0);
    CHECK(tr.count == 2 && tr.knots[0].t == 0 && tr.knots[1].t == 1);
    trajectory_free(&tr);
    CHECK(parse("\xEF\xBB\xBF# t tx ty tz qx qy qz qw\n" L0, &tr, &e) == 0 && tr.count == 1); /* then a comment */
    trajectory_free(&tr);
    CHECK(fails_with(L0 "\xEF\xBB\xBF" "1 0 0 0 0 0 0 1\n", "p.tum:2: field 't' is not a finite number "
                                                             "('\\xef\\xbb\\xbf1')"));
    CHECK(fails_with(L0 "1 0 0 0 0 0 0 1 \x01x\n", "p.tum:2: more than the 8 fields t tx ty tz qx qy qz qw "
                                                   "('\\x01x')"));
}

/* n poses moving along x at times t0 + k spacing (written with fmt), one
 * comment line first: pose k is on line k + 2. The spacing after pose
 * `short_at` is `shortened` times the others. */
static char *even_poses(const char *fmt, double t0, double spacing, int n, int short_at, double shortened)
{
    static char text[4096];
    size_t len = (size_t)snprintf(text, sizeof text, "# t tx ty tz qx qy qz qw\n");
    double t = t0;
    for (int k = 0; k < n; k++) {
        char time[64];
        snprintf(time, sizeof time, fmt, t);
        len += (size_t)snprintf(text + len, sizeof text - len, "%s %.17g 0 0 0 0 0 1\n", time, 0.1 * k);
        t += k == short_at ? spacing * shortened : spacing;
    }
    return text;
}

static int cubic_prepare(const char *text, rr_error *e)
{
    trajectory tr;
    if (parse(text, &tr, e))
        return -1;
    tr.interp = TRAJECTORY_CUBIC;
    int rc = trajectory_prepare(&tr, "p.tum", e);
    trajectory_free(&tr);
    return rc;
}

/* A uniform B-spline needs evenly spaced times, to a slack of the spacing
 * (not of |t|): at TUM RGB-D's Unix times (1.3e9, 1.7e9) a 30 Hz file is
 * even to the rounding of its doubles (2^-51 |t|, 6e-7 s) or, written to the
 * microsecond as TUM writes them, 1e-6 s (3e-5 of the spacing); one segment
 * 10x short is 0.03 s off and refused, naming the file and the line, as it
 * is at t = 0. */
TEST(cubic_spacing_is_checked_against_the_spacing_at_unix_times)
{
    rr_error e;
    for (int w = 0; w < 2; w++)
        for (double t0 = 1.3e9; t0 < 2e9; t0 += 0.4e9) {
            const char *fmt = w ? "%.6f" : "%.17g";
            int rc = cubic_prepare(even_poses(fmt, t0, 1.0 / 30, 40, -1, 1), &e);
            if (rc)
                printf("    %s at %g: %s\n", fmt, t0, e.msg);
            CHECK(rc == 0);
        }
    const char *needle = "p.tum:6: a cubic B-spline needs evenly spaced times: this pose is ";
    for (double t0 = 0; t0 < 2e9; t0 += 1.7e9) {
        rr_error f = {{0}};
        CHECK(cubic_prepare(even_poses("%.17g", t0, 1.0 / 30, 8, 3, 0.1), &f) != 0 && strstr(f.msg, needle));
        CHECK(strstr(f.msg, "after the one before (line 5)"));
        printf("    at %g: %s\n", t0, f.msg);
    }
}

/* What the slack lets through, the bounds hold: poses evenly along x, one
 * spacing 5e-5 short (within 1e-4 of the first's): the camera moves at
 * 0.1 / spacing there, faster than the first spacing gives, and the speed
 * bound covers it. */
TEST(cubic_bounds_hold_the_shortest_spacing)
{
    trajectory tr;
    rr_error e;
    CHECK(parse(even_poses("%.17g", 0, 1, 8, 3, 1 - 5e-5), &tr, &e) == 0);
    tr.interp = TRAJECTORY_CUBIC;
    CHECK(trajectory_prepare(&tr, "p.tum", &e) == 0);
    double fastest = 0.1 / (tr.knots[4].t - tr.knots[3].t);
    printf("    speed bound %.17g, the shortest segment's speed %.17g\n", tr.speed, fastest);
    CHECK(tr.speed >= fastest);
    trajectory_free(&tr);
}

/* Whether text, read with interpolation k, is refused with a message
 * holding needle. */
static int refused_as(const char *text, int k, const char *needle)
{
    trajectory tr;
    rr_error e = {{0}};
    if (parse(text, &tr, &e))
        return 0;
    tr.interp = (trajectory_interp)k;
    int rc = trajectory_prepare(&tr, "p.tum", &e);
    printf("    %s: %s\n", trajectory_interp_name(tr.interp), rc ? e.msg : "accepted");
    trajectory_free(&tr);
    return rc != 0 && strstr(e.msg, needle) != NULL;
}

/* Poses too close in time for their motion overflow the bounds: refused
 * alike by every interpolation, naming the pose's line (a Bezier's: its
 * last, as it divides by its whole span). */
TEST(poses_too_close_in_time_are_refused_by_line)
{
    const char *segments = "# t tx ty tz qx qy qz qw\n" L0 "1e-310 1 0 0 0 0 0 1\n1 2 0 0 0 0 0 1\n";
    const char *cubic = "# t tx ty tz qx qy qz qw\n" L0 "1e-310 1 0 0 0 0 0 1\n2e-310 2 0 0 0 0 0 1\n"
                        "3e-310 3 0 0 0 0 0 1\n";
    const char *bezier = "# t tx ty tz qx qy qz qw\n" L0 "1e-310 1 0 0 0 0 0 1\n";
    for (int k = TRAJECTORY_LINEAR; k <= TRAJECTORY_BEZIER_SE3; k++)
        CHECK(refused_as(k == TRAJECTORY_CUBIC ? cubic : k >= TRAJECTORY_BEZIER ? bezier : segments, k,
                         "p.tum:3: poses too close in time for their motion: this pose is 1e-310 after line 2's"));
}

/* The segment named is the one whose rate overflows, not the shortest:
 * line 4 follows line 3 1e-310 later without moving; the overflow is line 3,
 * 1e-300 after line 2 and 1e15 away. */
TEST(poses_too_close_name_the_segment_that_overflows)
{
    const char *text = "# t tx ty tz qx qy qz qw\n" L0 "1e-300 1e15 0 0 0 0 0 1\n"
                       "1.0000000001e-300 1e15 0 0 0 0 0 1\n1 1e15 0 0 0 0 0 1\n";
    for (int k = TRAJECTORY_LINEAR; k < TRAJECTORY_CUBIC; k++)
        CHECK(refused_as(text, k, "p.tum:3: poses too close in time for their motion: this pose is 1e-300 after "
                                  "line 2's"));
}

TEST(a_written_trajectory_reads_back_bit_for_bit)
{
    const char *text = "0.5 0.1 -2 3.25 0.1 0.2 0.3 0.9273618495495703\n"
                       "1.5 1e-300 7 -8 -0.5 0.5 0.5 0.5\n"
                       "2.5 3 0.3333333333333333 1 0.0 0.0 0.0 1\n";
    for (int gl = 0; gl < 2; gl++) {
        trajectory a, b;
        rr_error e;
        CHECK(parse(text, &a, &e) == 0);
        char buf[4096];
        FILE *f = fmemopen(buf, sizeof buf, "w");
        for (int k = 0; k < a.count; k++) {
            double q[4];
            /* what export does: the OpenCV-axes pose, written in the file's axes */
            a.opengl_axes = gl;
            a.interp = TRAJECTORY_LINEAR;
            vec3 p;
            trajectory_pose(&a, a.knots[k].t, &p, q);
            tum_write_line(f, a.knots[k].t, p, q, gl);
        }
        fclose(f);
        CHECK(parse(buf, &b, &e) == 0);
        CHECK(b.count == a.count);
        for (int k = 0; k < a.count && k < b.count; k++) {
            int same = !memcmp(&a.knots[k], &b.knots[k], sizeof a.knots[k]);
            /* q and -q are one rotation: the writer may choose either sign */
            int negated = a.knots[k].t == b.knots[k].t && !memcmp(&a.knots[k].p, &b.knots[k].p, sizeof(vec3));
            for (int i = 0; i < 4; i++)
                negated = negated && a.knots[k].q[i] == -b.knots[k].q[i];
            CHECK(same || negated);
        }
        trajectory_free(&a), trajectory_free(&b);
    }
}

/* The bounds: between densely sampled times the path moves and turns no
 * faster than trajectory_prepare says, for every interpolation. */
TEST(motion_bounds_hold_the_interpolated_path)
{
    const char *text = "0 0 0 0 0 0 0 1\n1 0.3 0.1 0 0.1 0.2 0 0.9746794344808963\n"
                       "2 0.5 -0.2 0.4 -0.2 0.3 0.1 0.9273618495495703\n3 1 0 0.2 0.3 0.1 0.4 0.8602325267042626\n"
                       "4 1.2 0.5 0 0 0.5 0 0.8660254037844386\n";
    for (int k = TRAJECTORY_LINEAR; k <= TRAJECTORY_GSPLAT; k++) {
        trajectory tr;
        rr_error e;
        CHECK(parse(text, &tr, &e) == 0);
        tr.interp = (trajectory_interp)k, tr.opengl_axes = 1;
        CHECK(trajectory_prepare(&tr, "p.tum", &e) == 0);
        double t0, t1, speed = 0, turn = 0, q0[4];
        trajectory_domain(&tr, &t0, &t1);
        vec3 p0;
        trajectory_pose(&tr, t0, &p0, q0);
        const int steps = 20000;
        for (int i = 1; i <= steps; i++) {
            double t = t0 + (t1 - t0) * i / steps, dt = (t1 - t0) / steps, q[4], c[4] = {q0[0], -q0[1], -q0[2], -q0[3]};
            vec3 p;
            trajectory_pose(&tr, t, &p, q);
            speed = fmax(speed, v3_len(v3_sub(p, p0)) / dt);
            double r[4];
            quat_mul(c, q, r);
            turn = fmax(turn, 2.0 * atan2(sqrt(r[1] * r[1] + r[2] * r[2] + r[3] * r[3]), fabs(r[0])) / dt);
            p0 = p;
            memcpy(q0, q, sizeof q0);
        }
        printf("    %s: speed %.4f <= %.4f, turn %.4f <= %.4f\n", trajectory_interp_name(tr.interp), speed, tr.speed,
               turn, tr.turn_rate);
        CHECK(speed <= tr.speed * (1 + 1e-6));
        CHECK(turn <= tr.turn_rate * (1 + 1e-6));
        trajectory_free(&tr);
    }
}

/* gsplat's rolling-shutter pose (trajectory.h): a camera at (10, 0, 0)
 * turning 90 degrees about z in place. Its world-to-camera translations
 * -R^T p are (-10, 0, 0) and (0, 10, 0), at u = 1/2 (-5, 5, 0), and the
 * rotation there Rz(45): the centre -Rz(45) (-5, 5, 0) = (5 sqrt 2, 0, 0),
 * 10 / sqrt 2 from the origin, where linear keeps it at (10, 0, 0). A
 * file cannot name it. */
TEST(gsplat_interpolation_lerps_the_world_to_camera_translation)
{
    trajectory_knot k[2] = {{0, {10, 0, 0}, {1, 0, 0, 0}}, {1, {10, 0, 0}, {sqrt(0.5), 0, 0, sqrt(0.5)}}};
    trajectory tr = {TRAJECTORY_GSPLAT, 0, 2, k, NULL, 0, 0, NULL};
    rr_error e;
    CHECK(trajectory_prepare(&tr, "two poses", &e) == 0);
    vec3 p;
    double q[4];
    trajectory_pose(&tr, 0.5, &p, q);
    printf("    centre (%.15g, %.15g, %.15g)\n", p.x, p.y, p.z);
    CHECK(fabs(p.x - 5 * sqrt(2.0)) < 1e-12 && fabs(p.y) < 1e-12 && fabs(p.z) < 1e-12);
    CHECK(fabs(q[0] - cos(M_PI / 8)) < 1e-12 && fabs(q[3] - sin(M_PI / 8)) < 1e-12);
    tr.interp = TRAJECTORY_LINEAR;
    trajectory_pose(&tr, 0.5, &p, q);
    CHECK(p.x == 10 && p.y == 0);
    CHECK(trajectory_interp_parse("gsplat") == -1 && !strcmp(trajectory_interp_name(TRAJECTORY_GSPLAT), "gsplat"));
}

/* ---- nerfstudio transforms.json ---------------------------------------- */

#include "formats/transforms.h"

#define CAMERA "\"fl_x\": 50, \"fl_y\": 52, \"cx\": 20.5, \"cy\": 14, \"w\": 40, \"h\": 30"
#define FRAME(t) "{\"file_path\": \"a.png\", " t "\"transform_matrix\": [[1,0,0,1],[0,1,0,2],[0,0,1,3],[0,0,0,1]]}"

static int transforms_fail(const char *text, const char *needle)
{
    trajectory tr;
    transforms_camera cam;
    rr_error e = {{0}};
    int ok = transforms_parse("t.json", text, strlen(text), &tr, &cam, &e) != 0 && strstr(e.msg, needle) != NULL;
    if (!ok)
        printf("    expected an error with '%s', got '%s'\n", needle, e.msg);
    return ok;
}

TEST(transforms_json_mistakes_are_named)
{
    CHECK(transforms_fail("{\"fl_x\": 50, \"frames\": []}", "t.json: 'fl_y' is missing"));
    CHECK(transforms_fail("{" CAMERA ", \"k1\": 0.01, \"frames\": []}", "t.json: distortion k1 = 0.01"));
    CHECK(transforms_fail("{" CAMERA ", \"k2\": 0, \"p1\": 0.0, \"frames\": [" FRAME("") "], \"fl_z\": 3}",
                          "t.json: unknown key 'fl_z'"));
    CHECK(transforms_fail("{" CAMERA ", \"camera_model\": \"OPENCV_FISHEYE\", \"frames\": []}",
                          "camera_model = \"OPENCV_FISHEYE\""));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"time\": 0, ") "," FRAME("") "]}",
                          "1 of 2 frames have a 'time'"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"time\": 1, ") "," FRAME("\"time\": 1, ") "]}",
                          "frames[1]: time 1 does not follow frames[0]'s 1"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [{\"transform_matrix\": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}",
                          "frames[0]: 'transform_matrix' rotation is not one"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]], "
                          "\"fl_x\": 51}]}", "frames[0].fl_x = 51 differs from the file's 50"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [{\"file_path\": \"a\", \"mask\": 1, "
                          "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}]}", "frames[0]: unknown key 'mask'"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,\"x\"]]}]}",
                          "frames[0]: 'transform_matrix' row 2 is not 4 numbers"));
    CHECK(transforms_fail("[1]", "not a transforms.json"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [", "t.json:1: not a complete JSON document"));
}

static int transforms_ok(const char *text, transforms_camera *cam)
{
    trajectory tr;
    rr_error e = {{0}};
    int rc = transforms_parse("t.json", text, strlen(text), &tr, cam, &e);
    if (rc)
        printf("    expected no error, got '%s'\n", e.msg);
    else
        trajectory_free(&tr);
    return rc == 0;
}

/* A distortion or camera model given in a frame, or as a string ("0.3" is a
 * distortion to nerfstudio, which float()s it), was read as absent and the
 * camera rendered as a pinhole: refused by entry and value wherever and
 * however given, unless it says "none" (the number 0, PINHOLE, OPENCV). */
TEST(transforms_json_refuses_distortion_in_frames_and_as_strings)
{
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("") "," FRAME("\"k1\": 0.3, ") "]}",
                          "t.json: distortion frames[1].k1 = 0.3: refrender renders a pinhole camera"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"p2\": -1e-3, ") "]}", "frames[0].p2 = -1e-3"));
    CHECK(transforms_fail("{" CAMERA ", \"k1\": \"0.3\", \"frames\": []}", "t.json: distortion k1 = \"0.3\""));
    CHECK(transforms_fail("{" CAMERA ", \"k2\": \"0\", \"frames\": []}", "t.json: distortion k2 = \"0\""));
    CHECK(transforms_fail("{" CAMERA ", \"k3\": null, \"frames\": []}", "t.json: distortion k3 = null"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"k4\": [0.1], ") "]}", "frames[0].k4 = [0.1]"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("") "," FRAME("\"camera_model\": \"OPENCV_FISHEYE\", ")
                          "]}", "t.json: frames[1].camera_model = \"OPENCV_FISHEYE\": only \"PINHOLE\""));
    CHECK(transforms_fail("{" CAMERA ", \"camera_model\": 1, \"frames\": []}", "t.json: camera_model = 1: only"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"camera_model\": \"pinhole\", ") "]}",
                          "frames[0].camera_model = \"pinhole\""));
    /* intrinsics in a frame, as strings: read as absent before */
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("") "," FRAME("\"fl_x\": \"500\", ") "]}",
                          "t.json: frames[1].fl_x = \"500\" is not a number"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"w\": true, ") "]}",
                          "frames[0].w = true is not a number"));
    CHECK(transforms_fail("{\"fl_x\": \"50\", \"fl_y\": 52, \"cx\": 20.5, \"cy\": 14, \"w\": 40, \"h\": 30, "
                          "\"frames\": []}",
                          "t.json: fl_x = \"50\" is not a number"));
    /* exposure_time and rolling_shutter_time are not applied (a warning says so) but must be
     * numbers: a string was dropped without the warning */
    CHECK(transforms_fail("{" CAMERA ", \"rolling_shutter_time\": \"abc\", \"frames\": []}",
                          "t.json: rolling_shutter_time = \"abc\" is not a number"));
    CHECK(transforms_fail("{" CAMERA ", \"exposure_time\": \"0.01\", \"frames\": []}",
                          "t.json: exposure_time = \"0.01\" is not a number"));
    /* "none", at the top level or in every frame, and the same camera per frame: the pinhole */
    transforms_camera cam;
    CHECK(transforms_ok("{" CAMERA ", \"camera_model\": \"OPENCV\", \"k1\": 0, \"p2\": -0.0, \"frames\": ["
                        FRAME("\"camera_model\": \"PINHOLE\", \"k2\": 0.0, \"k4\": 0, \"fl_x\": 50, \"w\": 40, ") "]}",
                        &cam));
    CHECK(cam.fx == 50 && cam.fy == 52 && cam.cx == 20.5 && cam.cy == 14 && cam.width == 40 && cam.height == 30);
}

/* Intrinsics follow the range rule of cameras.json's (camera_focal_usable,
 * camera_principal_usable): fl_x = 1e-14 rendered all background; fl_x or cx
 * = 1e300 wrote infinity into the EXR's float32 worldToNDC. */
TEST(transforms_json_intrinsics_out_of_range_are_named)
{
#define SIZES "\"w\": 40, \"h\": 30, \"frames\": []}"
    CHECK(transforms_fail("{\"fl_x\": 1e300, \"fl_y\": 52, \"cx\": 20, \"cy\": 15, " SIZES,
                          "t.json: fl_x = 1e+300 gives no usable field of view for w = 40"));
    CHECK(transforms_fail("{\"fl_x\": 1e-14, \"fl_y\": 52, \"cx\": 20, \"cy\": 15, " SIZES,
                          "t.json: fl_x = 1e-14 gives no usable field of view"));
    CHECK(transforms_fail("{\"fl_x\": 50, \"fl_y\": 1e-300, \"cx\": 20, \"cy\": 15, " SIZES,
                          "t.json: fl_y = 1e-300 gives no usable field of view for h = 30"));
    CHECK(transforms_fail("{\"fl_x\": 50, \"fl_y\": 52, \"cx\": 1e300, \"cy\": 15, " SIZES,
                          "t.json: cx = 1e+300 is too far off the image for fl_x = 50, w = 40"));
    CHECK(transforms_fail("{\"fl_x\": 50, \"fl_y\": 52, \"cx\": 20, \"cy\": -1e300, " SIZES, "t.json: cy = -1e+300"));
    /* an edge at atan(2e11) from the axis: 90 degrees within 3e-10 degrees, its tangent lost */
    CHECK(transforms_fail("{\"fl_x\": 50, \"fl_y\": 52, \"cx\": 1e13, \"cy\": 15, " SIZES, "t.json: cx = 1e+13"));
    /* the EXR header alone: fl_x / w = 2.5e38 is past float's 3.4e38 / 2, though the view's tangent keeps */
    CHECK(transforms_fail("{\"fl_x\": 1e40, \"fl_y\": 52, \"cx\": 20, \"cy\": 15, " SIZES, "t.json: fl_x = 1e+40"));
    /* a principal point off the image (a shifted lens) whose edges lie inside 90 degrees: kept */
    transforms_camera cam;
    CHECK(transforms_ok("{\"fl_x\": 50, \"fl_y\": 52, \"cx\": -100, \"cy\": 130, " SIZES, &cam));
    CHECK(cam.cx == -100 && cam.cy == 130);
    /* just inside the header's bound (fl_x / w = 0.49 FLT_MAX, cx / w = -0.49 FLT_MAX at its tangent 1): the
     * matrices the EXR records are finite in float32, as the camera the scene makes of it projects them */
    char text[512];
    snprintf(text, sizeof text, "{\"fl_x\": %.17g, \"fl_y\": 52, \"cx\": %.17g, \"cy\": 15, " SIZES,
             0.49 * FLT_MAX * 40, -0.49 * FLT_MAX * 40);
    CHECK(transforms_ok(text, &cam));
    camera c = {.position = v3(0, 0, 0), .lookat = v3(0, 0, 1), .up = v3(0, -1, 0), .width = 40, .height = 30};
    c.fov_degrees = camera_fov_of_focal(30, cam.fy), c.fov_x_degrees = camera_fov_of_focal(40, cam.fx);
    c.principal_dx = camera_principal_offset(40, cam.cx), c.principal_dy = camera_principal_offset(30, cam.cy);
    rr_error e = {{0}};
    CHECK(camera_prepare(&c, &e) == 0);
    double m[4][4];
    camera_projection(&c, 1, 1, m);
    for (int r = 0; r < 4; r++)
        for (int k = 0; k < 4; k++)
            CHECK(isfinite((float)m[r][k]));
#undef SIZES
}

/* A frame that is not an object was counted as a frame without a 'time'
 * ("2 of 3 frames have a 'time'"): named, with its value. */
TEST(transforms_json_frame_that_is_not_an_object_is_named)
{
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"time\": 0, ") ", 2, " FRAME("\"time\": 1, ") "]}",
                          "t.json: frames[1] = 2: a frame is an object"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [\"a.png\"]}",
                          "t.json: frames[0] = \"a.png\": a frame is an object"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("") ", null]}", "t.json: frames[1] = null"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("") "," FRAME("\"time\": \"1\", ") "]}",
                          "t.json: frames[1].time = \"1\" is not a number"));
}

/* A transforms.json of n frames: quarter turns through the half turns about
 * x, y and z (whose exact zeros test signed zeros), then a random walk (a
 * fixed LCG) of turns under 50 degrees; %.17g prints each double exactly. */
static char *transforms_text(int n)
{
    static const double c = 0.70710678118654752;
    static const double axis_aligned[7][4] = {{1, 0, 0, 0}, {c, c, 0, 0}, {0, 1, 0, 0}, {0, c, c, 0},
                                              {0, 0, 1, 0}, {0, 0, c, c}, {0, 0, 0, 1}};
    size_t cap = 512 + (size_t)n * 512, len = 0;
    char *text = malloc(cap);
    len += (size_t)snprintf(text, cap, "{" CAMERA ", \"exposure_time\": 0.01, \"frames\": [");
    uint64_t s = 12345;
    double q[4] = {1, 0, 0, 0}, r[3][3];
    for (int k = 0; k < n; k++) {
        double d[4] = {2.0, 0, 0, 0};
        for (int i = 1; i < 4; i++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            d[i] = (double)(s >> 11) / 9007199254740992.0 - 0.5;
        }
        if (k < 7)
            memcpy(q, axis_aligned[k], sizeof q);
        else
            quat_mul(q, d, q);
        quat_matrix(q, r);
        len += (size_t)snprintf(text + len, cap - len,
                                "%s{\"time\": %d.5, \"transform_matrix\": [[%.17g, %.17g, %.17g, %.17g], "
                                "[%.17g, %.17g, %.17g, %.17g], [%.17g, %.17g, %.17g, %.17g], [0, 0, 0, 1]]}",
                                k ? "," : "", k, r[0][0], r[0][1], r[0][2], 0.1 * k, r[1][0], r[1][1], r[1][2],
                                -1.0 / (k + 1), r[2][0], r[2][1], r[2][2], 3.0);
        double len_q = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        for (int i = 0; i < 4; i++)
            q[i] /= len_q;
    }
    snprintf(text + len, cap - len, "]}");
    return text;
}

/* Read, write, read back (export writes the trajectory it read, and a
 * method then reads that file): the same trajectory and camera bit for bit,
 * though a rotation matrix to a quaternion and back is not exact in
 * binary64: the reader keeps the quaternion its written matrix reads back as. */
TEST(transforms_json_reads_back_what_it_writes)
{
    enum { N = 500 };
    char *text = transforms_text(N);
    trajectory a, b;
    transforms_camera ca, cb;
    rr_error e;
    CHECK(transforms_parse("t.json", text, strlen(text), &a, &ca, &e) == 0);
    CHECK(a.count == N && ca.exposure_time == 0.01 && ca.cx == 20.5 && ca.width == 40);
    static double t[N], q[N][4];
    static vec3 p[N];
    a.interp = TRAJECTORY_LINEAR;
    CHECK(trajectory_prepare(&a, "t.json", &e) == 0);
    for (int k = 0; k < a.count; k++) { /* what export does: the poses at the knots' times */
        t[k] = a.knots[k].t;
        trajectory_pose(&a, t[k], &p[k], q[k]);
    }
    char *buf;
    size_t size;
    FILE *f = open_memstream(&buf, &size);
    transforms_write(f, &ca, t, p, (const double(*)[4])q, a.count);
    fclose(f);
    CHECK(transforms_parse("t2.json", buf, strlen(buf), &b, &cb, &e) == 0);
    CHECK(cb.fx == ca.fx && cb.fy == ca.fy && cb.cx == ca.cx && cb.cy == ca.cy && cb.width == 40 && cb.height == 30);
    CHECK(b.count == N);
    int differ = 0;
    for (int k = 0; k < a.count && k < b.count; k++)
        differ += !!memcmp(&a.knots[k], &b.knots[k], sizeof a.knots[k]);
    CHECK(differ == 0);
    trajectory_free(&a), trajectory_free(&b);
    free(text), free(buf);
}

/* The camera's side of the round trip: a focal length and principal point
 * kept as a field of view and an offset give back, written and read again,
 * the same field of view and offset (camera.c's representatives). */
TEST(a_camera_from_focal_lengths_reads_back_bit_for_bit)
{
    uint64_t s = 777;
    int differ = 0;
    for (int k = 0; k < 2000; k++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        int w = 16 + (int)(s >> 53) % 4000, h = 16 + (int)(s >> 41) % 3000;
        double f = 5 + (double)(s >> 11) / 9007199254740992.0 * 8000, c = (double)(s % 100000) / 100000.0 * w;
        camera cam = {.position = {0, 0, 0}, .lookat = {0, 0, 1}, .up = {0, -1, 0}, .width = w, .height = h};
        cam.fov_degrees = camera_fov_of_focal(h, f * 1.01), cam.fov_x_degrees = camera_fov_of_focal(w, f);
        cam.principal_dx = camera_principal_offset(w, c), cam.principal_dy = camera_principal_offset(h, 0.5 * c);
        rr_error e;
        camera_view v;
        CHECK(camera_prepare(&cam, &e) == 0);
        camera_view_rest(&cam, &v);
        differ += camera_fov_of_focal(w, v.fx) != cam.fov_x_degrees || camera_fov_of_focal(h, v.fy) != cam.fov_degrees;
        differ += camera_principal_offset(w, v.cx) != cam.principal_dx ||
                  camera_principal_offset(h, v.cy) != cam.principal_dy;
    }
    CHECK(differ == 0);
}
