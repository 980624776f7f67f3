/* <camera>: a pinhole camera given by its pose and field of view, or a
 * trained model's camera from its cameras.json (camjson.h) at the size it
 * was trained at, or a COLMAP model's or LLFF poses_bounds.npy's camera
 * (camsource.h) at the file's size, with an optional <animation> moving
 * its rest pose rigidly (keyframes, or two poses of the file).
 * scenes/README.md. */
#include "formats/camsource.h"
#include "formats/transforms.h"
#include "formats/tum.h"
#include "scenexml/scene_xml_internal.h"

#include <stdlib.h>
#include <string.h>

/* A camera from a camera source (camsource.h): its pose as the rest pose
 * (OpenCV axes: look along z, up is -y), its field of view from fx and fy
 * (square pixels or not), its principal point, its resolution. */
static int camera_from_pose(camera *cam, vec3 position, const double r[3][3], const camjson_camera *j)
{
    cam->position = position;
    cam->lookat = v3_add(position, v3(r[0][2], r[1][2], r[2][2]));
    cam->up = v3(-r[0][1], -r[1][1], -r[2][1]);
    cam->width = j->width, cam->height = j->height;
    cam->fov_degrees = 360.0 / M_PI * atan(0.5 * j->height / j->fy);
    cam->fov_x_degrees = 360.0 / M_PI * atan(0.5 * j->width / j->fx);
    if (j->cx != 0.5 * j->width) /* a COLMAP camera's own; centred stays exactly 0 */
        cam->principal_dx = camera_principal_offset(j->width, j->cx);
    if (j->cy != 0.5 * j->height)
        cam->principal_dy = camera_principal_offset(j->height, j->cy);
    return 0;
}

/* The size the model was trained at (its cameras.json gives the dataset
 * image's size, which training may have shrunk): 3DGS and 2DGS train at the
 * loaded image's size, by utils/camera_utils.py loadCam (graphdeco-inria
 * gaussian-splatting; the same in hbb1/2d-gaussian-splatting 1920a23):
 * -r 1, 2, 4 or 8 divides it, rounded as Python's round (ties to even);
 * -r -1, the default, shrinks an image wider than 1600 to 1600 wide, any
 * other -r to that width, both truncating orig / (orig / target). The
 * field of view stays (the camera's angles). "auto" is -1; a number is -r. */
static int training_size(xml_ctx *c, xmlNodePtr n, int *width, int *height)
{
    char text[32];
    int got = xml_attr_text(c, n, "trainingResolution", text, sizeof text), r = -1;
    char *end;
    if (got < 0)
        return -1;
    if (got && strcmp(text, "auto")) {
        long v = strtol(text, &end, 10);
        if (*end || end == text || v < 1 || v > 65536)
            return xml_fail(c, n, "trainingResolution must be auto (the training's -r -1), 1, 2, 4 or 8 (-r's "
                                  "divisors) or a width in pixels (-r WIDTH), got '%s'", text);
        r = (int)v;
    }
    double w = *width, h = *height;
    if (r == 1 || r == 2 || r == 4 || r == 8) {
        *width = (int)nearbyint(w / r), *height = (int)nearbyint(h / r);
    } else if (r != -1 || w > 1600) {
        double scale = w / (r == -1 ? 1600.0 : (double)r);
        *width = (int)(w / scale), *height = (int)(h / scale);
    }
    if (*width < 1 || *height < 1)
        return xml_fail(c, n, "trainingResolution '%s' leaves a %dx%d image", got ? text : "auto", *width, *height);
    return 0;
}

/* Which of the source's cameras element n names: image="NAME" (every
 * source), imageId="N" (COLMAP's IMAGE_ID) or index="N" (LLFF's row),
 * exactly one. image must hold 256 bytes. */
