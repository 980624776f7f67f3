/* camjson.c: a trained model's cameras.json read by field name, and every
 * mistake named with the file, the camera and the field. */
#include <stdio.h>
#include <string.h>

#include "formats/camjson.h"
#include "harness.h"

#define ROT "[[0, -1, 0], [1, 0, 0], [0, 0, 1]]" /* not symmetric: rows and columns differ */

static const char *one(const char *img, const char *fields)
{
    static char buf[2048];
    snprintf(buf, sizeof buf, "{\"id\": 0, \"img_name\": \"%s\", %s}", img, fields);
    return buf;
}

static int parse(const char *text, const char *img, camjson_camera *c, rr_error *e)
{
    return camjson_parse("cams.json", text, strlen(text), img, c, e);
}

/* The file [entry] with one field replaced (or the whole entry's fields). */
static int fails_with(const char *fields, const char *needle)
{
    char text[4096];
    snprintf(text, sizeof text, "[%s]", one("A", fields));
    camjson_camera c;
    rr_error e = {{0}};
    int ok = parse(text, "A", &c, &e) != 0 && strstr(e.msg, needle) != NULL;
    if (!ok)
        printf("    expected an error with '%s', got '%s'\n", needle, e.msg);
    return ok;
}

#define GOOD_POS "\"position\": [1, 2, 3]"
#define GOOD_SIZE "\"width\": 80, \"height\": 60"
#define GOOD_F "\"fx\": 70.5, \"fy\": 71"

TEST(camjson_reads_the_named_camera_by_field_name)
{
    char text[4096];
    snprintf(text, sizeof text, "[%s, ", one("B", "\"fy\": 9, \"fx\": 8, " GOOD_POS ", \"rotation\": " ROT ", "
                                              GOOD_SIZE));
    strcat(text, one("A", "\"fx\": 70.5, \"rotation\": " ROT ", \"width\": 80, \"height\": 60, \"position\": [1, 2, 3], "
                          "\"fy\": 71"));
    strcat(text, "]");
    camjson_camera c;
    rr_error e;
    CHECK(parse(text, "A", &c, &e) == 0);
    CHECK(c.width == 80 && c.height == 60 && c.fx == 70.5 && c.fy == 71 && !strcmp(c.img_name, "A"));
    CHECK(c.position.x == 1 && c.position.y == 2 && c.position.z == 3);
    CHECK(c.c2w[0][1] == -1 && c.c2w[1][0] == 1); /* row r, column c as written */
}

/* Errors name the line the camera starts on (json-c keeps no positions:
 * camjson.c scans for them, past strings holding brackets and commas). */
TEST(camjson_errors_name_the_line_of_the_camera)
{
    const char *text = "[\n  {\"img_name\": \"B, [x]{\\\"\", \"width\": 80, \"height\": 60, \"position\": [1, 2, 3],\n"
                       "   \"rotation\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], \"fx\": 70, \"fy\": 70},\n"
                       "\n  {\"img_name\": \"A\", \"width\": 80, \"height\": 60, \"position\": [1, 2],\n"
                       "   \"rotation\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], \"fx\": 70, \"fy\": 70}]";
    camjson_camera c;
    rr_error e;
    CHECK(parse(text, "A", &c, &e) != 0);
    CHECK(strstr(e.msg, "cams.json:5: camera 1 ('A'): field 'position'") != NULL);
}

