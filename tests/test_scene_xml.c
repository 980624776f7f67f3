/* Scene XML: a good scene parses to the documented values; every error
 * names the file and the line. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "formats/animfile.h"
#include "harness.h"
#include "core/inputfile.h"
#include "scenexml/scene_xml.h"

static int load_text(const char *xml, scene *s, rr_error *e)
{
    return scene_load_memory(xml, strlen(xml), "mem.xml", ".", s, e);
}

static int fails_with(const char *xml, const char *needle)
{
    scene s;
    rr_error e = {{0}};
    int rc = load_text(xml, &s, &e);
    int ok = rc != 0 && strstr(e.msg, needle) != NULL;
    if (!ok)
        printf("    expected error containing '%s', got '%s'\n", needle, rc ? e.msg : "(success)");
    if (rc == 0)
        scene_free(&s);
    return ok;
}

TEST(scene_parses_documented_elements)
{
    const char *xml =
        "<scene>\n"
        " <camera position='0 0 10' lookat='0 0 0' up='0 1 0' fov='30' width='64' height='32'/>\n"
        " <shutter open='0.5' close='1.5' weight='linear'/>\n"
        " <background color='0.1 0.2 0.3'/>\n"
        " <light type='directional' direction='0 0 -2' color='1 1 1'/>\n"
        " <render epsilon='0.05' kernel_sigma='0.4' time_factor='8'/>\n"
        " <object name='a' position='1 0 0'>\n"
        "  <pointModel><splat center='0 0 0' normal='0 0 1' radius='1' color='1 0 0'/>"
        "<splat center='0 0 0' u='1 0 0' v='0 2 0'/></pointModel>\n"
        "  <material shading='unlit'/>\n"
        "  <animation><linear velocity='1 2 3'/><rotation axis='0 0 2' degrees_per_unit_time='90'/></animation>\n"
        " </object>\n"
        " <object><sphere center='0 0 -1' radius='2'/></object>\n"
        "</scene>\n";
    scene s;
    rr_error e;
    CHECK(load_text(xml, &s, &e) == 0);
    CHECK(s.cam.width == 64 && s.cam.height == 32);
    CHECK(s.shut.kind == WEIGHT_LINEAR);
    CHECK_NEAR(s.shut.center, 1.5, 0); /* default center: shutter close */
    CHECK_NEAR(s.epsilon, 0.05, 0);
    CHECK(s.time_factor == 8);
    CHECK(s.nlights == 1 && fabs(s.lights[0].direction.z + 1) < 1e-12);
    CHECK(s.nobjects == 2);
    CHECK(s.objects[0].model.count == 2);
    CHECK(s.objects[0].mat.shading == SHADING_UNLIT);
    CHECK(s.objects[0].anim.has_rotation && fabs(s.objects[0].anim.axis.z - 1) < 1e-12);
    CHECK_NEAR(s.objects[0].anim.offset.x, 1, 0);
    CHECK(s.objects[1].kind == OBJECT_SPHERE && s.objects[1].sphere_radius == 2);
    scene_free(&s);
}

TEST(scene_generated_model_and_thesis_style_path)
{
    scene s;
    rr_error e;
    CHECK(load_text("<scene><object><pointModel generate='plane' count='100'/></object></scene>", &s, &e) == 0);
    CHECK(s.objects[0].model.count == 100);
    scene_free(&s);
    CHECK(fails_with("<scene><object><pointModel>models\\missing.ply</pointModel></object></scene>",
                     "./models/missing.ply: cannot open"));
}

/* A misspelt attribute or element is named with the nearest one it may
 * mean (common.c's rr_nearest_name); a name near none gets no guess. */