static int read_key(xml_ctx *c, xmlNodePtr n, const camsource *src, camsource_key *key, char *image)
{
    static const char *const number_attr[3] = {NULL, "imageId", "index"}; /* by camsource_kind */
    static const char *const source[3] = {"a cameras.json", "this COLMAP model", "this LLFF file"};
    static const char *const named[3] = {"an img_name of the file", "an image's NAME in the model",
                                         "a file name in images/ beside it"};
    const char *want = number_attr[src->kind];
    int got = xml_attr_text(c, n, "image", image, 256), number = 0;
    if (got < 0)
        return -1;
    for (int k = 1; k < 3; k++)
        if (k != (int)src->kind && xmlHasProp(n, (const xmlChar *)number_attr[k]))
            return xml_fail(c, n, "'%s' selects %s; %s takes 'image'%s%s%s", number_attr[k],
                            k == 1 ? "a COLMAP image by its IMAGE_ID" : "a row of an LLFF poses_bounds.npy",
                            source[src->kind], want ? " or '" : "", want ? want : "", want ? "'" : "");
    if (want && xmlHasProp(n, (const xmlChar *)want)) {
        if (got)
            return xml_fail(c, n, "give 'image' or '%s', not both", want);
        if (xml_attr_int(c, n, want, &number, 0, INT32_MAX))
            return -1;
        key->image = NULL, key->number = number;
        return 0;
    }
    if (!got)
        return xml_fail(c, n, "<%s> needs 'image' (%s)%s%s", xml_elname(n), named[src->kind], want ? " or " : "",
                        want ? want : "");
    key->image = image, key->number = -1;
    return 0;
}

static int find_source_camera(xml_ctx *c, xmlNodePtr n, camsource *src, camjson_camera *out)
{
    camsource_key key;
    char image[256];
    rr_error sub;
    if (read_key(c, n, src, &key, image))
        return -1;
    if (camsource_find(src, key, out, c->inputs_hash, &sub))
        return rr_fail(c->err, "%s (camera of %s:%ld)", sub.msg, c->name, xmlGetLineNo(n));
    return 0;
}

/* <animation><pose time="t0" image="A"/><pose time="t1" image="B"/></animation>:
 * from cameras.json pose A at t0 to pose B at t1, the position linear and
 * the rotation slerped (animation_between_poses); the camera's rest pose
 * becomes the one this motion moves. */
static int parse_pose_motion(xml_ctx *c, xmlNodePtr anim, camsource *src, camera *cam, animation *a)
{
    static const char *const ok[] = {"time", "image", "imageId", "index", NULL};
    camjson_camera pose[2];
    double t[2];
    int k = 0;
    for (xmlNodePtr p = anim->children; p; p = p->next) {
        if (!xml_is_element(p))
            continue;
        if (strcmp(xml_elname(p), "pose") || k == 2)
            return xml_fail(c, p, "a camera's pose motion is exactly two <pose> elements (for longer paths, "
                                  "keyframes)");
        if (xml_check_attributes(c, p, ok) || xml_attr_double(c, p, "time", &t[k], 1) ||
            find_source_camera(c, p, src, &pose[k]))
            return -1;
        k++;
    }
    if (k != 2)
        return xml_fail(c, anim, "a camera's pose motion is exactly two <pose> elements");
    vec3 rest_pos;
    double rest_rot[3][3];
    rr_error sub;
    animation_free(a);
    if (animation_between_poses(pose[0].position, pose[0].c2w, pose[1].position, pose[1].c2w, t[0], t[1], a,
                                &rest_pos, rest_rot, &sub))
        return xml_fail(c, anim, "%s", sub.msg);
    return camera_from_pose(cam, rest_pos, rest_rot, &pose[0]);
}

/* The camera of a transforms.json: its size, the field of view of its
 * focal lengths, its principal point; the scene's <camera> gives none. */
