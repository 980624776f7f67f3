/* Maya .anim reader: the bundled files, units, tangents, and bad input. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "formats/animfile.h"
#include "harness.h"

static rr_warnings last_warnings; /* of the last load */

static keyframes *load(const char *path)
{
    keyframes *k = NULL;
    rr_error e;
    memset(&last_warnings, 0, sizeof last_warnings);
    if (animfile_load(path, NULL, &k, NULL, &last_warnings, &e)) {
        printf("    %s\n", e.msg);
        return NULL;
    }
    return k;
}

static void free_keys(keyframes *k)
{
    animation a;
    animation_init_static(&a);
    a.keys = k;
    animation_free(&a);
}

TEST(rolling_anim_rolls_without_slipping)
{
    keyframes *k = load(RR_SOURCE_DIR "/scenes/animations/rolling.anim");
    CHECK(k != NULL);
    /* its visibility curve holds 1 (visible) throughout: skipped without a warning */
    CHECK(last_warnings.count == 0);
    if (!k)
        return;
    /* film: frame 12 = 0.5 s; 157.08 cm = 1.5708 m; cycleRelative after frame 24 */
    CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0.5), M_PI / 2, 1e-6);
    CHECK_NEAR(curve_eval(&k->ch[CH_TX], 1.5), 3 * M_PI / 2, 1e-6);
    /* rotateZ -360 deg per second, linear beyond: -4 pi at 2 s */
    CHECK_NEAR(curve_eval(&k->ch[CH_RZ], 2.0), -4 * M_PI, 1e-9);
    /* distance = radius (0.5 m) * angle: no slipping */
    CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0.8), -0.5 * curve_eval(&k->ch[CH_RZ], 0.8), 1e-6);
    CHECK(k->ch[CH_TY].count == 0 && k->ch[CH_SX].count == 0); /* listed without curves */
    free_keys(k);
}

TEST(bouncing_anim_has_flat_tops_sharp_floor_and_stepped_squash)
{
    keyframes *k = load(RR_SOURCE_DIR "/scenes/animations/bouncing.anim");
    CHECK(k != NULL);
    if (!k)
        return;
    const curve *y = &k->ch[CH_TY], *sy = &k->ch[CH_SY];
    CHECK_NEAR(curve_eval(y, 0.5), 0.0, 1e-12);
    /* frame 6 (0.25 s): flat out of 1 m, linear into 0 (slope -2 m/s over
     * h = 0.5 s): 1 * h00(1/2) + 0.5 * (-2) * h11(1/2) = 0.5 + 0.125 */
    CHECK_NEAR(curve_eval(y, 0.25), 0.625, 1e-12);
    CHECK_NEAR(curve_eval(y, 1.25), 0.625, 1e-12); /* cycled */
    CHECK_NEAR(curve_eval(sy, 12.5 / 24), 0.7, 0);
    CHECK_NEAR(curve_eval_left(sy, 0.5), 1.0, 0);
    CHECK_NEAR(curve_eval(sy, 13.0 / 24), 1.0, 0);
    CHECK_NEAR(curve_eval(sy, 36.5 / 24), 0.7, 0);
    free_keys(k);
}

TEST(thrown_anim_reads_version_1_0_keys_and_fixed_angles)
{
    keyframes *k = load(RR_SOURCE_DIR "/scenes/animations/thrown.anim");
    CHECK(k != NULL);
    if (!k)
        return;
    /* ntsc: frame 15 = 0.5 s, x from -150 to 150 cm */
    CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0.5), 0.0, 1e-12);
    CHECK_NEAR(curve_eval(&k->ch[CH_TY], 0.5), 1.2, 1e-12);
    /* 86.4237 degrees: tan = 16.000 cm per ntsc frame = 0.16 m / (1/30 s) = 4.8 m/s */
    double launch = 0.01 * 30 * tan(86.4237 * M_PI / 180);
    CHECK_NEAR(launch, 4.8, 1e-3);
    CHECK_NEAR(k->ch[CH_TY].keys[0].out_slope, launch, 1e-12);
    CHECK_NEAR(k->ch[CH_TY].keys[2].in_slope, -launch, 1e-12);
    CHECK_NEAR(curve_eval(&k->ch[CH_RZ], 1.0), 3 * M_PI, 1e-12);
    free_keys(k);
}

