#include "formats/transforms.h"

#include <json-c/json.h>
#include <stdlib.h>
#include <string.h>

#include "core/camera.h"
#include "formats/camjson.h"
#include "core/inputfile.h"
#include "core/rotation.h"

#define TRANSFORMS_MAX_BYTES ((size_t)256 << 20)

static const char *const INTRINSICS[] = {"fl_x", "fl_y", "cx", "cy", "w", "h", NULL};
static const char *const DISTORTION[] = {"k1", "k2", "k3", "k4", "p1", "p2", NULL};
/* keys nerfstudio, its data processors and 3dgs-deblur write that say
 * nothing about the pinhole pose refrender renders */
static const char *const TOP_KEYS[] = {"camera_model", "frames", "applied_transform", "ply_file_path", "aabb_scale",
                                       "orientation_override", "exposure_time", "rolling_shutter_time",
                                       "camera_angle_x", "camera_angle_y", NULL};
static const char *const FRAME_KEYS[] = {"file_path", "transform_matrix", "time", "colmap_im_id", "mask_path",
                                         "depth_file_path", "camera_model", NULL};

static int listed(const char *const *list, const char *key)
{
    for (; *list; list++)
        if (!strcmp(*list, key))
            return 1;
    return 0;
}

static int known_keys(json_object *o, const char *const *extra, const char *name, const char *where, rr_error *err)
{
    json_object_object_foreach(o, key, value) {
        (void)value;
        if (!listed(extra, key) && !listed(INTRINSICS, key) && !listed(DISTORTION, key))
            return rr_fail(err, "%s: %sunknown key '%.100s' (a misspelling would be ignored: refused)", name, where,
                           key);
    }
    return 0;
}

/* A value as the file writes it, for a message: compact JSON, its first 60
 * characters and "..." when longer. */
static const char *value_text(json_object *v, char *buf, size_t size)
{
    const char *text = json_object_to_json_string_ext(v, JSON_C_TO_STRING_PLAIN | JSON_C_TO_STRING_NOSLASHESCAPE);
    snprintf(buf, size, "%.60s%s", text ? text : "?", text && strlen(text) > 60 ? "..." : "");
    return buf;
}

static int is_number(json_object *v)
{
    return json_object_is_type(v, json_type_double) || json_object_is_type(v, json_type_int);
}

/* A key that changes the projection says "none" or is refused: a distortion
 * coefficient must be the number 0, a camera model PINHOLE or OPENCV (OPENCV
 * with zero coefficients is the pinhole). nerfstudio reads them at the top
 * level and in each frame, and float()s strings, so "0.3" is a distortion
 * (nerfstudio_dataparser.py at 01595f7, _generate_dataparser_outputs): a
 * frame's or a string's rendered as a pinhole if not refused. where: "" or
 * "frames[i]." */
static int projection_keys(const char *name, json_object *o, const char *where, rr_error *err)
{
    char text[72];
    json_object_object_foreach(o, key, value) {
        if (listed(DISTORTION, key) && !(is_number(value) && json_object_get_double(value) == 0))
            return rr_fail(err, "%s: distortion %s%s = %s: refrender renders a pinhole camera (undistort the images "
                                "and give the coefficients as the number 0)", name, where, key,
                           value_text(value, text, sizeof text));
        const char *model = json_object_is_type(value, json_type_string) ? json_object_get_string(value) : "";
        if (!strcmp(key, "camera_model") && strcmp(model, "PINHOLE") && strcmp(model, "OPENCV"))
            return rr_fail(err, "%s: %scamera_model = %s: only \"PINHOLE\" (or \"OPENCV\" without distortion)", name,
                           where, value_text(value, text, sizeof text));
    }
    return 0;
}

/* o's number `key` into *out: 0; 1 where o has no such key; a value that is
 * not a finite number is refused, naming it (a string would read as absent). */
static int number_key(const char *name, json_object *o, const char *where, const char *key, double *out,
                      rr_error *err)
{
    json_object *v;
    if (!json_object_object_get_ex(o, key, &v))
        return 1;
    int rc = camjson_number_field(o, key, out);
    char text[72];
    return rc ? rr_fail(err, "%s: %s%s = %s is not a %snumber", name, where, key, value_text(v, text, sizeof text),
                        rc == -2 ? "finite " : "")
              : 0;
}

/* Every frame an object of known keys that say nothing but a pinhole's
 * (before any frame is read: a number among them was counted as a frame
 * without a 'time'). */