static int camera_from_transforms(xml_ctx *c, xmlNodePtr cam_node, const transforms_camera *t, camera *cam)
{
    static const char *const given[] = {"fov", "width", "height", NULL};
    for (const char *const *k = given; *k; k++)
        if (xmlHasProp(cam_node, (const xmlChar *)*k))
            return xml_fail(c, cam_node, "a camera with a transforms.json trajectory takes its intrinsics from the "
                                         "file: drop '%s' (--res changes the size)", *k);
    cam->width = t->width, cam->height = t->height;
    cam->fov_degrees = camera_fov_of_focal(t->height, t->fy);
    cam->fov_x_degrees = camera_fov_of_focal(t->width, t->fx);
    cam->principal_dx = camera_principal_offset(t->width, t->cx);
    cam->principal_dy = camera_principal_offset(t->height, t->cy);
    if (isfinite(t->exposure_time) || isfinite(t->rolling_shutter_time))
        rr_warn(&c->sc->warnings, "%s:%ld: the transforms.json's exposure_time and rolling_shutter_time are not "
                                  "applied: give them in <shutter> (close - open, rolling=\"3dgs-deblur\" "
                                  "readoutTime)", c->name, xmlGetLineNo(cam_node));
    return 0;
}

/* A trajectory file: format="tum" (the default unless the name ends in
 * .json) or "transforms" (nerfstudio, OpenGL axes, with the camera). */
static int load_path(xml_ctx *c, xmlNodePtr n, const char *path, int transforms, trajectory_interp kind,
                     int opengl, trajectory *tr, camera *cam)
{
    rr_error sub;
    transforms_camera tc;
    int rc = transforms ? transforms_load(path, tr, &tc, c->inputs_hash, &sub)
                        : tum_load(path, tr, c->inputs_hash, &sub);
    tr->interp = kind, tr->opengl_axes = transforms || opengl;
    if (rc || trajectory_prepare(tr, path, &sub))
        return rr_fail(c->err, "%s (trajectory of %s:%ld)", sub.msg, c->name, xmlGetLineNo(n));
    return transforms ? camera_from_transforms(c, n->parent, &tc, cam) : 0;
}

static int trajectory_format(xml_ctx *c, xmlNodePtr n, const char *rel, int *transforms)
{
    char format[16];
    size_t len = strlen(rel);
    int got = xml_attr_text(c, n, "format", format, sizeof format);
    if (got < 0)
        return -1;
    if (got && strcmp(format, "tum") && strcmp(format, "transforms"))
        return xml_fail(c, n, "unknown trajectory format '%s' (tum or transforms)", format);
    *transforms = got ? !strcmp(format, "transforms") : len >= 5 && !strcmp(rel + len - 5, ".json");
    return 0;
}

/* <trajectory file="poses.tum" axes="opengl|opencv" interpolation="linear"/>:
 * the camera's pose over time from a TUM file or a transforms.json (trajectory.h,
 * transforms.h), the rest
 * pose the identity (OpenCV axes at the origin) that the path moves. */
static int parse_trajectory(xml_ctx *c, xmlNodePtr n, camera *cam, animation *a)
{
    static const char *const ok[] = {"file", "format", "axes", "interpolation", NULL};
    char rel[4096], path[8192], axes[16] = "opengl", interp[16] = "linear";
    int transforms = 0;
    if (xml_check_attributes(c, n, ok) || xml_check_no_text(c, n))
        return -1;
    if (xml_attr_text(c, n, "file", rel, sizeof rel) <= 0)
        return c->err->msg[0] ? -1 : xml_fail(c, n, "<trajectory> needs 'file' (a TUM file: t tx ty tz qx qy qz qw)");
    if (trajectory_format(c, n, rel, &transforms))
        return -1;
    if (transforms && xmlHasProp(n, (const xmlChar *)"axes"))
        return xml_fail(c, n, "a transforms.json's axes are nerfstudio's (OpenGL): drop 'axes'");
    if ((!transforms && xml_attr_text(c, n, "axes", axes, sizeof axes) <= 0) ||
        (strcmp(axes, "opengl") && strcmp(axes, "opencv")))
        return c->err->msg[0] ? -1 : xml_fail(c, n, "<trajectory> needs axes=\"opengl\" (camera x right, y up, z "
                                                   "backward: BAD-Gaussians' export, Blender) or axes=\"opencv\" (x "
                                                   "right, y down, z forward: COLMAP, 3DGS)");
    if (xml_attr_text(c, n, "interpolation", interp, sizeof interp) < 0)
        return -1;
    int kind = trajectory_interp_parse(interp);
    if (kind < 0)
        return xml_fail(c, n, "unknown interpolation '%s' (linear, se3, cubic, bezier or bezier-se3)", interp);
    if (xml_resolve_path(c, n, rel, path, sizeof path))
        return -1;
    trajectory *tr = calloc(1, sizeof *tr);
    if (!tr)
        return xml_fail(c, n, "out of memory");
    animation_free(a);
    animation_init_static(a);
    a->path = tr;
    if (load_path(c, n, path, transforms, (trajectory_interp)kind, !strcmp(axes, "opengl"), tr, cam))
        return -1;
    if (scene_add_input(c->sc, path))
        return xml_fail(c, n, "out of memory");
    cam->position = v3(0, 0, 0), cam->lookat = v3(0, 0, 1), cam->up = v3(0, -1, 0); /* OpenCV axes */
    return 0;
}