/* A fixed tangent's tan(angle) is value per frame of the
 * file's timeUnit. Keys (frame 0, 0 m, fixed 45 degrees out) and (frame 24,
 * 24 m, linear): both end slopes are the secant, 1 m/frame = 24 m/s, so the
 * segment is the straight line x = 24 t (per second it was 1 m/s and the
 * curve passed 2.766 m at 0.25 s). */
TEST(fixed_tangent_angles_are_per_frame)
{
    const char *text = "animVersion 1.1;\ntimeUnit film;\nlinearUnit m;\nangularUnit deg;\n"
                       "anim translate.translateX translateX n 0 0 0;\nanimData {\n input time;\n output linear;\n"
                       " weighted 0;\n keys {\n  0 0 fixed fixed 1 1 45 1 45 1;\n  24 24 linear linear 1 1;\n }\n}\n";
    keyframes *k = NULL;
    rr_error e;
    CHECK(animfile_parse(text, "fixed.anim", NULL, &k, NULL, &e) == 0);
    if (!k)
        return;
    for (int i = 1; i <= 8; i++)
        CHECK_NEAR(curve_eval(&k->ch[CH_TX], i / 8.0), 24.0 * i / 8.0, 1e-9);
    CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0.25), 6.0, 1e-9);
    free_keys(k);
}

/* One curve of attribute attr (a node's "anim" line and keys), after a
 * translateX curve refrender reads; the warnings it leaves. */
static int warnings_for_curve(const char *attr, const char *post, const char *keys)
{
    char text[1024];
    snprintf(text, sizeof text,
             "animVersion 1.1;\ntimeUnit film;\nlinearUnit cm;\nangularUnit deg;\n"
             "anim translate.translateX translateX n 0 0 0;\nanimData {\n input time;\n output linear;\n"
             " weighted 0;\n keys {\n  0 0 linear linear 1 1 0;\n }\n}\n"
             "anim %s %s n 2 0 9;\nanimData {\n input time;\n output unitless;\n weighted 0;\n"
             " preInfinity constant;\n postInfinity %s;\n keys {\n%s }\n}\n", attr, attr, post, keys);
    keyframes *k = NULL;
    rr_error e;
    rr_warnings w;
    memset(&w, 0, sizeof w);
    if (animfile_parse(text, "v.anim", NULL, &k, &w, &e)) {
        printf("    %s\n", e.msg);
        return -1;
    }
    free_keys(k);
    return w.count;
}

/* A visibility curve that holds 1 everywhere changes nothing refrender
 * draws: no warning. One that reaches any other value would hide the object
 * somewhere, which refrender cannot: warned, as every unsupported curve. */
TEST(only_an_always_visible_visibility_curve_is_skipped_silently)
{
    CHECK(warnings_for_curve("visibility", "constant", "  0 1 linear linear 1 1 0;\n") == 0);
    CHECK(warnings_for_curve("visibility", "linear", "  0 1 linear linear 1 1 0;\n  24 1 spline spline 1 1 0;\n"
                                                     "  48 1 step step 1 1 0;\n") == 0);
    /* hidden at frame 24, or sloping away from 1 beyond the key, or never 1 */
    CHECK(warnings_for_curve("visibility", "constant", "  0 1 linear linear 1 1 0;\n  24 0 step step 1 1 0;\n") == 1);
    CHECK(warnings_for_curve("visibility", "linear", "  0 1 fixed fixed 1 1 -45 1 -45 1;\n") == 1);
    CHECK(warnings_for_curve("visibility", "constant", "  0 0 linear linear 1 1 0;\n") == 1);
    /* another unsupported attribute, however constant, is still named */
    CHECK(warnings_for_curve("lodVisibility", "constant", "  0 1 linear linear 1 1 0;\n") == 1);
}

static const char *parse_error(const char *text)
{
    static rr_error e;
    static rr_warnings w;
    keyframes *k = NULL;
    if (animfile_parse(text, "t.anim", NULL, &k, &w, &e) == 0) {
        free_keys(k);
        return "";
    }
    return e.msg;
}

/* Weighted curves: a fixed tangent's weight is its Bezier
 * handle's length in the (frames, file value) plane, along its angle; other
 * tangents reach a third of the interval (animx). Film, cm. */