TEST(scene_typos_get_a_did_you_mean)
{
    CHECK(fails_with("<scene>\n<camera positon='0 0 5'/>\n</scene>",
                     "mem.xml:2: <camera>: unknown attribute 'positon' (did you mean 'position'?)"));
    CHECK(fails_with("<scene><render kernelSigma='0.5'/></scene>", "(did you mean 'kernel_sigma'?)"));
    CHECK(fails_with("<scene>\n<objet/>\n</scene>", "mem.xml:2: <objet>: unknown element (expected camera, "
                     "shutter, frames, background, ambient, light, render or object) (did you mean '<object>'?)"));
    CHECK(fails_with("<scene><object><gaussianmodel file='a.ply'/></object></scene>",
                     "(did you mean '<gaussianModel>'?)"));
    CHECK(fails_with("<scene><object><sphere radius='1'/><animation><rotaton axis='0 1 0'/></animation></object>"
                     "</scene>", "(did you mean '<rotation>'?)"));
    CHECK(fails_with("<scene><camera><trajectroy file='a.tum'/></camera></scene>", "(did you mean '<trajectory>'?)"));
    CHECK(fails_with("<scene><object><sphere radius='1'/><animation><keyframes><kye time='0'/></keyframes>"
                     "</animation></object></scene>", "(did you mean '<key>'?)"));
    CHECK(fails_with("<scene><object><pointModel><splats center='0 0 0'/></pointModel></object></scene>",
                     "(did you mean '<splat>'?)"));
    CHECK(!fails_with("<scene>\n<bogus/>\n</scene>", "did you mean"));
    CHECK(!fails_with("<scene><camera velocity='1 0 0'/></scene>", "did you mean"));
}

/* The scene suite's scanned models are made by `make scenes` into
 * scenes/models/: a model missing there says so; one missing elsewhere
 * gets no such hint. */
TEST(a_missing_suite_model_says_make_scenes)
{
    const char *xml = "<scene><object><pointModel>models/refrender-never-made.ply</pointModel></object></scene>";
    scene s;
    rr_error e = {{0}};
    CHECK(scene_load_memory(xml, strlen(xml), "scenes/x.xml", "scenes", &s, &e) != 0);
    CHECK(strstr(e.msg, "scenes/models/refrender-never-made.ply: cannot open") &&
          strstr(e.msg, "(run `make scenes` to convert the scanned models)"));
    const char *gs = "<scene><object><gaussianModel file='models/refrender-never-made.ply'/></object></scene>";
    CHECK(scene_load_memory(gs, strlen(gs), "x.xml", "/tmp/scenes", &s, &e) != 0);
    CHECK(strstr(e.msg, "(run `make scenes` to convert the scanned models)"));
    CHECK(fails_with(xml, "./models/refrender-never-made.ply: cannot open") && !fails_with(xml, "make scenes"));
    CHECK(scene_load_memory(xml, strlen(xml), "x.xml", "/tmp/notscenes", &s, &e) != 0);
    CHECK(!strstr(e.msg, "make scenes"));
}

TEST(scene_errors_name_file_and_line)
{
    CHECK(fails_with("<scene>\n<camera fov='abc'/>\n</scene>", "mem.xml:2: <camera>: attribute 'fov'"));
    CHECK(fails_with("<scene>\n\n<camera fov='190'/></scene>", "mem.xml:3: <camera>: camera fov"));
    CHECK(fails_with("<scene>\n<bogus/>\n</scene>", "mem.xml:2: <bogus>: unknown element"));
    /* a 2,000-character name is shown by its first 64 characters, and the
     * reason still ends the message (the name once pushed it out) */
    static char xml[4600];
    char name[2001];
    memset(name, 'q', 2000), name[2000] = 0;
    snprintf(xml, sizeof xml, "<scene>\n<%s/>\n</scene>", name);
    CHECK(fails_with(xml, "mem.xml:2: <qqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqq...>: unknown element "
                          "(expected camera, "));
    snprintf(xml, sizeof xml, "<scene>\n<camera %s=\"1\"/>\n</scene>", name);
    CHECK(fails_with(xml, "mem.xml:2: <camera>: unknown attribute "
                          "'qqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqqq...'"));
    CHECK(fails_with("<scene>\n<object>\n<sphere radius='1' colour='1 0 0'/></object></scene>",
                     "mem.xml:3: <sphere>: unknown attribute 'colour'"));
    CHECK(fails_with("<scene>\n<object>\n<sphere radius='-1'/></object></scene>", "mem.xml:3: <sphere>"));
    CHECK(fails_with("<scene>\n<shutter open='1' close='0'/>\n</scene>", "mem.xml:2: <shutter>"));
    CHECK(fails_with("<scene>\n<shutter weight='gauss'/>\n</scene>", "unknown weight 'gauss'"));
    CHECK(fails_with("<scene>\n<object>\n</object>\n</scene>", "mem.xml:2: <object>: object has no geometry"));
    CHECK(fails_with("<scene><object><pointModel>\n<splat center='0 0 0' normal='0 0 0' radius='1'/>"
                     "</pointModel></object></scene>", "mem.xml:2: <splat>"));
    CHECK(fails_with("<scene></scene>", "no <object>"));
    CHECK(fails_with("<world/>", "root element must be <scene>"));
    CHECK(fails_with("<scene><object><animation>a.anim</animation><sphere radius='1'/></object></scene>",
                     "a.anim: cannot open: No such file or directory (animation of mem.xml:1)"));
}