static int has_pose_child(xmlNodePtr anim)
{
    for (xmlNodePtr p = anim->children; p; p = p->next)
        if (xml_is_element(p) && !strcmp(xml_elname(p), "pose"))
            return 1;
    return 0;
}

/* <camera ...> with an optional <animation> moving its rest pose rigidly. */
static int parse_camera_motion(xml_ctx *c, xmlNodePtr n, camera *cam, animation *a, camsource *json)
{
    if (xml_check_no_text(c, n))
        return -1;
    for (xmlNodePtr k = n->children; k; k = k->next) {
        if (!xml_is_element(k))
            continue;
        int is_path = !strcmp(xml_elname(k), "trajectory");
        if (strcmp(xml_elname(k), "animation") && !is_path)
            return xml_unknown_element(c, k, "element inside <camera>",
                                       (const char *const[]){"animation", "trajectory", NULL});
        if (a->keys || !animation_is_static(a))
            return xml_fail(c, k, "the camera has one <animation> or <trajectory>");
        if (is_path) {
            if (json || xmlHasProp(n, (const xmlChar *)"position") || xmlHasProp(n, (const xmlChar *)"lookat") ||
                xmlHasProp(n, (const xmlChar *)"up"))
                return xml_fail(c, k, "a camera with a <trajectory> takes its pose from the file: drop its "
                                      "'position', 'lookat', 'up' and 'cameras'; keep fov, width and height");
            if (parse_trajectory(c, k, cam, a))
                return -1;
            continue;
        }
        if (has_pose_child(k)) {
            if (!json)
                return xml_fail(c, k, "<pose> needs the camera's 'cameras' (a cameras.json, COLMAP model or "
                                      "poses_bounds.npy)");
            if (parse_pose_motion(c, k, json, cam, a))
                return -1;
            continue;
        }
        animation_free(a);
        animation_init_static(a);
        a->offset = cam->position; /* the default keyframe pivot; the camera has no model offset */
        if (xml_parse_animation(c, k, a))
            return -1;
        a->offset = v3(0, 0, 0);
        if (a->keys && (a->keys->ch[CH_SX].count || a->keys->ch[CH_SY].count || a->keys->ch[CH_SZ].count))
            return xml_fail(c, k, "the camera cannot be scaled (its motion must be rigid)");
    }
    return 0;
}

/* <camera cameras="cameras.json" image="NAME" trainingResolution="auto"/>:
 * a trained model's camera, or a COLMAP model's or an LLFF file's
 * (camsource.h); the source, read once, stays in *f for the poses of its
 * motion. */