#define WEIGHTED(keys)                                                                                    \
    "animVersion 1.1;\ntimeUnit film;\nlinearUnit cm;\nangularUnit deg;\n"                               \
    "anim translate.translateX translateX n 0 0 0;\nanimData {\n input time;\n output linear;\n"          \
    " weighted 1;\n keys {\n" keys " }\n}\n"

static keyframes *parse_ok(const char *text)
{
    keyframes *k = NULL;
    rr_error e;
    CHECK(animfile_parse(text, "w.anim", NULL, &k, NULL, &e) == 0);
    return k;
}

/* The file parses and its translateX is `meters` at time t (seconds). */
static void check_tx_at(const char *text, double t, double meters)
{
    keyframes *k = parse_ok(text);
    if (k) {
        CHECK_NEAR(curve_eval(&k->ch[CH_TX], t), meters, 1e-15);
        free_keys(k);
    }
}

/* Out-tangent flat with weight 16 frames (two thirds of the 24-frame
 * interval), the last key flat with its computed 8-frame handle: time
 * controls (0, 16, 16, 24) frames, values (0, 0, 10, 10) cm. At u = 1/2 the
 * time is 2/8 + 2/8 + 1/8 of the interval (frame 15, 0.625 s) and the value
 * 3/8 * 10 + 1/8 * 10 = 5 cm. Unweighted (Hermite in time) it would be
 * 10 (3 s^2 - 2 s^3) = 6.836 cm at s = 5/8. Collinear handles at 45 degrees
 * (1 cm per frame) whatever their weights give the straight line 24 t cm. */
TEST(weighted_anim_curves_are_bezier_in_frames_and_values)
{
    keyframes *k = parse_ok(WEIGHTED("  0 0 flat fixed 1 0 0 0 16;\n  24 10 flat flat 1 1 0;\n"));
    if (k) {
        CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0.625), 0.05, 1e-15);
        CHECK(k->ch[CH_TX].weighted);
        free_keys(k);
    }
    k = parse_ok(WEIGHTED("  0 0 fixed fixed 1 0 0 45 5 45 3;\n  24 24 fixed fixed 1 0 0 45 20 45 2;\n"));
    if (k) {
        for (int i = 0; i <= 8; i++)
            CHECK_NEAR(curve_eval(&k->ch[CH_TX], i / 8.0), 0.24 * i / 8.0, 1e-15);
        free_keys(k);
    }
    CHECK(strstr(parse_error(WEIGHTED("  0 0 flat fixed 1 0 0 0 -2;\n  24 10 flat flat 1 1 0;\n")),
                 "t.anim:11: key at time 0: out-tangent weight -2 is negative"));
    CHECK(strstr(parse_error(WEIGHTED("  0 0 flat fixed 1 0 0 0 24;\n  24 10 fixed flat 1 1 0 0 24;\n")),
                 "keys 1 and 2: the tangent weights give the segment a vertical tangent"));
}

/* The plane of a fixed tangent's angle and weight: a curve's
 * tangentAngleUnit overrides the header's angularUnit for its angles, and a
 * Maya 2.x file measured them per second in internal units (centimeters),
 * which Autodesk's animImportExport reader converts. The same curves as
 * above, written those ways, give the same values. */
TEST(tangent_angle_units_and_maya_2_files)
{
    /* 45 degrees given in radians: 1 cm per frame, the straight line */
    check_tx_at("animVersion 1.1;\ntimeUnit film;\nlinearUnit cm;\nangularUnit deg;\n"
                "anim translate.translateX translateX n 0 0 0;\nanimData {\n input time;\n tangentAngleUnit rad;\n"
                " keys {\n  0 0 fixed fixed 1 0 0 0.7853981633974483 1 0.7853981633974483 1;\n"
                "  24 24 linear linear 1 1 0;\n }\n}\n",
                0.25, 0.06);
    /* Maya 2.x: 45 degrees is 1 cm per second; keys (0 s, 0) and (1 s, 1 cm) */
    check_tx_at("animVersion 1.1;\nmayaVersion 2.5;\ntimeUnit film;\nlinearUnit cm;\n"
                "anim translate.translateX translateX n 0 0 0;\nanimData {\n input time;\n keys {\n"
                "  0 0 fixed fixed 1 0 0 45 1 45 1;\n  24 1 linear linear 1 1 0;\n }\n}\n",
                0.25, 0.0025);
    /* ... and a weight of 2/3 s is the 16-frame handle of the weighted test */
    check_tx_at("animVersion 1.1;\nmayaVersion 2.5;\ntimeUnit film;\nlinearUnit cm;\n"
                "anim translate.translateX translateX n 0 0 0;\nanimData {\n input time;\n weighted 1;\n keys {\n"
                "  0 0 flat fixed 1 0 0 0 0.6666666666666666;\n  24 10 flat flat 1 1 0;\n }\n}\n",
                0.625, 0.05);
}

