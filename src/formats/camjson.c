#include "formats/camjson.h"

#include <json-c/json.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/camera.h"
#include "core/inputfile.h"

#define CAMJSON_MAX_BYTES ((size_t)256 << 20)

/* The line of byte offset `at` (1-based), for json-c's parse errors. */
static int line_of(const char *data, size_t at)
{
    int line = 1;
    for (size_t i = 0; i < at; i++)
        line += data[i] == '\n';
    return line;
}

static int entry_fail(rr_error *err, const char *name, size_t index, json_object *entry, const char *fmt,
                      const char *field)
{
    json_object *n;
    const char *img = json_object_object_get_ex(entry, "img_name", &n) && json_object_is_type(n, json_type_string)
                          ? json_object_get_string(n) : "?";
    char what[512]; /* the longest format here with a field name: no cut */
    snprintf(what, sizeof what, fmt, field);
    return rr_fail(err, "%s: camera %zu ('%.100s'): %s", name, index, img, what);
}

/* A finite number field (ints are numbers too). */
int camjson_number_field(struct json_object *o, const char *field, double *out)
{
    json_object *v;
    if (!json_object_object_get_ex(o, field, &v) ||
        !(json_object_is_type(v, json_type_double) || json_object_is_type(v, json_type_int)))
        return -1;
    *out = json_object_get_double(v);
    return isfinite(*out) ? 0 : -2;
}

/* The messages of number_field's and numbers' errors, by -rc. */
static const char *const number_errors[] = {"", "field '%s' is missing or not a number (list)",
                                            "field '%s' is not finite"};

int camjson_numbers(struct json_object *arr, int n, double *out)
{
    if (!json_object_is_type(arr, json_type_array) || (int)json_object_array_length(arr) != n)
        return -1;
    for (int i = 0; i < n; i++) {
        json_object *v = json_object_array_get_idx(arr, (size_t)i);
        if (!(json_object_is_type(v, json_type_double) || json_object_is_type(v, json_type_int)))
            return -1;
        out[i] = json_object_get_double(v);
        if (!isfinite(out[i]))
            return -2;
    }
    return 0;
}

static int read_rotation(json_object *entry, double r[3][3])
{
    json_object *rows;
    if (!json_object_object_get_ex(entry, "rotation", &rows) || !json_object_is_type(rows, json_type_array) ||
        json_object_array_length(rows) != 3)
        return -1;
    for (int i = 0; i < 3; i++) {
        int rc = camjson_numbers(json_object_array_get_idx(rows, (size_t)i), 3, r[i]);
        if (rc)
            return rc;
    }
    return 0;
}

/* Orthonormal within 1e-4 and a rotation, not a reflection. */
static int is_rotation(const double r[3][3])
{
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            double d = r[0][a] * r[0][b] + r[1][a] * r[1][b] + r[2][a] * r[2][b];
            if (fabs(d - (a == b)) > 1e-4)
                return 0;
        }
    double det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
                 r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    return det > 0;
}

static int read_size(json_object *entry, const char *field, int *out)
{
    double v;
    if (camjson_number_field(entry, field, &v))
        return -1;
    if (!(v >= 1 && v <= 65536 && v == floor(v)))
        return -2;
    *out = (int)v;
    return 0;
}

/* The camera looks along the rotation's third column from the position,
 * and a scene takes it as lookat = position + that column (scene_xml.c):
 * far out (1e16) the sum rounds back to the position, and the error would
 * then blame a lookat the file does not have. The direction must survive
 * the sum within 1e-6, which holds up to about 1e9 from the origin. */
int camjson_direction_survives(const double pos[3], const double r[3][3])
{
    for (int k = 0; k < 3; k++) {
        volatile double lookat = pos[k] + r[k][2]; /* rounded to a double, as stored */
        if (!(fabs((lookat - pos[k]) - r[k][2]) <= 1e-6))
            return 0;
    }
    return 1;
}