static int check_frames(const char *name, json_object *frames, rr_error *err)
{
    size_t n = json_object_array_length(frames);
    for (size_t i = 0; i < n; i++) {
        json_object *f = json_object_array_get_idx(frames, i);
        char label[48], entry[48], text[72];
        if (!json_object_is_type(f, json_type_object))
            return rr_fail(err, "%s: frames[%zu] = %s: a frame is an object ({\"transform_matrix\": [...], ...})",
                           name, i, value_text(f, text, sizeof text));
        snprintf(label, sizeof label, "frames[%zu]: ", i);
        snprintf(entry, sizeof entry, "frames[%zu].", i);
        if (known_keys(f, FRAME_KEYS, name, label, err) || projection_keys(name, f, entry, err))
            return -1;
    }
    return 0;
}

/* One intrinsic of the top level or, where a frame gives it, that frame's,
 * which must then agree (one camera for the whole path). */
static int intrinsic(const char *name, json_object *root, json_object *frames, const char *key, double *out,
                     rr_error *err)
{
    int rc = number_key(name, root, "", key, out, err);
    if (rc < 0)
        return -1;
    size_t n = json_object_array_length(frames);
    for (size_t i = 0; i < n; i++) {
        double v;
        char where[48];
        snprintf(where, sizeof where, "frames[%zu].", i);
        int f = number_key(name, json_object_array_get_idx(frames, i), where, key, &v, err);
        if (f < 0)
            return -1;
        if (f == 0 && rc == 0 && v != *out)
            return rr_fail(err, "%s: frames[%zu].%s = %.17g differs from the file's %.17g (per-frame intrinsics must "
                                "all be the same camera's)", name, i, key, v, *out);
        if (f == 0 && rc != 0)
            return rr_fail(err, "%s: frames[%zu] gives '%s' but the file does not: give the camera once, at the top "
                                "level", name, i, key);
    }
    return rc ? rr_fail(err, "%s: '%s' is missing (the pinhole camera needs fl_x, fl_y, cx, cy, w, h)", name, key)
              : 0;
}

/* The range rule cameras.json's focal lengths follow (camera_focal_usable),
 * and the principal point's (camera_principal_usable): fl_x = 1e-14 rendered
 * all background, fl_x or cx = 1e300 wrote infinity into the EXR header. */
static int usable_intrinsics(const char *name, const double v[6], rr_error *err)
{
    static const char *const focal[2] = {"fl_x", "fl_y"}, *const centre[2] = {"cx", "cy"}, *const size[2] = {"w", "h"};
    for (int k = 0; k < 2; k++) {
        double f = v[k], c = v[2 + k], s = v[4 + k];
        if (!camera_focal_usable(f, s))
            return rr_fail(err, "%s: %s = %.9g gives no usable field of view for %s = %g (2 atan(%s / (2 %s)) must lie "
                                "inside (0, 180) degrees and %s / %s fit the EXR header's float32)", name, focal[k], f,
                           size[k], s, size[k], focal[k], focal[k], size[k]);
        if (!camera_principal_usable(f, c, s))
            return rr_fail(err, "%s: %s = %.9g is too far off the image for %s = %.9g, %s = %g (the farther image edge "
                                "must lie inside 90 degrees of the optical axis, its tangent kept within 1e-6, and "
                                "%s / %s fit the EXR header's float32)", name, centre[k], c, focal[k], f, size[k], s,
                           centre[k], size[k]);
    }
    return 0;
}

static int read_camera(const char *name, json_object *root, json_object *frames, transforms_camera *cam,
                       rr_error *err)
{
    double v[6];
    for (int k = 0; INTRINSICS[k]; k++)
        if (intrinsic(name, root, frames, INTRINSICS[k], &v[k], err))
            return -1;
    if (!(v[0] > 0) || !(v[1] > 0) || !(v[4] >= 1 && v[4] <= 65536 && v[4] == floor(v[4])) ||
        !(v[5] >= 1 && v[5] <= 65536 && v[5] == floor(v[5])))
        return rr_fail(err, "%s: fl_x %g, fl_y %g must be > 0 and w %g, h %g whole numbers of pixels in [1, 65536]",
                       name, v[0], v[1], v[4], v[5]);
    if (usable_intrinsics(name, v, err))
        return -1;
    cam->fx = v[0], cam->fy = v[1], cam->cx = v[2], cam->cy = v[3], cam->width = (int)v[4], cam->height = (int)v[5];
    /* not applied (the scene's shutter is), but read as numbers: a string
     * one was dropped without the warning a number gets */
    cam->exposure_time = cam->rolling_shutter_time = NAN;
    int rc = number_key(name, root, "", "exposure_time", &v[0], err);
    if (rc < 0)
        return -1;
    cam->exposure_time = rc ? NAN : v[0];
    rc = number_key(name, root, "", "rolling_shutter_time", &v[0], err);
    if (rc < 0)
        return -1;
    cam->rolling_shutter_time = rc ? NAN : v[0];
    return 0;
}

