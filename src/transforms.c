#include "transforms.h"

#include <json-c/json.h>
#include <stdlib.h>
#include <string.h>

#include "camjson.h"
#include "inputfile.h"

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

/* One intrinsic of the top level or, where a frame gives it, that frame's,
 * which must then agree (one camera for the whole path). */
static int intrinsic(const char *name, json_object *root, json_object *frames, const char *key, double *out,
                     rr_error *err)
{
    int rc = camjson_number_field(root, key, out);
    if (rc == -2)
        return rr_fail(err, "%s: '%s' is not finite", name, key);
    size_t n = json_object_array_length(frames);
    for (size_t i = 0; i < n; i++) {
        double v;
        int f = camjson_number_field(json_object_array_get_idx(frames, i), key, &v);
        if (f == -2 || (f == 0 && rc == 0 && v != *out))
            return rr_fail(err, "%s: frames[%zu]: '%s' %s (per-frame intrinsics must all be the same camera's)",
                           name, i, key, f == -2 ? "is not finite" : "differs from the file's");
        if (f == 0 && rc != 0)
            return rr_fail(err, "%s: frames[%zu] gives '%s' but the file does not: give the camera once, at the top "
                                "level", name, i, key);
    }
    return rc ? rr_fail(err, "%s: '%s' is missing or not a number (the pinhole camera needs fl_x, fl_y, cx, cy, w, "
                             "h)", name, key)
              : 0;
}

static int read_camera(const char *name, json_object *root, json_object *frames, transforms_camera *cam,
                       rr_error *err)
{
    double v[6];
    for (int k = 0; INTRINSICS[k]; k++)
        if (intrinsic(name, root, frames, INTRINSICS[k], &v[k], err))
            return -1;
    for (int k = 0; DISTORTION[k]; k++) {
        double d;
        int rc = camjson_number_field(root, DISTORTION[k], &d);
        if (rc == -2 || (rc == 0 && d != 0))
            return rr_fail(err, "%s: distortion '%s' = %g: refrender renders a pinhole camera (undistort the images "
                                "and give the coefficients as 0)", name, DISTORTION[k], d);
    }
    json_object *m;
    if (json_object_object_get_ex(root, "camera_model", &m)) {
        const char *model = json_object_is_type(m, json_type_string) ? json_object_get_string(m) : "";
        if (strcmp(model, "PINHOLE") && strcmp(model, "OPENCV"))
            return rr_fail(err, "%s: camera_model '%.60s': only PINHOLE (or OPENCV without distortion)", name, model);
    }
    if (!(v[0] > 0) || !(v[1] > 0) || !(v[4] >= 1 && v[4] <= 65536 && v[4] == floor(v[4])) ||
        !(v[5] >= 1 && v[5] <= 65536 && v[5] == floor(v[5])))
        return rr_fail(err, "%s: fl_x %g, fl_y %g must be > 0 and w %g, h %g whole numbers of pixels in [1, 65536]",
                       name, v[0], v[1], v[4], v[5]);
    cam->fx = v[0], cam->fy = v[1], cam->cx = v[2], cam->cy = v[3], cam->width = (int)v[4], cam->height = (int)v[5];
    cam->exposure_time = camjson_number_field(root, "exposure_time", &v[0]) ? NAN : v[0];
    cam->rolling_shutter_time = camjson_number_field(root, "rolling_shutter_time", &v[0]) ? NAN : v[0];
    return 0;
}

/* A rotation matrix's quaternion, with +0 for -0: a zero's sign is no
 * rotation's, and a writer's arithmetic (export composes the camera's rest
 * pose) may flip it. */
static void matrix_to_quat(const double r[3][3], double q[4])
{
    trajectory_matrix_quat(r, q);
    for (int i = 0; i < 4; i++)
        q[i] += 0.0;
}

/* The matrix transforms_write writes for q, read back as a quaternion. */
static void matrix_round_trip(const double *q, double *out, void *ctx)
{
    (void)ctx;
    double r[3][3];
    trajectory_quat_matrix(q, r);
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
    /* the quaternion its written matrix reads back as (issue 30: read, write, read back bit for bit) */
    rr_round_trip_representative(k->q, 4, matrix_round_trip, NULL);
    k->p = v3(m[0][3] + 0.0, m[1][3] + 0.0, m[2][3] + 0.0); /* +0 for -0 (matrix_to_quat) */
    if (!(fabs(k->p.x) <= TRAJECTORY_MAX_ABS && fabs(k->p.y) <= TRAJECTORY_MAX_ABS &&
          fabs(k->p.z) <= TRAJECTORY_MAX_ABS))
        return rr_fail(err, "%s: frames[%zu]: the position is beyond the %g a position may reach", name, i,
                       TRAJECTORY_MAX_ABS);
    return 0;
}

/* Every frame's time, or none's (then the index). */
static int read_times(const char *name, json_object *frames, size_t n, double *t, rr_error *err)
{
    size_t timed = 0;
    for (size_t i = 0; i < n; i++) {
        int rc = camjson_number_field(json_object_array_get_idx(frames, i), "time", &t[i]);
        if (rc == -2 || (rc == -1 && json_object_object_get_ex(json_object_array_get_idx(frames, i), "time", NULL)))
            return rr_fail(err, "%s: frames[%zu]: 'time' is not a finite number", name, i);
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
    for (size_t i = 0; !rc && i < n; i++) {
        json_object *f = json_object_array_get_idx(frames, i);
        char where[48];
        snprintf(where, sizeof where, "frames[%zu]: ", i);
        rc = !json_object_is_type(f, json_type_object) ? rr_fail(err, "%s: frames[%zu] is not an object", name, i)
                                                        : known_keys(f, FRAME_KEYS, name, where, err) ||
                                                              read_pose(name, i, f, &tr->knots[i], err);
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
                 : known_keys(root, TOP_KEYS, name, "", err) || read_camera(name, root, frames, cam, err) ||
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
        trajectory_quat_matrix(gl, r);
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