static int read_focal(const char *name, size_t index, json_object *entry, camjson_camera *c, rr_error *err)
{
    const char *focal[2] = {"fx", "fy"};
    double *f[2] = {&c->fx, &c->fy};
    int size[2] = {c->width, c->height}, rc;
    for (int k = 0; k < 2; k++) {
        if ((rc = camjson_number_field(entry, focal[k], f[k])))
            return entry_fail(err, name, index, entry, number_errors[-rc], focal[k]);
        if (!(*f[k] > 0))
            return entry_fail(err, name, index, entry, "field '%s' must be > 0", focal[k]);
        if (!camera_focal_usable(*f[k], size[k])) { /* fx = 1e-14 was blamed on the object's reach */
            char what[400];
            snprintf(what, sizeof what, "field '%%s' = %g gives no usable field of view for %s %d (2 atan(%s / (2 "
                     "%s)) must lie inside (0, 180) degrees and %s / %s fit the EXR header's float32)", *f[k],
                     k ? "height" : "width", size[k], k ? "height" : "width", focal[k], focal[k],
                     k ? "height" : "width");
            return entry_fail(err, name, index, entry, what, focal[k]);
        }
    }
    return 0;
}

static int read_camera(const char *name, size_t index, json_object *entry, camjson_camera *c, rr_error *err)
{
    double pos[3];
    json_object *arr;
    int rc = json_object_object_get_ex(entry, "position", &arr) ? camjson_numbers(arr, 3, pos) : -1;
    if (rc)
        return entry_fail(err, name, index, entry, number_errors[-rc], "position");
    if ((rc = read_rotation(entry, c->c2w)))
        return entry_fail(err, name, index, entry, "field '%s' is not a 3x3 array of finite numbers", "rotation");
    if (!is_rotation(c->c2w))
        return entry_fail(err, name, index, entry, "field '%s' is not a rotation (orthonormal, determinant 1)",
                          "rotation");
    const char *sizes[2] = {"width", "height"};
    int *dims[2] = {&c->width, &c->height};
    for (int k = 0; k < 2; k++)
        if ((rc = read_size(entry, sizes[k], dims[k])))
            return entry_fail(err, name, index, entry,
                              rc == -1 ? number_errors[1] : "field '%s' must be a whole number of pixels in [1, 65536]", sizes[k]);
    if ((long long)c->width * c->height > RR_MAX_PIXELS)
        return entry_fail(err, name, index, entry, "%s: more pixels than refrender renders", "width x height");
    if (read_focal(name, index, entry, c, err))
        return -1;
    if (!camjson_direction_survives(pos, c->c2w)) {
        char what[400];
        snprintf(what, sizeof what, "field '%%s' (%g %g %g) is too far out for the view direction of 'rotation' "
                 "to survive position + direction in double precision (within 1e-6)", pos[0], pos[1], pos[2]);
        return entry_fail(err, name, index, entry, what, "position");
    }
    c->position = v3(pos[0], pos[1], pos[2]);
    c->cx = 0.5 * c->width, c->cy = 0.5 * c->height; /* 3DGS's projection centres it */
    return 0;
}

/* "'a', 'b', 'c', ... (N cameras)" into buf: what the file has. */
static void list_names(json_object *root, char *buf, size_t size)
{
    size_t n = json_object_array_length(root), len = 0;
    buf[0] = 0;
    for (size_t i = 0; i < n && i < 4 && len + 1 < size; i++) {
        json_object *e = json_object_array_get_idx(root, i), *v;
        const char *img = json_object_object_get_ex(e, "img_name", &v) && json_object_is_type(v, json_type_string)
                              ? json_object_get_string(v) : "?";
        len += (size_t)snprintf(buf + len, size - len, "%s'%.40s'", i ? ", " : "", img);
    }
    if (len + 1 < size)
        snprintf(buf + len, size - len, "%s (%zu cameras)", n > 4 ? ", ..." : "", n);
}

/* Whether entry e (an object with a string img_name) is named img_name: by
 * the JSON string's length ("A\u0000x" is not "A": strcmp would stop at the
 * NUL). */