TEST(scene_xml_syntax_error_reports_line)
{
    CHECK(fails_with("<scene>\n<camera>\n</scene>\n", "mem.xml:3: XML syntax error"));
}

TEST(scene_file_errors_name_the_file)
{
    scene s;
    rr_error e;
    CHECK(scene_load_file("/nonexistent/scene.xml", &s, &e) != 0);
    CHECK(strstr(e.msg, "/nonexistent/scene.xml") != NULL);
}

#define KEYED(keys) "<scene><object><sphere radius='1'/><animation><keyframes interpolation='spline'>" keys \
                    "</keyframes></animation></object></scene>"

TEST(keyframes_frames_and_camera_motion_parse)
{
    const char *xml =
        "<scene><camera position='0 0 5'><animation><keyframes>"
        "<key time='0' translate='0 0 0'/><key time='1' translate='1 0 0' rotate='0 10 0'/>"
        "</keyframes></animation></camera>"
        "<frames rate='24'/><shutter fraction='0.5'/>"
        "<object position='1 2 3'><sphere radius='1'/><animation><keyframes interpolation='step' post='cycle'>"
        "<key time='0' scale='1 2 1'/><key time='0.5' translate='0 1 0' interpolation='linear'/>"
        "</keyframes></animation></object></scene>";
    scene s;
    rr_error e;
    CHECK(load_text(xml, &s, &e) == 0);
    CHECK_NEAR(s.frame_rate, 24, 0);
    CHECK_NEAR(s.shut.open, 0, 0);
    CHECK_NEAR(s.shut.close, 0.5 / 24, 1e-15);
    CHECK_NEAR(s.shut.center, 0.5 / 24, 1e-15); /* the default weighting center: close */
    shutter f10;
    CHECK(scene_frame_shutter(&s, 10, &f10, &e) == 0);
    CHECK_NEAR(f10.open, 10.0 / 24, 1e-15);
    CHECK_NEAR(f10.close, 10.5 / 24, 1e-15);
    CHECK_NEAR(s.shut.open, 0, 0); /* the scene keeps frame 0's */
    const keyframes *k = s.objects[0].anim.keys;
    CHECK(k && k->ch[CH_SY].count == 1 && k->ch[CH_TY].count == 1 && k->ch[CH_TX].count == 1);
    CHECK(k && k->ch[CH_SY].keys[0].out == TAN_STEP && k->ch[CH_TY].keys[0].out == TAN_LINEAR);
    CHECK(k && k->ch[CH_TY].post == INF_CYCLE);
    CHECK(k && k->pivot.x == 1 && k->pivot.z == 3); /* the object's position */
    CHECK(s.camera_motion.keys && s.camera_motion.keys->pivot.z == 5 && scene_camera_moves(&s));
    CHECK_NEAR(s.camera_motion.keys->ch[CH_RY].keys[0].value, 10 * M_PI / 180, 1e-15);
    vec3 org, dir;
    scene_camera_ray(&s, s.cam.width / 2.0, s.cam.height / 2.0, 1.0, &org, &dir);
    CHECK(fabs(org.x - 1) < 1e-12 && fabs(org.z - 5) < 1e-12); /* moved, turned in place */
    CHECK_NEAR(dir.x, -sin(10 * M_PI / 180), 1e-9);
    scene_free(&s);
}

