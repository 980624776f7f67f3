/* Cameras as trained Gaussian-splat models have them: the cameras.json
 * that 3DGS and 2DGS training write (graphdeco-inria/gaussian-splatting,
 * utils/camera_utils.py camera_to_JSON): an array of objects with
 * img_name, width, height, position (the camera centre, world), rotation
 * (3x3, rows: the camera-to-world rotation, so its columns are the
 * camera's x right, y down and z forward axes in world, OpenCV/COLMAP),
 * fx and fy (pixels; the principal point is the image centre). Parsed
 * with json-c. */
#ifndef RR_CAMJSON_H
#define RR_CAMJSON_H

#include <stdint.h>

#include "core/common.h"

typedef struct {
    char img_name[256];
    int width, height;
    vec3 position;
    double c2w[3][3]; /* c2w[r][c]: column c is camera axis c in world */
    double fx, fy;
    double cx, cy; /* the principal point, pixels from the top-left image corner: the centre
                      here (3DGS renders so), the file's in a COLMAP model (colmap.h) */
} camjson_camera;

/* A parsed cameras.json: parsed once, however many of its cameras a
 * scene names (one parse per use would read a 236 MiB file three times for
 * a camera and two poses). */
struct json_object;
typedef struct {
    struct json_object *root; /* the array of cameras */
    char *name;               /* the file's name, for errors */
    int *lines;               /* the line each camera starts on, for errors */
} camjson_file;

/* Reads and parses the file (its bytes folded into *content_hash unless
 * NULL); errors: not JSON (with the line), not an array. */
int camjson_load(const char *path, camjson_file *f, uint64_t *content_hash, rr_error *err);
int camjson_load_text(const char *name, const char *data, size_t len, camjson_file *f, rr_error *err);
/* The camera named img_name (errors as camjson_read's). */
int camjson_find(const camjson_file *f, const char *img_name, camjson_camera *out, rr_error *err);
void camjson_free(camjson_file *f);

/* The camera named img_name in the cameras.json at path. Errors name the
 * file and, where one is at fault, the entry (index and img_name) and its
 * field: not JSON (with the line), not an array, a missing or mistyped
 * field, a non-finite number, a size below 1 or above RR_MAX_PIXELS,
 * focal lengths <= 0 or not usable (camera_focal_usable: a field of view
 * inside (0, 180) degrees, a scale the EXR's float32 header holds), a
 * rotation that is not one (orthonormal within 1e-4, determinant 1), a
 * position too far out for position + view direction to keep the
 * direction, no camera of that name (compared with the JSON string's whole
 * length), or two of that name that differ (repeats of one camera are one:
 * SpacetimeGaussians lists each view once per frame).
 * The file's bytes are folded into *content_hash unless NULL. */
int camjson_read(const char *path, const char *img_name, camjson_camera *out, uint64_t *content_hash,
                 rr_error *err);
int camjson_parse(const char *name, const char *data, size_t len, const char *img_name, camjson_camera *out,
                  rr_error *err);

/* The JSON helpers the trained models' other files share (transforms.h):
 * a whole document (errors: not JSON, with the line; text after it); a
 * finite number field (0; -1 missing or not a number, -2 not finite); an
 * array of exactly n finite numbers (the same codes). */
int camjson_parse_document(const char *name, const char *data, size_t len, struct json_object **out, rr_error *err);
int camjson_number_field(struct json_object *o, const char *field, double *out);
int camjson_numbers(struct json_object *arr, int n, double *out);

/* Whether a camera at pos looking along r's third column keeps that
 * direction as lookat = pos + direction in double precision (within 1e-6;
 * it holds to about 1e9 from the origin): the other camera sources'
 * check too (colmap.h, llff.h). */
int camjson_direction_survives(const double pos[3], const double r[3][3]);

#endif