/* Maya's obsolete slow and fast tangents are read (animEngine gives them
 * the secant to the neighbouring key), so the segment is straight. */
TEST(slow_and_fast_tangents_are_read)
{
    check_tx_at(WEIGHTED("  0 0 slow slow 1 1 0;\n  24 24 fast fast 1 1 0;\n"), 0.25, 0.06);
}

#define HEAD "animVersion 1.1;\ntimeUnit %s;\nlinearUnit %s;\nangularUnit %s;\n"
#define CURVE(attr, keys) "anim " attr " " attr " n 0 0 0;\nanimData {\n input time;\n keys {\n" keys " }\n}\n"

TEST(units_are_converted)
{
    static const struct {
        const char *time, *lin, *ang;
        double seconds_per_frame, meters, radians;
    } u[] = {{"pal", "m", "rad", 1.0 / 25, 1, 1}, {"game", "mm", "deg", 1.0 / 15, 1e-3, M_PI / 180},
             {"sec", "ft", "deg", 1, 0.3048, M_PI / 180}, {"ntscf", "in", "rad", 1.0 / 60, 0.0254, 1}};
    for (size_t i = 0; i < sizeof u / sizeof u[0]; i++) {
        char text[1024];
        snprintf(text, sizeof text, HEAD CURVE("translateZ", "  3 2 linear linear 1 1 0;\n")
                 CURVE("rotateX", "  3 2 linear linear 1 1 0;\n"), u[i].time, u[i].lin, u[i].ang);
        keyframes *k = NULL;
        rr_error e;
        CHECK(animfile_parse(text, "u.anim", NULL, &k, NULL, &e) == 0);
        if (!k)
            continue;
        CHECK_NEAR(k->ch[CH_TZ].keys[0].time, 3 * u[i].seconds_per_frame, 1e-15);
        CHECK_NEAR(k->ch[CH_TZ].keys[0].value, 2 * u[i].meters, 1e-15);
        CHECK_NEAR(k->ch[CH_RX].keys[0].value, 2 * u[i].radians, 1e-15);
        free_keys(k);
    }
}

TEST(bad_anim_files_give_clear_errors_with_lines)
{
    const char *ok = "animVersion 1.1;\n" CURVE("translateX", "  0 0 linear linear 1 1 0;\n  5 1 linear linear 1 1 0;\n");
    CHECK(strcmp(parse_error(ok), "") == 0);
    /* truncated block */
    CHECK(strstr(parse_error("animVersion 1.1;\nanim translateX translateX n 0 0 0;\nanimData {\n input time;\n keys {\n"
                             "  0 0 linear linear 1 1 0;\n"),
                 "t.anim:7: file ends inside the keys block"));
    /* unknown tangent type */
    CHECK(strstr(parse_error("animVersion 1.1;\n" CURVE("translateX", "  0 0 wobbly linear 1 1 0;\n")),
                 "t.anim:6: unknown or unsupported tangent type 'wobbly'"));
    /* key times that do not increase */
    CHECK(strstr(parse_error("animVersion 1.1;\n" CURVE("translateX", "  5 0 linear linear 1 1 0;\n"
                                                                      "  5 1 linear linear 1 1 0;\n")),
                 "t.anim:7: key time 5 is not after the previous key's 5"));
    /* NaN */
    CHECK(strstr(parse_error("animVersion 1.1;\n" CURVE("translateX", "  0 nan linear linear 1 1 0;\n")),
                 "t.anim:6: 'nan' is not a finite number"));
    /* missing fixed-tangent angles */
    CHECK(strstr(parse_error("animVersion 1.1;\n" CURVE("translateX", "  0 0 fixed linear 1 1 0;\n")),
                 "has 7 fields, expected 9"));
    CHECK(strstr(parse_error("anim translateX translateX n 0 0 0;\n"), "t.anim:1: not a Maya .anim file"));
    CHECK(strstr(parse_error("animVersion 1.1;\ntimeUnit fortnight;\n"), "t.anim:2: unknown timeUnit"));
    CHECK(strstr(parse_error("animVersion 1.1;\n" CURVE("visibility", "  0 1 linear linear 1 1 0;\n")),
                 "no translate, rotate or scale curve"));
    CHECK(strstr(parse_error("animVersion 1.1;\n" CURVE("scaleX", "  0 0 linear linear 1 1 0;\n")),
                 "scale keys must be positive"));
    CHECK(strstr(parse_error("animVersion 1.1;\n" CURVE("tx", "  0 0 linear linear 1 1 0;\n")
                             CURVE("translateX", "  0 0 linear linear 1 1 0;\n")),
                 "a second curve for 'translateX' (first at line 2)"));
    rr_error e;
    keyframes *k;
    CHECK(animfile_load("no/such.anim", NULL, &k, NULL, NULL, &e) == -1 && strstr(e.msg, "no/such.anim: cannot open"));
}