TEST(keyframe_and_frame_errors_name_the_line)
{
    CHECK(fails_with(KEYED("<key time='0'/>"), "mem.xml:1: <key>: a key needs translate, rotate or scale"));
    CHECK(fails_with(KEYED("<key time='1' translate='0 0 0'/>\n<key time='1' translate='1 0 0'/>"),
                     "mem.xml:2: <key>: key time 1 is not after the previous key's 1"));
    CHECK(fails_with(KEYED("<key time='0' scale='1 0 1'/>"), "scale must be positive"));
    CHECK(fails_with(KEYED("<key time='0' translate='0 0 0' interpolation='bouncy'/>"), "unknown interpolation 'bouncy'"));
    CHECK(fails_with("<scene><object><sphere radius='1'/><animation><linear velocity='1 0 0'/>"
                     "<keyframes><key time='0' translate='0 0 0'/></keyframes></animation></object></scene>",
                     "either keyframes (or a .anim file) or linear/rotation"));
    CHECK(fails_with("<scene><camera><animation><keyframes><key time='0' scale='2 2 2'/></keyframes>"
                     "</animation></camera><object><sphere radius='1'/></object></scene>",
                     "the camera cannot be scaled"));
    CHECK(fails_with("<scene>\n<shutter fraction='0.5'/><object><sphere radius='1'/></object></scene>",
                     "mem.xml:2: a shutter fraction needs <frames"));
    CHECK(fails_with("<scene><shutter fraction='0.5' close='1'/><object><sphere radius='1'/></object></scene>",
                     "either open/close or fraction"));
    CHECK(fails_with("<scene><frames rate='-24'/><object><sphere radius='1'/></object></scene>", "rate"));
}

/* A render state's identity covers every input's content. The
 * inputs hash changes with a model file's bytes while the scene file's own
 * hash does not, and is the hash of the scene file then the model. */
TEST(inputs_hash_covers_the_model_files)
{
    char dir[] = "/tmp/refrender-hash-XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char scene_path[128], ply_path[128];
    snprintf(scene_path, sizeof scene_path, "%s/s.xml", dir);
    snprintf(ply_path, sizeof ply_path, "%s/m.ply", dir);
    const char *xml = "<scene><object><pointModel>m.ply</pointModel></object></scene>";
    const char *ply[2] = {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                          "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                          "property float radius\nend_header\n0 0 0 0 0 1 0.5\n",
                          "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                          "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                          "property float radius\nend_header\n0 0 0 0 0 1 0.6\n"};
    uint64_t scene_hash[2], inputs_hash[2];
    for (int k = 0; k < 2; k++) {
        FILE *f = fopen(scene_path, "w");
        fputs(xml, f), fclose(f);
        f = fopen(ply_path, "w");
        fputs(ply[k], f), fclose(f);
        scene s;
        rr_error e;
        CHECK(scene_load_file(scene_path, &s, &e) == 0);
        scene_hash[k] = s.scene_hash, inputs_hash[k] = s.inputs_hash;
        scene_free(&s);
    }
    CHECK(scene_hash[0] == scene_hash[1] && inputs_hash[0] != inputs_hash[1]);
    uint64_t expect = input_hash(input_hash(INPUT_HASH_INIT, xml, strlen(xml)), ply[0], strlen(ply[0]));
    CHECK(inputs_hash[0] == expect);
    unlink(scene_path), unlink(ply_path), rmdir(dir);
}

/* Regression: entity errors named "(scene)" instead of the file. */
TEST(xml_errors_name_the_scene_file)
{
    scene s;
    rr_error e;
    const char *xml = "<!DOCTYPE scene [<!ENTITY a \"&b;\">]><scene>&a;</scene>";
    CHECK(scene_load_memory(xml, strlen(xml), "ent.xml", ".", &s, &e) != 0 && strstr(e.msg, "ent.xml:1:"));
}

/* Regression: libxml2 reported every line past 65535 as 65535. */
TEST(errors_past_line_65535_name_their_line)
{
    size_t lines = 70000;
    char *xml = malloc(lines + 64);
    strcpy(xml, "<scene>");
    memset(xml + 7, '\n', lines);
    strcpy(xml + 7 + lines, "<nonsense/></scene>");
    scene s;
    rr_error e;
    CHECK(load_text(xml, &s, &e) != 0 && strstr(e.msg, "mem.xml:70001:"));
    free(xml);
}