static int named(json_object *e, const char *img_name)
{
    json_object *v;
    json_object_object_get_ex(e, "img_name", &v);
    return (size_t)json_object_get_string_len(v) == strlen(img_name) &&
           !memcmp(json_object_get_string(v), img_name, strlen(img_name));
}

/* The index of the first entry named img_name (-1 none, -2 a malformed
 * entry); camjson_find checks the others of that name. */
static long find_entry(const char *name, json_object *root, const char *img_name, rr_error *err)
{
    long found = -1;
    size_t n = json_object_array_length(root);
    for (size_t i = 0; i < n; i++) {
        json_object *e = json_object_array_get_idx(root, i), *v;
        if (!json_object_is_type(e, json_type_object))
            return rr_fail(err, "%s: camera %zu is not an object", name, i), -2;
        if (!json_object_object_get_ex(e, "img_name", &v) || !json_object_is_type(v, json_type_string))
            return rr_fail(err, "%s: camera %zu: field 'img_name' is missing or not a string", name, i), -2;
        if (found < 0 && named(e, img_name))
            found = (long)i;
    }
    if (found < 0) {
        char names[256];
        list_names(root, names, sizeof names);
        rr_fail(err, "%s: no camera named '%s' (img_name); it has %s", name, img_name, names);
    }
    return found;
}

/* The first field in which two cameras differ, or NULL: exact, as parsed. */
static const char *camera_difference(const camjson_camera *a, const camjson_camera *b)
{
    if (a->width != b->width || a->height != b->height)
        return "width x height";
    if (a->position.x != b->position.x || a->position.y != b->position.y || a->position.z != b->position.z)
        return "position";
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            if (a->c2w[r][c] != b->c2w[r][c])
                return "rotation";
    return a->fx != b->fx ? "fx" : a->fy != b->fy ? "fy" : NULL;
}

/* The line each element of the top-level array starts on (json-c keeps no
 * positions, and errors name the line): a scan that skips strings and
 * counts nesting. n: the array's length, as json-c parsed it. */
static int *entry_lines(const char *data, size_t len, size_t n)
{
    int *lines = calloc(n ? n : 1, sizeof *lines), line = 1, depth = 0, in_string = 0, expect = 1;
    size_t k = 0;
    if (!lines)
        return NULL;
    for (size_t i = 0; i < len && k < n; i++) {
        char ch = data[i];
        if (ch == '\n')
            line++;
        if (in_string) {
            if (ch == '\\')
                i += i + 1 < len && data[i + 1] != '\n';
            else if (ch == '"')
                in_string = 0;
            continue;
        }
        if (depth == 1 && expect && ch != ' ' && ch != '\t' && ch != '\r' && ch != '\n' && ch != ',') {
            lines[k++] = line, expect = 0;
        }
        if (ch == '"')
            in_string = 1;
        else if (ch == '[' || ch == '{')
            depth++;
        else if (ch == ']' || ch == '}')
            depth--;
        else if (ch == ',' && depth == 1)
            expect = 1;
    }
    return lines;
}

int camjson_parse_document(const char *name, const char *data, size_t len, struct json_object **out, rr_error *err)
{
    /* RFC 8259 section 8.1: a parser may ignore a leading byte order mark, which
     * Windows editors write; json-c refuses it with the mark invisible in the
     * message (the TUM reader skips it likewise) */
    static const char bom[] = "\xEF\xBB\xBF";
    if (len >= 3 && !memcmp(data, bom, 3))
        data += 3, len -= 3;
    json_tokener *tok = json_tokener_new();
    if (!tok)
        return rr_fail(err, "out of memory");
    json_object *root = len <= (size_t)INT32_MAX ? json_tokener_parse_ex(tok, data, (int)len) : NULL;
    enum json_tokener_error jerr = json_tokener_get_error(tok);
    if (!root || jerr != json_tokener_success || (size_t)json_tokener_get_parse_end(tok) != len) {
        size_t at = json_tokener_get_parse_end(tok);
        int rc = rr_fail(err, "%s:%d: not a complete JSON document (%s)", name, line_of(data, at < len ? at : len),
                         jerr == json_tokener_success ? "text after the end" : jerr == json_tokener_continue
                             ? "it ends early" : json_tokener_error_desc(jerr));
        json_object_put(root);
        json_tokener_free(tok);
        return rc;
    }
    json_tokener_free(tok);
    *out = root;
    return 0;
}

