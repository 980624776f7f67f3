/* colmap.c and llff.c from memory: poses worked by hand. A COLMAP image
 * turned a quarter about y (q = (cos 45, 0, sin 45, 0), R(q) = [[0 0 1]
 * [0 1 0] [-1 0 0]]) with T = (1, 2, 3) sits at -R^T T = (3, -2, -1) with
 * R^T's columns as its axes; binary and text give it bit for bit alike
 * (CRLF lines, comments, an empty POINTS2D line). An LLFF row whose
 * [down, right, back] columns are (0 1 0), (1 0 0), (0 0 -1) is the
 * identity camera in OpenCV axes. */
#include <stdio.h>
#include <string.h>

#include "formats/colmap.h"
#include "formats/llff.h"
#include "harness.h"

static size_t put(unsigned char *at, const void *v, size_t n)
{
    memcpy(at, v, n); /* the tests run little-endian, as COLMAP's files are */
    return n;
}

/* cameras.bin with one PINHOLE camera 2 (80x60, f 70 72, c 40 30). */
static size_t cameras_bin(unsigned char *b)
{
    uint64_t count = 1, w = 80, h = 60;
    uint32_t id = 2;
    int32_t model = 1;
    double params[4] = {70, 72, 40, 30};
    size_t n = put(b, &count, 8);
    n += put(b + n, &id, 4), n += put(b + n, &model, 4), n += put(b + n, &w, 8), n += put(b + n, &h, 8);
    return n + put(b + n, params, sizeof params);
}

/* images.bin with image 5 "a.png" of camera 2, two 2D points. */
static size_t images_bin(unsigned char *b)
{
    uint64_t count = 1, points = 2;
    uint32_t id = 5, cam = 2;
    double pose[7] = {sqrt(0.5), 0, sqrt(0.5), 0, 1, 2, 3}, point[3] = {1.5, 2.5, 0};
    size_t n = put(b, &count, 8);
    n += put(b + n, &id, 4), n += put(b + n, pose, sizeof pose), n += put(b + n, &cam, 4);
    n += put(b + n, "a.png", 6), n += put(b + n, &points, 8);
    for (int k = 0; k < 2; k++)
        n += put(b + n, point, sizeof point);
    return n;
}

static void check_quarter_turn(const camjson_camera *c)
{
    static const double axes[3][3] = {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}}; /* R^T */
    CHECK_NEAR(c->position.x, 3, 1e-15);
    CHECK_NEAR(c->position.y, -2, 1e-15);
    CHECK_NEAR(c->position.z, -1, 1e-15);
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            CHECK_NEAR(c->c2w[a][b], axes[a][b], 1e-15);
    CHECK(c->width == 80 && c->height == 60 && c->fx == 70 && c->fy == 72 && c->cx == 40 && c->cy == 30);
}

TEST(colmap_binary_and_text_give_the_pose_worked_by_hand)
{
    unsigned char cb[256], ib[256];
    size_t nc = cameras_bin(cb), ni = images_bin(ib);
    colmap_model m = {0};
    rr_error e = {{0}};
    CHECK(!colmap_parse_cameras("cameras.bin", (char *)cb, nc, 0, &m, &e));
    CHECK(!colmap_parse_images("images.bin", (char *)ib, ni, 0, &m, &e));
    camjson_camera bin, txt, by_id;
    CHECK(!colmap_find(&m, "a.png", -1, &bin, &e));
    CHECK(!colmap_find(&m, NULL, 5, &by_id, &e));
    check_quarter_turn(&bin);
    CHECK(!memcmp(&bin, &by_id, sizeof bin));
    colmap_free(&m);
    const char *cams = "# comment\r\n\r\n2 PINHOLE 80 60 70 72 40 30\r\n";
    const char *imgs = "# IMAGE_ID ...\r\n5 0.70710678118654757 0 0.70710678118654757 0 1 2 3 2 a.png\r\n\r\n";
    CHECK(!colmap_parse_cameras("cameras.txt", cams, strlen(cams), 1, &m, &e));
    CHECK(!colmap_parse_images("images.txt", imgs, strlen(imgs), 1, &m, &e));
    CHECK(!colmap_find(&m, "a.png", -1, &txt, &e));
    CHECK(!memcmp(&bin, &txt, sizeof bin)); /* sqrt(0.5) printed to 17 digits reads back */
    CHECK(colmap_find(&m, "b.png", -1, &txt, &e) != 0 && strstr(e.msg, "no image named 'b.png'; it has 5 'a.png'"));
    colmap_free(&m);
}

TEST(colmap_truncation_is_named_at_every_cut)
{
    unsigned char ib[256];
    size_t ni = images_bin(ib);
    for (size_t cut = 0; cut < ni; cut++) { /* every shorter file is refused, none read past its end */
        colmap_model m = {0};
        rr_error e = {{0}};
        CHECK(colmap_parse_images("images.bin", (char *)ib, cut, 0, &m, &e) != 0);
        CHECK(strstr(e.msg, "images.bin") != NULL);
        colmap_free(&m);
    }
}

/* A version 1.0 .npy of one '<f8' row. */
static size_t npy_row(unsigned char *b, const double row[17])
{
    const char *dict = "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 17), }";
    size_t hlen = 118; /* 10 + 118 = 128, a multiple of 64 */
    memcpy(b, "\x93NUMPY\x01\x00", 8);
    b[8] = (unsigned char)hlen, b[9] = 0;
    memset(b + 10, ' ', hlen);
    memcpy(b + 10, dict, strlen(dict));
    b[10 + hlen - 1] = '\n';
    memcpy(b + 10 + hlen, row, 17 * sizeof *row);
    return 10 + hlen + 17 * sizeof *row;
}

TEST(llff_columns_down_right_back_are_the_opencv_identity)
{
    const double row[17] = {0, 1, 0, 0.5, 60, 1, 0, 0, -0.25, 80, 0, 0, -1, 2, 70, 1.5, 9};
    unsigned char b[512];
    size_t n = npy_row(b, row);
    llff_poses p;
    rr_error e = {{0}};
    camjson_camera c;
    CHECK(!llff_parse("poses_bounds.npy", (char *)b, n, &p, &e));
    CHECK(!llff_find(&p, NULL, 0, &c, &e));
    for (int a = 0; a < 3; a++)
        for (int k = 0; k < 3; k++)
            CHECK(c.c2w[a][k] == (a == k));
    CHECK(c.position.x == 0.5 && c.position.y == -0.25 && c.position.z == 2);
    CHECK(c.height == 60 && c.width == 80 && c.fx == 70 && c.fy == 70 && c.cx == 40 && c.cy == 30);
    CHECK(llff_find(&p, NULL, 1, &c, &e) != 0 && strstr(e.msg, "no row 1 (it has 1, from 0)"));
    llff_free(&p);
    for (size_t cut = 0; cut < n; cut++) {
        CHECK(llff_parse("poses_bounds.npy", (char *)b, cut, &p, &e) != 0);
        CHECK(strstr(e.msg, "poses_bounds.npy") != NULL);
    }
}