/* <animation file="..." node="..."/> picks a node of an .anim file. */
TEST(animation_file_attribute_selects_a_node)
{
    char dir[] = "/tmp/refrender-node-XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[128];
    snprintf(path, sizeof path, "%s/rig.anim", dir);
    FILE *f = fopen(path, "w");
    fputs("animVersion 1.1;\ntimeUnit film;\nlinearUnit m;\n"
          "anim translate.translateX translateX a 0 1 0;\nanimData {\n keys {\n  0 0 linear linear 1 1 0;\n"
          "  24 2 linear linear 1 1 0;\n }\n}\n"
          "anim translate.translateX translateX b 0 1 0;\nanimData {\n keys {\n  0 0 linear linear 1 1 0;\n"
          "  24 8 linear linear 1 1 0;\n }\n}\n", f);
    fclose(f);
    scene s;
    rr_error e;
    char xml[512];
    snprintf(xml, sizeof xml, "<scene><object><sphere radius='1'/><animation file='rig.anim' node='b'/></object></scene>");
    CHECK(scene_load_memory(xml, strlen(xml), "mem.xml", dir, &s, &e) == 0);
    if (s.nobjects == 1) {
        xform x = animation_at(&s.objects[0].anim, 0.5);
        CHECK_NEAR(xform_point(&x, v3(0, 0, 0)).x, 4.0, 1e-12);
        scene_free(&s);
    }
    snprintf(xml, sizeof xml, "<scene><object><sphere radius='1'/>\n<animation>rig.anim</animation></object></scene>");
    CHECK(scene_load_memory(xml, strlen(xml), "mem.xml", dir, &s, &e) != 0 &&
          strstr(e.msg, "animates 2 nodes ('a', 'b')") && strstr(e.msg, "mem.xml:2"));
    unlink(path), rmdir(dir);
}

/* A value longer than its buffer is refused,
 * naming file, line and length; it was cut (a cut name could match another
 * value) or, as a <pointModel> path, reported as "point model has no
 * splats". */
TEST(over_long_values_are_refused_with_line_and_length)
{
    static const char *const cases[][2] = {
        {"<light type='%s'/>", "<light>: attribute 'type' is 300 characters long"},
        {"<shutter open='0' close='1' weight='%s'/>", "<shutter>: attribute 'weight' is 300 characters long"},
        {"<object name='%s'><sphere radius='1'/></object>", "<object>: attribute 'name' is 300 characters long"},
        {"<object><sphere radius='1'/><material shading='%s'/></object>", "attribute 'shading' is 300"},
        {"<object><pointModel generate='%s'/></object>", "attribute 'generate' is 300 characters long"},
        {"<object><sphere radius='1'/><animation><keyframes post='%s'><key time='0'/></keyframes></animation>"
         "</object>", "<keyframes>: attribute 'post' is 300 characters long"},
        {"<object><sphere radius='1'/><animation><keyframes interpolation='%s'><key time='0'/></keyframes>"
         "</animation></object>", "attribute 'interpolation' is 300 characters long"},
        {"<object><sphere radius='1'/><animation file='a.anim' node='%s'/></object>",
         "<animation>: attribute 'node' is 300 characters long"}};
    char value[301], body[1024], xml[2048];
    memset(value, 'x', 300), value[300] = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        snprintf(body, sizeof body, cases[i][0], value);
        snprintf(xml, sizeof xml, "<scene>\n%s</scene>", body);
        CHECK(fails_with(xml, cases[i][1]) && fails_with(xml, "mem.xml:2:"));
    }
    /* a model path as the element's text (thesis Figure 4.11) */
    char *path_xml = malloc(6000);
    size_t len = (size_t)snprintf(path_xml, 6000, "<scene><object>\n<pointModel>");
    memset(path_xml + len, 'p', 5000);
    snprintf(path_xml + len + 5000, 6000 - len - 5000, "</pointModel></object></scene>");
    CHECK(fails_with(path_xml, "mem.xml:2: <pointModel>: its text is 5000 characters long")); /* not "no splats" */
    free(path_xml);
}

/* A path that fits its attribute but not once joined to the scene's
 * directory is refused naming the length it reached. */
TEST(resolved_paths_too_long_are_refused_with_their_length)
{
    char *dir = malloc(8200);
    memset(dir, 'd', 8190), dir[0] = '/', dir[8190] = 0;
    const char *xml = "<scene><object>\n<pointModel file='m.ply'/></object></scene>";
    scene s;
    rr_error e = {{0}};
    CHECK(scene_load_memory(xml, strlen(xml), "mem.xml", dir, &s, &e) != 0);
    CHECK(strstr(e.msg, "mem.xml:2: <pointModel>: file path 'm.ply...' resolves to 8196 characters") != NULL);
    free(dir);
}

/* A scene selects any node an .anim file can name (its
 * words run to ANIMFILE_MAX_WORD characters); node names were held in 63. */