static int parse_json_camera(xml_ctx *c, xmlNodePtr n, camera *cam, camsource *f)
{
    char rel[4096], path[8192];
    static const char *const exclusive[] = {"position", "lookat", "up", "fov", "width", "height", NULL};
    for (const char *const *k = exclusive; *k; k++)
        if (xmlHasProp(n, (const xmlChar *)*k))
            return xml_fail(c, n, "a camera from 'cameras' takes its pose, field of view and size from the file: "
                                  "drop '%s' (--res changes the size)", *k);
    if (xml_attr_text(c, n, "cameras", rel, sizeof rel) < 0 || xml_resolve_path(c, n, rel, path, sizeof path))
        return -1;
    rr_error sub;
    if (camsource_load(path, f, c->inputs_hash, &sub))
        return rr_fail(c->err, "%s (camera of %s:%ld)", sub.msg, c->name, xmlGetLineNo(n));
    if (f->kind != CAMSOURCE_JSON && xmlHasProp(n, (const xmlChar *)"trainingResolution"))
        return xml_fail(c, n, "trainingResolution is 3DGS's rule for a cameras.json: a %s camera renders at the "
                              "file's size (--res changes it, keeping the field of view)",
                        f->kind == CAMSOURCE_COLMAP ? "COLMAP" : "poses_bounds.npy");
    camjson_camera j;
    if (find_source_camera(c, n, f, &j))
        return -1;
    for (int k = 0; k < 2; k++)
        if (f->files[k] && scene_add_input(c->sc, f->files[k]))
            return xml_fail(c, n, "out of memory");
    return camera_from_pose(cam, j.position, j.c2w, &j);
}

static int has_trajectory_child(xmlNodePtr n)
{
    for (xmlNodePtr k = n->children; k; k = k->next)
        if (xml_is_element(k) && !strcmp(xml_elname(k), "trajectory"))
            return 1;
    return 0;
}

static int parse_plain_camera(xml_ctx *c, xmlNodePtr n, camera *cam)
{
    int path = has_trajectory_child(n); /* the pose comes from the file */
    if (xmlHasProp(n, (const xmlChar *)"trainingResolution"))
        return xml_fail(c, n, "trainingResolution is for a camera from 'cameras' (a cameras.json): give this one "
                              "its width and height");
    static const char *const selectors[] = {"image", "imageId", "index", NULL};
    for (const char *const *k = selectors; *k; k++)
        if (xmlHasProp(n, (const xmlChar *)*k)) /* was ignored: the camera at its default pose instead */
            return xml_fail(c, n, "'%s' selects a camera of 'cameras' (a cameras.json, COLMAP model or "
                                  "poses_bounds.npy), which this camera does not name", *k);
    return (!path && (xml_attr_vec3(c, n, "position", &cam->position, 0) ||
                      xml_attr_vec3(c, n, "lookat", &cam->lookat, 0) || xml_attr_vec3(c, n, "up", &cam->up, 0))) ||
                   xml_attr_double(c, n, "fov", &cam->fov_degrees, 0) ||
                   xml_attr_int(c, n, "width", &cam->width, 1, 65536) ||
                   xml_attr_int(c, n, "height", &cam->height, 1, 65536)
               ? -1 : 0;
}

int xml_parse_camera(xml_ctx *c, xmlNodePtr n, camera *cam, animation *motion)
{
    static const char *const ok[] = {"position", "lookat",  "up",    "fov",   "width", "height", "cameras",
                                     "image",    "imageId", "index", "trainingResolution", NULL};
    int from_json = xmlHasProp(n, (const xmlChar *)"cameras") != NULL;
    if (xml_check_attributes(c, n, ok))
        return -1;
    camsource json = {0};
    int rc = from_json ? parse_json_camera(c, n, cam, &json) : parse_plain_camera(c, n, cam);
    rc = rc || parse_camera_motion(c, n, cam, motion, from_json ? &json : NULL);
    /* after any pose motion, which takes its rest pose's size from the file */
    rc = rc || (from_json && json.kind == CAMSOURCE_JSON && training_size(c, n, &cam->width, &cam->height));
    camsource_free(&json);
    if (rc)
        return -1;
    rr_error sub;
    if (camera_prepare(cam, &sub))
        return xml_fail(c, n, "%s", sub.msg);
    return 0;
}