/* A rotation matrix's quaternion, with +0 for -0: a zero's sign is no
 * rotation's, and a writer's arithmetic (export composes the camera's rest
 * pose) may flip it. */
static void matrix_to_quat(const double r[3][3], double q[4])
{
    quat_of_matrix(r, q);
    for (int i = 0; i < 4; i++)
        q[i] += 0.0;
}

/* The matrix transforms_write writes for q, read back as a quaternion. */
static void matrix_round_trip(const double *q, double *out, void *ctx)
{
    (void)ctx;
    double r[3][3];
    quat_matrix(q, r);
    matrix_to_quat(r, out);
}

/* A frame's transform_matrix: 4x4 (or 3x4), its last row 0 0 0 1, its
 * rotation a rotation within 1e-6. */
static int read_pose(const char *name, size_t i, json_object *frame, trajectory_knot *k, rr_error *err)
{
    json_object *rows;
    double m[4][4] = {{0}};
    m[3][3] = 1;
    if (!json_object_object_get_ex(frame, "transform_matrix", &rows) || !json_object_is_type(rows, json_type_array) ||
        (json_object_array_length(rows) != 4 && json_object_array_length(rows) != 3))
        return rr_fail(err, "%s: frames[%zu]: 'transform_matrix' is missing or not 4 rows", name, i);
    for (size_t r = 0; r < json_object_array_length(rows); r++) {
        int rc = camjson_numbers(json_object_array_get_idx(rows, r), 4, m[r]);
        if (rc)
            return rr_fail(err, "%s: frames[%zu]: 'transform_matrix' row %zu is %s", name, i, r,
                           rc == -2 ? "not finite" : "not 4 numbers");
    }
    if (m[3][0] != 0 || m[3][1] != 0 || m[3][2] != 0 || m[3][3] != 1)
        return rr_fail(err, "%s: frames[%zu]: 'transform_matrix' last row is not 0 0 0 1", name, i);
    double r[3][3], det = 0, off = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            r[a][b] = m[a][b];
            double dot = m[0][a] * m[0][b] + m[1][a] * m[1][b] + m[2][a] * m[2][b];
            off = fmax(off, fabs(dot - (a == b)));
        }
    det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
          r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    if (!(off <= 1e-6) || !(det > 0))
        return rr_fail(err, "%s: frames[%zu]: 'transform_matrix' rotation is not one (columns orthonormal within 1e-6, "
                            "determinant 1; a scaled world is not a camera pose)", name, i);
    matrix_to_quat(r, k->q);
    /* the quaternion its written matrix reads back as: a file read, written
     * (export, transforms_write) and read again gives the same poses bit for
     * bit, though a matrix to a quaternion and back rounds (quat_matrix) */
    rr_round_trip_representative(k->q, 4, matrix_round_trip, NULL);
    k->p = v3(m[0][3] + 0.0, m[1][3] + 0.0, m[2][3] + 0.0); /* +0 for -0 (matrix_to_quat) */
    if (!(fabs(k->p.x) <= RR_MAX_REACH && fabs(k->p.y) <= RR_MAX_REACH &&
          fabs(k->p.z) <= RR_MAX_REACH))
        return rr_fail(err, "%s: frames[%zu]: the position is beyond the %g a position may reach", name, i,
                       RR_MAX_REACH);
    return 0;
}

/* Every frame's time, or none's (then the index). */
static int read_times(const char *name, json_object *frames, size_t n, double *t, rr_error *err)
{
    size_t timed = 0;
    for (size_t i = 0; i < n; i++) {
        char where[48];
        snprintf(where, sizeof where, "frames[%zu].", i);
        int rc = number_key(name, json_object_array_get_idx(frames, i), where, "time", &t[i], err);
        if (rc < 0)
            return -1;
        timed += rc == 0;
    }
    if (timed && timed != n)
        return rr_fail(err, "%s: %zu of %zu frames have a 'time': all or none (then a frame's time is its index)",
                       name, timed, n);
    for (size_t i = 0; !timed && i < n; i++)
        t[i] = (double)i;
    for (size_t i = 1; i < n; i++)
        if (!(t[i] > t[i - 1]) || !isfinite(t[i] - t[0]))
            return rr_fail(err, "%s: frames[%zu]: time %.17g does not follow frames[%zu]'s %.17g (times must "
                                "increase, as the frames are listed)", name, i, t[i], i - 1, t[i - 1]);
    return 0;
}