TEST(animation_node_names_as_long_as_anim_words_are_selected)
{
    char dir[] = "/tmp/refrender-longnode-XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[128], node[ANIMFILE_MAX_WORD + 1], xml[1024];
    snprintf(path, sizeof path, "%s/rig.anim", dir);
    memset(node, 'n', ANIMFILE_MAX_WORD), node[ANIMFILE_MAX_WORD] = 0;
    FILE *f = fopen(path, "w");
    for (int i = 0; i < 2; i++) /* two nodes that differ in their last character */
        fprintf(f, "%sanim translate.translateX translateX %.*s%c 0 1 0;\nanimData {\n keys {\n"
                   "  0 %d linear linear 1 1 0;\n  24 %d linear linear 1 1 0;\n }\n}\n",
                i ? "" : "animVersion 1.1;\ntimeUnit film;\nlinearUnit m;\n", ANIMFILE_MAX_WORD - 1, node,
                "ab"[i], i + 1, i + 1);
    fclose(f);
    node[ANIMFILE_MAX_WORD - 1] = 'b';
    snprintf(xml, sizeof xml, "<scene><object><sphere radius='1'/><animation file='rig.anim' node='%s'/></object>"
             "</scene>", node);
    scene s;
    rr_error e = {{0}};
    CHECK(scene_load_memory(xml, strlen(xml), "mem.xml", dir, &s, &e) == 0);
    if (!e.msg[0]) {
        xform x = animation_at(&s.objects[0].anim, 0.5);
        CHECK_NEAR(xform_point(&x, v3(0, 0, 0)).x, 2.0, 1e-12);
        scene_free(&s);
    } else
        printf("    %s\n", e.msg);
    unlink(path), rmdir(dir);
}

/* Regression: an <animation> whose text is an external entity was
 * taken for an animation without text and left the object static without a
 * word; a CDATA path was dropped the same way. */
TEST(animation_text_as_entity_or_cdata_is_not_dropped)
{
    CHECK(fails_with("<?xml version='1.0'?><!DOCTYPE scene [<!ENTITY ext SYSTEM 'rig.anim'>]>\n<scene><object>"
                     "<sphere radius='1'/>\n<animation>&ext;</animation></object></scene>",
                     "mem.xml:3: <animation>: its text uses the external XML entity 'ext'"));
    CHECK(fails_with("<?xml version='1.0'?><!DOCTYPE scene [<!ENTITY ext SYSTEM 'x'>]>\n<scene>\n<object>&ext;"
                     "<sphere radius='1'/></object></scene>", "mem.xml:3: <object>: unexpected text"));
    CHECK(fails_with("<scene><object><sphere radius='1'/>\n<animation><![CDATA[missing.anim]]></animation>"
                     "</object></scene>", "missing.anim"));
}

/* A temporary ASCII PLY (path: a mkstemp template) of one 2DGS Gaussian
 * with its mean at `mean` ("x y z"), colour f_dc (0.1, 0.2, 0.3), opacity
 * logit 0, log scales (-2, -2) and the identity rotation. */
static void write_one_2d_gaussian(char *path, const char *mean)
{
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    char text[1024];
    int n = snprintf(text, sizeof text,
                     "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                     "property float z\nproperty float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n"
                     "property float opacity\nproperty float scale_0\nproperty float scale_1\n"
                     "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\n"
                     "end_header\n%s 0.1 0.2 0.3 0 -2 -2 1 0 0 0\n",
                     mean);
    CHECK(n > 0 && n < (int)sizeof text && write(fd, text, (size_t)n) == n);
    close(fd);
}

/* <gaussianModel>: a trained model in an object; every mistake named with
 * the scene's line, the PLY's own errors with the file and property. */