/* Regression: <animation>/dev/zero</animation> used to read forever. */
TEST(anim_refuses_what_is_not_a_regular_file)
{
    keyframes *k = NULL;
    rr_error e;
    CHECK(animfile_load("/dev/zero", NULL, &k, NULL, NULL, &e) == -1 && strstr(e.msg, "/dev/zero: not a regular file"));
    CHECK(animfile_load("/tmp", NULL, &k, NULL, NULL, &e) == -1 && strstr(e.msg, "/tmp: not a regular file"));
}

/* A Maya export holds a hierarchy; each 'anim' line names its
 * node. Two nodes here, in Maya's syntax: 'ball' moves in x (linear keys),
 * 'joint2' in y (step then linear) and x (fixed 45 degrees per frame). */
static const char TWO_NODES[] =
    "animVersion 1.1;\nmayaVersion 2026;\ntimeUnit film;\nlinearUnit m;\nangularUnit deg;\n"
    "startTime 0;\nendTime 24;\n"
    "anim translate.translateX translateX ball 0 1 0;\nanimData {\n  input time;\n  output linear;\n"
    "  weighted 0;\n  preInfinity constant;\n  postInfinity constant;\n  keys {\n"
    "    0 0 linear linear 1 1 0;\n    24 2 linear linear 1 1 0;\n  }\n}\n"
    "anim translate.translateY translateY joint2 0 1 1;\nanimData {\n  input time;\n  output linear;\n"
    "  weighted 0;\n  preInfinity constant;\n  postInfinity constant;\n  keys {\n"
    "    0 1 step step 1 1 0;\n    12 3 linear linear 1 1 0;\n    24 5 linear linear 1 1 0;\n  }\n}\n"
    "anim translate.translateX translateX joint2 0 1 2;\nanimData {\n  input time;\n  output linear;\n"
    "  weighted 0;\n  preInfinity constant;\n  postInfinity constant;\n  keys {\n"
    "    0 0 fixed fixed 1 1 0 45 1 45 1;\n    24 24 linear linear 1 1 0;\n  }\n}\n";

TEST(multi_node_files_select_a_node)
{
    keyframes *k = NULL;
    rr_error e;
    CHECK(animfile_parse(TWO_NODES, "rig.anim", "joint2", &k, NULL, &e) == 0);
    if (k) {
        CHECK_NEAR(curve_eval(&k->ch[CH_TY], 0.25), 1.0, 1e-12); /* frame 6: held by the step */
        CHECK_NEAR(curve_eval(&k->ch[CH_TY], 0.75), 4.0, 1e-12); /* frame 18: linear 3 -> 5 */
        CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0.25), 6.0, 1e-9);  /* fixed 45: 1 m/frame, straight */
        free_keys(k), k = NULL;
    }
    CHECK(animfile_parse(TWO_NODES, "rig.anim", "ball", &k, NULL, &e) == 0);
    if (k) {
        CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0.5), 1.0, 1e-12);
        CHECK(k->ch[CH_TY].count == 0); /* joint2's curves are not ball's */
        free_keys(k), k = NULL;
    }
    CHECK(animfile_parse(TWO_NODES, "rig.anim", NULL, &k, NULL, &e) != 0 &&
          strstr(e.msg, "rig.anim: the file animates 2 nodes ('ball', 'joint2'): choose one"));
    CHECK(animfile_parse(TWO_NODES, "rig.anim", "joint3", &k, NULL, &e) != 0 &&
          strstr(e.msg, "no curves for node 'joint3'; the file animates 'ball', 'joint2'"));
}