TEST(camjson_names_every_mistake)
{
    const char *rest = ", \"rotation\": " ROT ", " GOOD_SIZE ", " GOOD_F;
    char f[1024];
    snprintf(f, sizeof f, "\"position\": [1, 2]%s", rest);
    CHECK(fails_with(f, "cams.json:1: camera 0 ('A'): field 'position' is missing or not a number"));
    snprintf(f, sizeof f, "\"position\": [1, 2, 1e999]%s", rest);
    CHECK(fails_with(f, "field 'position' is not finite"));
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": [[1, 0, 0], [0, 1, 0], [0, 0, -1]], " GOOD_SIZE ", " GOOD_F);
    CHECK(fails_with(f, "field 'rotation' is not a rotation")); /* a reflection */
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": [[1, 0, 0], [0, 1.01, 0], [0, 0, 1]], " GOOD_SIZE ", " GOOD_F);
    CHECK(fails_with(f, "field 'rotation' is not a rotation"));
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": [[1, 0, 0], [0, 1, 0]], " GOOD_SIZE ", " GOOD_F);
    CHECK(fails_with(f, "field 'rotation' is not a 3x3 array"));
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": " ROT ", \"width\": 0, \"height\": 60, " GOOD_F);
    CHECK(fails_with(f, "field 'width' must be a whole number of pixels"));
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": " ROT ", \"width\": \"80\", \"height\": 60, " GOOD_F);
    CHECK(fails_with(f, "field 'width' is missing or not a number"));
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", \"fx\": 0, \"fy\": 71");
    CHECK(fails_with(f, "field 'fx' must be > 0"));
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", \"fx\": 70");
    CHECK(fails_with(f, "field 'fy' is missing"));
}

TEST(camjson_names_the_file_level_mistakes)
{
    camjson_camera c;
    rr_error e;
    CHECK(parse("[\n{\"img_name\": \"A\",\n \"fx\": }]", "A", &c, &e) != 0 && strstr(e.msg, "cams.json:3: not a complete JSON"));
    CHECK(parse("[{\"img_name\": \"A\"}", "A", &c, &e) != 0 && strstr(e.msg, "it ends early"));
    CHECK(parse("{\"img_name\": \"A\"}", "A", &c, &e) != 0 && strstr(e.msg, "expected an array of cameras"));
    CHECK(parse("[{\"img_name\": \"A\"}, {\"img_name\": \"B\"}]", "C", &c, &e) != 0 &&
          strstr(e.msg, "no camera named 'C' (img_name); it has 'A', 'B' (2 cameras)"));
    CHECK(parse("[{\"img_name\": 3}]", "A", &c, &e) != 0 && strstr(e.msg, "camera 0: field 'img_name'"));
    CHECK(camjson_read("/nonexistent/cameras.json", "A", &c, NULL, &e) != 0 && strstr(e.msg, "/nonexistent/cameras.json"));
}

/* SpacetimeGaussians' cameras.json lists each view once per frame under
 * one name: a name may repeat when every entry is the
 * same camera (read as the first), and entries of one name that differ in
 * any field are refused as ambiguous, naming both and the field. */
TEST(camjson_repeated_names_are_one_camera_or_refused)
{
    char text[4 * 2048 + 16], b[2048];
    camjson_camera c;
    rr_error e = {{0}};
    snprintf(b, sizeof b, "%s", one("B", GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", \"fx\": 10, \"fy\": 10"));
    const char *same = GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", " GOOD_F;
    char a[2048];
    snprintf(a, sizeof a, "%s", one("A", same));
    snprintf(text, sizeof text, "[%s, %s, %s, %s]", a, b, a, a);
    CHECK(parse(text, "A", &c, &e) == 0 && c.fx == 70.5 && c.fy == 71 && c.width == 80 && c.position.z == 3);
    const char *other[] = {"\"position\": [1, 2, 3.5], \"rotation\": " ROT ", " GOOD_SIZE ", " GOOD_F,
                           GOOD_POS ", \"rotation\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], " GOOD_SIZE ", " GOOD_F,
                           GOOD_POS ", \"rotation\": " ROT ", \"width\": 80, \"height\": 61, " GOOD_F,
                           GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", \"fx\": 70.5, \"fy\": 72"};
    const char *field[] = {"differ in position", "differ in rotation", "differ in width x height", "differ in fy"};
    for (int k = 0; k < 4; k++) {
        char d[2048];
        snprintf(d, sizeof d, "%s", one("A", other[k]));
        snprintf(text, sizeof text, "[%s, %s, %s]", a, b, d);
        e.msg[0] = 0;
        CHECK(parse(text, "A", &c, &e) != 0 && strstr(e.msg, "cameras 0 and 2 are both named 'A'") &&
              strstr(e.msg, field[k]) && strstr(e.msg, "ambiguous"));
    }
}

