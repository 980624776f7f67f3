/* trajectory.c: the TUM reader names every mistake (file, line, field),
 * a file it wrote reads back bit for bit, and the motion bounds hold the
 * interpolated path (the poses themselves are checked against an
 * independent reference in tests/test_trajectory.py). */
#include <stdio.h>
#include <string.h>

#include "../src/trajectory.h"
#include "harness.h"

static int parse(const char *text, trajectory *tr, rr_error *e)
{
    return trajectory_parse_tum(text, strlen(text), "p.tum", tr, e);
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
    CHECK(trajectory_parse_tum(nul, sizeof nul - 1, "p.tum", &tr, &e) != 0 && strstr(e.msg, "NUL"));
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
            trajectory_write_tum_line(f, a.knots[k].t, p, q, gl);
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
    for (int k = TRAJECTORY_LINEAR; k <= TRAJECTORY_BEZIER_SE3; k++) {
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
            trajectory_quat_mul(c, q, r);
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

/* ---- nerfstudio transforms.json ---------------------------------------- */

#include "../src/transforms.h"

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
    CHECK(transforms_fail("{" CAMERA ", \"k1\": 0.01, \"frames\": []}", "t.json: distortion 'k1' = 0.01"));
    CHECK(transforms_fail("{" CAMERA ", \"k2\": 0, \"p1\": 0.0, \"frames\": [" FRAME("") "], \"fl_z\": 3}",
                          "t.json: unknown key 'fl_z'"));
    CHECK(transforms_fail("{" CAMERA ", \"camera_model\": \"OPENCV_FISHEYE\", \"frames\": []}",
                          "camera_model 'OPENCV_FISHEYE'"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"time\": 0, ") "," FRAME("") "]}",
                          "1 of 2 frames have a 'time'"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [" FRAME("\"time\": 1, ") "," FRAME("\"time\": 1, ") "]}",
                          "frames[1]: time 1 does not follow frames[0]'s 1"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [{\"transform_matrix\": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}",
                          "frames[0]: 'transform_matrix' rotation is not one"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]], "
                          "\"fl_x\": 51}]}", "frames[0]: 'fl_x' differs from the file's"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [{\"file_path\": \"a\", \"mask\": 1, "
                          "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}]}", "frames[0]: unknown key 'mask'"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,\"x\"]]}]}",
                          "frames[0]: 'transform_matrix' row 2 is not 4 numbers"));
    CHECK(transforms_fail("[1]", "not a transforms.json"));
    CHECK(transforms_fail("{" CAMERA ", \"frames\": [", "t.json:1: not a complete JSON document"));
}

/* Read, write, read: the camera exactly, the poses within 1e-15 (a
 * rotation matrix to a quaternion and back is not exact in binary64). */
TEST(transforms_json_reads_back_what_it_writes)
{
    const char *text = "{" CAMERA ", \"exposure_time\": 0.01, \"frames\": ["
                       "{\"time\": 0.5, \"transform_matrix\": [[0.36, 0.48, -0.8, 1], [-0.8, 0.6, 0, 2], "
                       "[0.48, 0.64, 0.6, 3], [0, 0, 0, 1]]},"
                       "{\"time\": 1.5, \"transform_matrix\": [[1, 0, 0, -1], [0, 0, -1, 0.5], [0, 1, 0, 7], "
                       "[0, 0, 0, 1]]}]}";
    trajectory a, b;
    transforms_camera ca, cb;
    rr_error e;
    CHECK(transforms_parse("t.json", text, strlen(text), &a, &ca, &e) == 0);
    CHECK(a.count == 2 && ca.exposure_time == 0.01 && ca.cx == 20.5 && ca.width == 40);
    double t[2], q[2][4];
    vec3 p[2];
    a.interp = TRAJECTORY_LINEAR;
    CHECK(trajectory_prepare(&a, "t.json", &e) == 0);
    for (int k = 0; k < 2; k++) {
        t[k] = a.knots[k].t;
        trajectory_pose(&a, t[k], &p[k], q[k]);
    }
    char buf[8192];
    FILE *f = fmemopen(buf, sizeof buf, "w");
    transforms_write(f, &ca, t, p, (const double(*)[4])q, 2);
    fclose(f);
    CHECK(transforms_parse("t2.json", buf, strlen(buf), &b, &cb, &e) == 0);
    CHECK(cb.fx == ca.fx && cb.fy == ca.fy && cb.cx == ca.cx && cb.cy == ca.cy && cb.width == 40 && cb.height == 30);
    CHECK(b.count == 2);
    for (int k = 0; k < 2 && b.count == 2; k++) {
        CHECK(b.knots[k].t == a.knots[k].t);
        CHECK(!memcmp(&b.knots[k].p, &a.knots[k].p, sizeof(vec3)));
        double d = 0;
        for (int i = 0; i < 4; i++)
            d = fmax(d, fabs(b.knots[k].q[i] - a.knots[k].q[i]));
        CHECK(d < 1e-15);
    }
    trajectory_free(&a), trajectory_free(&b);
}