/* Maya lists nodes without curves as placeholders, "anim <node> row child
 * attr;" (Autodesk's animImportExport reader): they are not animated nodes,
 * and their numbers are not node names. */
TEST(placeholder_lines_are_not_animated_nodes)
{
    const char *text = "animVersion 1.1;\nanim hips 0 1 0;\nanim spine 1 1 0;\n"
                       "anim translate.translateX translateX hand 2 0 0;\nanimData {\n input time;\n keys {\n"
                       "  0 0 linear linear 1 1 0;\n  24 10 linear linear 1 1 0;\n }\n}\n";
    keyframes *k = parse_ok(text);
    rr_error e;
    if (k) {
        CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0.5), 0.05, 1e-15);
        free_keys(k), k = NULL;
    }
    CHECK(animfile_parse(text, "rig.anim", "hips", &k, NULL, &e) != 0 &&
          strstr(e.msg, "no curves for node 'hips'; the file animates 'hand'"));
}

/* Words are kept whole up to 255 characters
 * and refused beyond (a 69-character number was cut to 63 and read as 1;
 * node names sharing 63 leading characters became one node); any number
 * of nodes (the 257th was once not recorded); a tangent angle of 180
 * degrees is named as such (it was reported as a negative weight). */
TEST(anim_words_are_whole_nodes_unlimited_and_backward_tangents_named)
{
    char text[200000];
    char number[80] = "1.", long_name[300];
    for (int i = 0; i < 62; i++)
        strcat(number, "0");
    strcat(number, "e+02"); /* 68 characters: 100 */
    snprintf(text, sizeof text, WEIGHTED("  0 0 linear linear 1 1 0;\n  24 %s linear linear 1 1 0;\n"), number);
    check_tx_at(text, 1.0, 1.0); /* 100 cm at frame 24 */
    memset(long_name, 'n', 299), long_name[299] = 0;
    snprintf(text, sizeof text, "animVersion 1.1;\nanim translate.translateX translateX %s 0 0 0;\n", long_name);
    CHECK(strstr(parse_error(text), "t.anim:2: a word of 299 characters"));
    /* 300 nodes whose names share 70 leading characters; node299 is found */
    size_t len = (size_t)snprintf(text, sizeof text, "animVersion 1.1;\n");
    for (int i = 0; i < 300; i++)
        len += (size_t)snprintf(text + len, sizeof text - len,
                                "anim translate.translateX translateX "
                                "%.70s%d 0 0 0;\nanimData {\n input time;\n keys {\n 0 %d linear linear 1 1 0;\n"
                                " 24 0 linear linear 1 1 0;\n }\n}\n", long_name, i, i);
    char node[96];
    snprintf(node, sizeof node, "%.70s299", long_name);
    keyframes *k = NULL;
    rr_error e;
    CHECK(animfile_parse(text, "rig.anim", node, &k, NULL, &e) == 0);
    if (k)
        CHECK_NEAR(curve_eval(&k->ch[CH_TX], 0), 2.99, 1e-12), free_keys(k);
    /* a missing node lists the names that fit and counts the rest */
    CHECK(animfile_parse(text, "rig.anim", "other", &k, NULL, &e) != 0 && strstr(e.msg, "no curves for node 'other'"));
    int listed = 0, more = 0;
    for (const char *q = strstr(e.msg, "animates '"); q && (q = strchr(q + 1, '\'')); q = strchr(q + 1, '\''))
        listed++; /* each name opens and closes a quote */
    const char *tail = strstr(e.msg, ", and ");
    CHECK(tail && sscanf(tail, ", and %d more", &more) == 1 && listed > 0 && listed + more == 300);
    CHECK(strstr(parse_error(WEIGHTED("  0 0 fixed fixed 1 1 0 180 1 0 1;\n  24 10 linear linear 1 1 0;\n")),
                 "t.anim:11: key at time 0: in-tangent angle 180 points backwards in time"));
}