TEST(gaussian_model_elements_and_their_errors)
{
    char ply[] = "/tmp/rr_gm_XXXXXX";
    write_one_2d_gaussian(ply, "0 0 0");
    char xml[1024];
    const char *head = "<scene>\n<object>\n";
    snprintf(xml, sizeof xml, "%s<gaussianModel file=\"%s\" order=\"hit-depth\"/></object></scene>", head, ply);
    scene s;
    rr_error e = {{0}};
    CHECK(load_text(xml, &s, &e) == 0);
    CHECK(s.objects[0].kind == OBJECT_GAUSSIANS && s.objects[0].gaussians.kind == GAUSSIAN_2D &&
          s.objects[0].gaussians.count == 1 && s.objects[0].order == GAUSSIAN_ORDER_HIT_DEPTH);
    scene_free(&s);
    snprintf(xml, sizeof xml, "%s<gaussianModel file=\"%s\" kind=\"4dgs\"/></object></scene>", head, ply);
    CHECK(fails_with(xml, "mem.xml:3: <gaussianModel>: gaussianModel kind must be auto, 2dgs or 3dgs, got '4dgs'"));
    snprintf(xml, sizeof xml, "%s<gaussianModel file=\"%s\" order=\"depth\"/></object></scene>", head, ply);
    CHECK(fails_with(xml, "order must be center-depth or hit-depth"));
    snprintf(xml, sizeof xml, "%s<gaussianModel file=\"%s\" kind=\"3dgs\"/></object></scene>", head, ply);
    CHECK(fails_with(xml, "scale_2")); /* forced 3D on a 2D file: the reader names the property */
    CHECK(fails_with("<scene>\n<object>\n<gaussianModel/></object></scene>", "mem.xml:3: <gaussianModel>: gaussianModel needs a 'file'"));
    CHECK(fails_with("<scene>\n<object>\n<gaussianModel file=\"/nonexistent/m.ply\"/></object></scene>",
                     "/nonexistent/m.ply"));
    snprintf(xml, sizeof xml, "%s<gaussianModel file=\"%s\"/><sphere radius=\"1\"/></object></scene>", head, ply);
    CHECK(fails_with(xml, "exactly one pointModel, gaussianModel or sphere"));
    unlink(ply);
}

/* Each object kind is a row (scene_object_row): a scene with a point
 * model, a sphere and a Gaussian model asks each the same questions. The
 * sphere's bounds are its centre +- radius and its rest sphere itself; the
 * splats' rest sphere holds both splats' discs (centre +- radius along
 * the plane), the Gaussian model's bounds its mean; the counts are what
 * the file gives; only the point model is a point model (the splatting
 * comparands' question) and only the Gaussian model Gaussians. */
TEST(every_object_kind_answers_through_its_row)
{
    char ply[] = "/tmp/refrender-rows-XXXXXX";
    write_one_2d_gaussian(ply, "1 2 3");
    char xml[1024];
    snprintf(xml, sizeof xml, "<scene><object><pointModel><splat center='0 0 0' normal='0 0 1' radius='1'/>"
             "<splat center='4 0 0' normal='0 0 1' radius='0.5'/></pointModel></object>"
             "<object><sphere center='1 2 3' radius='0.5'/></object>"
             "<object><gaussianModel file='%s'/></object></scene>", ply);
    scene s;
    rr_error e = {{0}};
    CHECK(load_text(xml, &s, &e) == 0);
    const scene_object_ops *pts = scene_object_row(&s.objects[0]), *sph = scene_object_row(&s.objects[1]);
    const scene_object_ops *gs = scene_object_row(&s.objects[2]);
    CHECK(pts->count(&s.objects[0]) == 2 && sph->count(&s.objects[1]) == 1 && gs->count(&s.objects[2]) == 1);
    CHECK(pts->point_model && !sph->point_model && !gs->point_model);
    CHECK(!pts->gaussians && !sph->gaussians && gs->gaussians);
    CHECK(!strcmp(sph->name, "an analytic sphere") && !strcmp(gs->name, "a Gaussian-splat model"));
    aabb b = scene_object_bounds(&s.objects[1]);
    CHECK(b.lo.x == 0.5 && b.hi.x == 1.5 && b.lo.y == 1.5 && b.hi.z == 3.5);
    vec3 c;
    double r;
    sph->rest_sphere(&s.objects[1], &c, &r);
    CHECK(c.x == 1 && c.y == 2 && c.z == 3 && r == 0.5);
    pts->rest_sphere(&s.objects[0], &c, &r);
    const double rim[4][2] = {{-1, 0}, {0, 1}, {4.5, 0}, {4, -0.5}};
    for (int k = 0; k < 4; k++)
        CHECK(v3_len(v3_sub(v3(rim[k][0], rim[k][1], 0), c)) <= r);
    b = scene_object_bounds(&s.objects[2]);
    CHECK(b.lo.x < 1 && b.hi.x > 1 && b.lo.y < 2 && b.hi.y > 2 && b.lo.z < 3 && b.hi.z > 3);
    scene_free(&s);
    unlink(ply);
}