static int read_frames(const char *name, json_object *frames, trajectory *tr, rr_error *err)
{
    size_t n = json_object_array_length(frames);
    if (n > (1u << 24))
        return rr_fail(err, "%s: %zu frames, more than a trajectory holds", name, n);
    double *t = malloc((n ? n : 1) * sizeof *t);
    tr->knots = malloc((n ? n : 1) * sizeof *tr->knots);
    int rc = !t || !tr->knots ? rr_fail(err, "out of memory") : read_times(name, frames, n, t, err);
    for (size_t i = 0; !rc && i < n; i++) { /* each an object (check_frames) */
        rc = read_pose(name, i, json_object_array_get_idx(frames, i), &tr->knots[i], err);
        tr->knots[i].t = t[i];
    }
    free(t);
    tr->count = rc ? 0 : (int)n;
    return rc;
}

int transforms_parse(const char *name, const char *text, size_t len, trajectory *tr, transforms_camera *cam,
                     rr_error *err)
{
    json_object *root, *frames;
    memset(tr, 0, sizeof *tr);
    tr->opengl_axes = 1;
    if (camjson_parse_document(name, text, len, &root, err))
        return -1;
    int rc = !json_object_is_type(root, json_type_object)
                 ? rr_fail(err, "%s: not a transforms.json (expected an object with 'frames')", name)
             : !json_object_object_get_ex(root, "frames", &frames) || !json_object_is_type(frames, json_type_array)
                 ? rr_fail(err, "%s: 'frames' is missing or not an array", name)
                 : known_keys(root, TOP_KEYS, name, "", err) || projection_keys(name, root, "", err) ||
                       check_frames(name, frames, err) || read_camera(name, root, frames, cam, err) ||
                       read_frames(name, frames, tr, err);
    if (!rc && !(tr->name = strdup(name)))
        rc = rr_fail(err, "out of memory");
    json_object_put(root);
    if (rc)
        trajectory_free(tr);
    return rc;
}

int transforms_load(const char *path, trajectory *tr, transforms_camera *cam, uint64_t *content_hash, rr_error *err)
{
    input_file in;
    if (input_file_read(path, TRANSFORMS_MAX_BYTES, &in, err))
        return -1;
    int rc = transforms_parse(path, in.data, in.len, tr, cam, err);
    if (!rc && content_hash)
        *content_hash = input_hash(*content_hash, in.data, in.len);
    input_file_free(&in);
    return rc;
}

void transforms_write(FILE *f, const transforms_camera *cam, const double *t, const vec3 *p, const double (*q)[4],
                      int n)
{
    fprintf(f, "{\n  \"camera_model\": \"PINHOLE\",\n  \"fl_x\": %.17g,\n  \"fl_y\": %.17g,\n  \"cx\": %.17g,\n"
               "  \"cy\": %.17g,\n  \"w\": %d,\n  \"h\": %d,\n  \"frames\": [",
            cam->fx, cam->fy, cam->cx, cam->cy, cam->width, cam->height);
    for (int i = 0; i < n; i++) {
        double r[3][3], gl[4];
        trajectory_quat_to_axes(q[i], gl, 1);
        quat_matrix(gl, r);
        for (int a = 0; a < 9; a++) /* +0 for -0: the reader keeps none (matrix_to_quat) */
            r[a / 3][a % 3] += 0.0;
        vec3 pi = p[i];
        fprintf(f, "%s\n    {\"file_path\": \"frame_%05d\", \"time\": %.17g, \"transform_matrix\": [[%.17g, %.17g, "
                   "%.17g, %.17g], [%.17g, %.17g, %.17g, %.17g], [%.17g, %.17g, %.17g, %.17g], [0, 0, 0, 1]]}",
                i ? "," : "", i, t[i], r[0][0], r[0][1], r[0][2], pi.x, r[1][0], r[1][1], r[1][2], pi.y, r[2][0],
                r[2][1], r[2][2], pi.z);
    }
    fputs("\n  ]\n}\n", f);
}