/* Regressions: an img_name with an embedded NUL matched the name before it;
 * a position of 1e16 (where position + view direction rounds back to the
 * position) was blamed on a lookat the file does not have; fx = 1e-14 (a
 * field of view of 180 degrees) on the object's reach. Each is named by
 * entry and field. */
TEST(camjson_names_nul_names_far_positions_and_degenerate_focal_lengths)
{
    const char *rest = ", \"rotation\": " ROT ", " GOOD_SIZE ", " GOOD_F;
    char text[4096], f[1024];
    snprintf(text, sizeof text, "[%s]", one("A\\u0000x", GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", " GOOD_F));
    camjson_camera c;
    rr_error e = {{0}};
    CHECK(parse(text, "A", &c, &e) != 0 && strstr(e.msg, "no camera named 'A'"));
    snprintf(f, sizeof f, "\"position\": [0, 0, 1e16]%s", rest); /* ROT looks along z */
    CHECK(fails_with(f, "camera 0 ('A'): field 'position' (0 0 1e+16) is too far out"));
    snprintf(f, sizeof f, "\"position\": [1e9, -1e9, 1e9]%s", rest); /* far, but the direction survives */
    snprintf(text, sizeof text, "[%s]", one("A", f));
    CHECK(parse(text, "A", &c, &e) == 0);
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", \"fx\": 1e-14, \"fy\": 71");
    CHECK(fails_with(f, "camera 0 ('A'): field 'fx' = 1e-14 gives no usable field of view"));
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", \"fx\": 70, \"fy\": 1e-300");
    CHECK(fails_with(f, "field 'fy' = 1e-300 gives no usable field of view"));
}

/* fx = 1e300 passed the field-of-view rule (a tiny view, its tangent kept)
 * and wrote infinity into the EXR's float32 worldToNDC, whose scale is
 * fx / width: the rule holds that scale within float's range. */
TEST(camjson_refuses_a_focal_length_the_exr_header_cannot_hold)
{
    char f[1024];
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", \"fx\": 1e300, \"fy\": 71");
    CHECK(fails_with(f, "camera 0 ('A'): field 'fx' = 1e+300 gives no usable field of view for width 80"));
    snprintf(f, sizeof f, GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", \"fx\": 70, \"fy\": 1e41");
    CHECK(fails_with(f, "field 'fy' = 1e+41 gives no usable field of view for height 60"));
}

/* A byte order mark before the JSON (RFC 8259 8.1 lets a parser ignore it; Windows
 * editors write it) is skipped, as the TUM reader skips one: the file reads as
 * without it, and a later mistake keeps its line. Elsewhere it is still an error. */
TEST(camjson_skips_a_leading_byte_order_mark)
{
    char text[4096], marked[4100];
    snprintf(text, sizeof text, "[%s]", one("A", GOOD_POS ", \"rotation\": " ROT ", " GOOD_SIZE ", " GOOD_F));
    snprintf(marked, sizeof marked, "\xEF\xBB\xBF%s", text);
    camjson_camera plain, c;
    rr_error e = {{0}};
    CHECK(parse(text, "A", &plain, &e) == 0);
    CHECK(parse(marked, "A", &c, &e) == 0 && c.fx == plain.fx && c.width == plain.width);
    CHECK(parse("\xEF\xBB\xBF[\n{\"img_name\": \"A\",\n \"fx\": }]", "A", &c, &e) != 0 &&
          strstr(e.msg, "cams.json:3: not a complete JSON"));
    CHECK(parse("[\xEF\xBB\xBF{\"img_name\": \"A\"}]", "A", &c, &e) != 0 && strstr(e.msg, "not a complete JSON"));
}