int camjson_load_text(const char *name, const char *data, size_t len, camjson_file *f, rr_error *err)
{
    memset(f, 0, sizeof *f);
    json_object *root;
    if (camjson_parse_document(name, data, len, &root, err))
        return -1;
    if (!json_object_is_type(root, json_type_array)) {
        json_object_put(root);
        return rr_fail(err, "%s: not a cameras.json (expected an array of cameras)", name);
    }
    f->name = strdup(name);
    f->lines = entry_lines(data, len, json_object_array_length(root));
    if (!f->name || !f->lines) {
        json_object_put(root);
        free(f->name), free(f->lines);
        return rr_fail(err, "out of memory");
    }
    f->root = root;
    return 0;
}

int camjson_load(const char *path, camjson_file *f, uint64_t *content_hash, rr_error *err)
{
    input_file in;
    if (input_file_read(path, CAMJSON_MAX_BYTES, &in, err))
        return -1;
    int rc = camjson_load_text(path, in.data, in.len, f, err);
    if (!rc && content_hash)
        *content_hash = input_hash(*content_hash, in.data, in.len);
    input_file_free(&in);
    return rc;
}

/* Entry idx read into out (its errors name the file and the entry's line). */
static int read_entry(const camjson_file *f, long idx, camjson_camera *out, rr_error *err)
{
    char *at = NULL; /* "file:line", where the entry starts */
    if (asprintf(&at, "%s:%d", f->name, f->lines[idx]) < 0)
        return rr_fail(err, "out of memory");
    int rc = read_camera(at, (size_t)idx, json_object_array_get_idx(f->root, (size_t)idx), out, err);
    free(at);
    return rc;
}

/* A name may repeat (SpacetimeGaussians' cameras.json lists each view once
 * per frame under one name) when every entry of it is the same camera;
 * entries that differ make the name ambiguous and are refused. */
int camjson_find(const camjson_file *f, const char *img_name, camjson_camera *out, rr_error *err)
{
    long idx = find_entry(f->name, f->root, img_name, err);
    if (idx < 0)
        return -1;
    memset(out, 0, sizeof *out);
    snprintf(out->img_name, sizeof out->img_name, "%s", img_name);
    if (read_entry(f, idx, out, err))
        return -1;
    size_t n = json_object_array_length(f->root);
    for (size_t i = (size_t)idx + 1; i < n; i++) {
        if (!named(json_object_array_get_idx(f->root, i), img_name))
            continue;
        camjson_camera other = *out;
        if (read_entry(f, (long)i, &other, err))
            return -1;
        const char *field = camera_difference(out, &other);
        if (field)
            return rr_fail(err, "%s: cameras %ld and %zu are both named '%s' and differ in %s: which is meant is "
                                "ambiguous", f->name, idx, i, img_name, field);
    }
    return 0;
}

void camjson_free(camjson_file *f)
{
    json_object_put(f->root);
    free(f->name);
    free(f->lines);
    memset(f, 0, sizeof *f);
}

int camjson_parse(const char *name, const char *data, size_t len, const char *img_name, camjson_camera *out,
                  rr_error *err)
{
    camjson_file f;
    if (camjson_load_text(name, data, len, &f, err))
        return -1;
    int rc = camjson_find(&f, img_name, out, err);
    camjson_free(&f);
    return rc;
}

int camjson_read(const char *path, const char *img_name, camjson_camera *out, uint64_t *content_hash,
                 rr_error *err)
{
    camjson_file f;
    if (camjson_load(path, &f, content_hash, err))
        return -1;
    int rc = camjson_find(&f, img_name, out, err);
    camjson_free(&f);
    return rc;
}
