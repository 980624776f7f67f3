#include "formats/colmap.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/camera.h"
#include "core/inputfile.h"
#include "core/rotation.h"

#define COLMAP_MAX_BYTES ((size_t)4 << 30)
#define COLMAP_MAX_NAME 4096

/* COLMAP 4.1.1's camera models by CameraModelId with their parameter
 * counts (focal + principal point + extra), src/colmap/sensor/models.h
 * 87-108 (the ids) and each model's PERSPECTIVE_CAMERA_MODEL_DEFINITIONS
 * (435-757). A binary cameras.bin holds no count: a model not listed here
 * cannot be stepped over. */
static const struct {
    const char *name;
    int nparams;
} MODELS[] = {{"SIMPLE_PINHOLE", 3},  {"PINHOLE", 4},         {"SIMPLE_RADIAL", 4},
              {"RADIAL", 5},          {"OPENCV", 8},          {"OPENCV_FISHEYE", 8},
              {"FULL_OPENCV", 12},    {"FOV", 5},             {"SIMPLE_RADIAL_FISHEYE", 4},
              {"RADIAL_FISHEYE", 5},  {"THIN_PRISM_FISHEYE", 12}, {"RAD_TAN_THIN_PRISM_FISHEYE", 16},
              {"SIMPLE_DIVISION", 4}, {"DIVISION", 5},        {"SIMPLE_FISHEYE", 3},
              {"FISHEYE", 4},         {"EUCM", 6},            {"EQUIRECTANGULAR", 2}};
#define NMODELS ((int)(sizeof MODELS / sizeof MODELS[0]))
enum { SIMPLE_PINHOLE = 0, PINHOLE = 1 };

static int model_of_name(const char *name)
{
    for (int k = 0; k < NMODELS; k++)
        if (!strcmp(MODELS[k].name, name))
            return k;
    return -1;
}

/* A record's place for a message: "file:line" (text) or "file: record k". */
static const char *where(char *buf, size_t size, const char *file, int text, long record, const char *what)
{
    if (text)
        snprintf(buf, size, "%s:%ld", file, record);
    else
        snprintf(buf, size, "%s: %s record %ld", file, what, record);
    return buf;
}

/* A quaternion of length 1 within 1e-3, normalised (see colmap.h). */
static int unit_quaternion(double q[4])
{
    double n = quat_norm(q);
    if (!(fabs(n - 1) <= 1e-3))
        return -1;
    for (int i = 0; i < 4; i++)
        q[i] /= n;
    return 0;
}

static int finite_all(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* ---- binary ------------------------------------------------------------------- */

/* Little-endian reads from a bounded buffer (COLMAP writes
 * WriteBinaryLittleEndian whatever the host). */
typedef struct {
    const unsigned char *p;
    size_t len, at;
} cursor;

static int take(cursor *c, size_t n, uint64_t *out)
{
    *out = 0;
    if (c->len - c->at < n)
        return -1;
    uint64_t v = 0;
    for (size_t i = 0; i < n; i++)
        v |= (uint64_t)c->p[c->at + i] << (8 * i);
    c->at += n;
    *out = v;
    return 0;
}

static int take_u32(cursor *c, uint32_t *out)
{
    uint64_t v = 0;
    int rc = take(c, 4, &v);
    *out = (uint32_t)v;
    return rc;
}

static int take_doubles(cursor *c, double *out, int n)
{
    for (int i = 0; i < n; i++) {
        uint64_t v = 0;
        if (take(c, 8, &v))
            return -1;
        memcpy(&out[i], &v, sizeof v);
    }
    return 0;
}

/* The record count at the file's start, no more than the file can hold at
 * min_size bytes a record (a crafted count is no allocation). */
static int take_count(cursor *c, size_t min_size, const char *name, const char *what, size_t *n, rr_error *err)
{
    uint64_t v;
    if (take(c, 8, &v))
        return rr_fail(err, "%s: %zu bytes: too short for the count of %ss (8 bytes)", name, c->len, what);
    if (v > (c->len - c->at) / min_size)
        return rr_fail(err, "%s: says %llu %ss, more than its %zu bytes can hold (truncated, or not a COLMAP "
                            "%ss.bin)", name, (unsigned long long)v, what, c->len, what);
    *n = (size_t)v;
    return 0;
}

static int binary_camera(const char *name, cursor *c, long k, colmap_camera *cam, rr_error *err)
{
    uint64_t model;
    char at[4200];
    where(at, sizeof at, name, 0, k, "camera");
    if (take_u32(c, &cam->id) || take(c, 4, &model) || take(c, 8, &cam->width) || take(c, 8, &cam->height))
        return rr_fail(err, "%s: truncated (the file ends inside it)", at);
    int id = (int32_t)(uint32_t)model;
    if (id < 0 || id >= NMODELS)
        return rr_fail(err, "%s: camera %u has model id %d, which COLMAP 4.1.1 does not define (its parameters "
                            "cannot be stepped over)", at, cam->id, id);
    cam->model = id, cam->nparams = MODELS[id].nparams, cam->record = k;
    snprintf(cam->model_name, sizeof cam->model_name, "%s", MODELS[id].name);
    if (take_doubles(c, cam->params, cam->nparams))
        return rr_fail(err, "%s: truncated in camera %u's %d parameters", at, cam->id, cam->nparams);
    if (!finite_all(cam->params, cam->nparams))
        return rr_fail(err, "%s: camera %u has a parameter that is not finite", at, cam->id);
    return 0;
}

static int binary_image(const char *name, cursor *c, long k, colmap_image *im, rr_error *err)
{
    char at[4200];
    where(at, sizeof at, name, 0, k, "image");
    if (take_u32(c, &im->id) || take_doubles(c, im->q, 4) || take_doubles(c, im->t, 3) ||
        take_u32(c, &im->camera_id))
        return rr_fail(err, "%s: truncated (the file ends inside it)", at);
    const char *s = (const char *)c->p + c->at, *nul = memchr(s, 0, c->len - c->at);
    if (!nul || nul - s >= COLMAP_MAX_NAME)
        return rr_fail(err, "%s: image %u's name has no terminating NUL within %d bytes", at, im->id,
                       COLMAP_MAX_NAME);
    if (!(im->name = strdup(s)))
        return rr_fail(err, "out of memory");
    c->at += (size_t)(nul - s) + 1;
    uint64_t npoints;
    if (take(c, 8, &npoints) || npoints > (c->len - c->at) / 24)
        return rr_fail(err, "%s: image %u ('%.200s'): truncated in its 2D points (24 bytes each: x, y, "
                            "point3D_id)", at, im->id, im->name);
    c->at += (size_t)npoints * 24; /* the points say nothing of the pose */
    im->record = k;
    return 0;
}

/* ---- text ------------------------------------------------------------------- */

#define MAX_TOKENS (4 + COLMAP_MAX_PARAMS + 1)

typedef struct {
    const char *data;
    size_t len, at;
    long line;
} lines;

/* The next line's whitespace-separated words (at most MAX_TOKENS + 1, so
 * that an extra one is seen) into tok (NUL-terminated copies in buf);
 * -1 at the end of the text. */
static int next_line(lines *l, char *buf, size_t size, char **tok, int *ntok)
{
    if (l->at >= l->len)
        return -1;
    const char *s = l->data + l->at, *nl = memchr(s, '\n', l->len - l->at);
    size_t n = nl ? (size_t)(nl - s) : l->len - l->at;
    l->at += n + (nl != NULL), l->line++;
    if (n >= size)
        n = size - 1; /* a line past COLMAP_MAX_NAME + numbers: its words are still counted */
    memcpy(buf, s, n);
    buf[n] = 0;
    *ntok = 0;
    for (char *save = NULL, *w = strtok_r(buf, " \t\r\v\f", &save); w && *ntok <= MAX_TOKENS;
         w = strtok_r(NULL, " \t\r\v\f", &save))
        tok[(*ntok)++] = w;
    return 0;
}

static int parse_u32(const char *s, uint32_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (*s < '0' || *s > '9' || *end || errno || v > UINT32_MAX)
        return -1;
    *out = (uint32_t)v;
    return 0;
}

static int parse_numbers(char **tok, int n, double *out)
{
    for (int i = 0; i < n; i++) {
        char *end;
        out[i] = strtod(tok[i], &end);
        if (end == tok[i] || *end || !isfinite(out[i]))
            return i;
    }
    return -1;
}

static int text_camera(const char *at, char **tok, int ntok, colmap_camera *cam, rr_error *err)
{
    uint32_t w, h;
    if (ntok < 4 || parse_u32(tok[0], &cam->id) || parse_u32(tok[2], &w) || parse_u32(tok[3], &h))
        return rr_fail(err, "%s: not a camera line (CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], whole numbers)", at);
    cam->width = w, cam->height = h;
    cam->model = model_of_name(tok[1]);
    snprintf(cam->model_name, sizeof cam->model_name, "%.31s", tok[1]);
    cam->nparams = ntok - 4;
    if (cam->model >= 0 && cam->nparams != MODELS[cam->model].nparams)
        return rr_fail(err, "%s: camera %u: %s has %d parameters, the line %d", at, cam->id, MODELS[cam->model].name,
                       MODELS[cam->model].nparams, cam->nparams);
    if (cam->nparams > COLMAP_MAX_PARAMS)
        return rr_fail(err, "%s: camera %u: more than %d parameters", at, cam->id, COLMAP_MAX_PARAMS);
    int bad = parse_numbers(tok + 4, cam->nparams, cam->params);
    if (bad >= 0)
        return rr_fail(err, "%s: camera %u: parameter %d '%.40s' is not a finite number", at, cam->id, bad + 1,
                       tok[4 + bad]);
    return 0;
}

static const char *const IMAGE_FIELDS[] = {"QW", "QX", "QY", "QZ", "TX", "TY", "TZ"};

static int text_image(const char *at, char **tok, int ntok, colmap_image *im, rr_error *err)
{
    if (ntok < 10 || parse_u32(tok[0], &im->id) || parse_u32(tok[8], &im->camera_id))
        return rr_fail(err, "%s: not an image line (IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME; ids whole "
                            "numbers)", at);
    if (ntok > 10)
        return rr_fail(err, "%s: image %u: words after the name '%.200s' (a name with a space: COLMAP's reader "
                            "takes its first word; rename the image)", at, im->id, tok[9]);
    double v[7];
    int bad = parse_numbers(tok + 1, 7, v);
    if (bad >= 0)
        return rr_fail(err, "%s: image %u: %s '%.40s' is not a finite number", at, im->id, IMAGE_FIELDS[bad],
                       tok[1 + bad]);
    memcpy(im->q, v, sizeof im->q);
    memcpy(im->t, v + 4, sizeof im->t);
    if (strlen(tok[9]) >= COLMAP_MAX_NAME)
        return rr_fail(err, "%s: image %u: a name longer than %d bytes", at, im->id, COLMAP_MAX_NAME - 1);
    return (im->name = strdup(tok[9])) ? 0 : rr_fail(err, "out of memory");
}

/* ---- both --------------------------------------------------------------------- */

static int grow(void **arr, size_t *cap, size_t n, size_t elem)
{
    if (n < *cap)
        return 0;
    size_t c = *cap ? 2 * *cap : 64;
    void *p = realloc(*arr, c * elem);
    if (!p)
        return -1;
    memset((char *)p + *cap * elem, 0, (c - *cap) * elem);
    *arr = p, *cap = c;
    return 0;
}

static int check_image(const char *at, colmap_image *im, rr_error *err)
{
    if (!finite_all(im->q, 4) || !finite_all(im->t, 3))
        return rr_fail(err, "%s: image %u: a pose number that is not finite", at, im->id);
    if (unit_quaternion(im->q))
        return rr_fail(err, "%s: image %u: quaternion (%g %g %g %g) has length %.9g, not 1 within 1e-3", at, im->id,
                       im->q[0], im->q[1], im->q[2], im->q[3], quat_norm(im->q));
    if (!(fabs(im->t[0]) <= RR_MAX_REACH && fabs(im->t[1]) <= RR_MAX_REACH && fabs(im->t[2]) <= RR_MAX_REACH))
        return rr_fail(err, "%s: image %u: translation beyond the %g a position may reach", at, im->id,
                       RR_MAX_REACH);
    return 0;
}

static int parse_text(const char *name, const char *data, size_t len, int images, colmap_model *m, rr_error *err)
{
    lines l = {data, len, 0, 0};
    char buf[COLMAP_MAX_NAME + 1024], *tok[MAX_TOKENS + 1], at[4200];
    size_t cap = 0;
    int ntok;
    while (!next_line(&l, buf, sizeof buf, tok, &ntok)) {
        if (!ntok || tok[0][0] == '#')
            continue;
        snprintf(at, sizeof at, "%s:%ld", name, l.line);
        if (images ? grow((void **)&m->images, &cap, m->nimages, sizeof *m->images)
                   : grow((void **)&m->cameras, &cap, m->ncameras, sizeof *m->cameras))
            return rr_fail(err, "out of memory");
        if (!images) {
            if (text_camera(at, tok, ntok, &m->cameras[m->ncameras], err))
                return -1;
            m->cameras[m->ncameras++].record = l.line;
            continue;
        }
        colmap_image *im = &m->images[m->nimages];
        im->record = l.line;
        if (text_image(at, tok, ntok, im, err) || (m->nimages++, check_image(at, im, err)))
            return -1;
        next_line(&l, buf, sizeof buf, tok, &ntok); /* its POINTS2D line: no pose in it */
    }
    return 0;
}

static int parse_binary(const char *name, const char *data, size_t len, int images, colmap_model *m, rr_error *err)
{
    cursor c = {(const unsigned char *)data, len, 0};
    size_t n = 0;
    /* the smallest record: a camera of 2 parameters, 40 bytes; an image, 73 */
    if (take_count(&c, images ? 73 : 40, name, images ? "image" : "camera", &n, err))
        return -1;
    if (images ? !(m->images = calloc(n ? n : 1, sizeof *m->images)) : !(m->cameras = calloc(n ? n : 1,
                                                                                           sizeof *m->cameras)))
        return rr_fail(err, "out of memory");
    for (size_t k = 0; k < n; k++) {
        char at[4200];
        if (!images) {
            if (binary_camera(name, &c, (long)k, &m->cameras[k], err))
                return -1;
            m->ncameras = k + 1;
            continue;
        }
        m->nimages = k + 1; /* freed with the model, even half read */
        if (binary_image(name, &c, (long)k, &m->images[k], err) ||
            check_image(where(at, sizeof at, name, 0, (long)k, "image"), &m->images[k], err))
            return -1;
    }
    if (c.at != len)
        return rr_fail(err, "%s: %zu bytes after the last of its %zu %ss (not a COLMAP %ss.bin, or a wrong count)",
                       name, len - c.at, n, images ? "image" : "camera", images ? "image" : "camera");
    return 0;
}

static int compare_ids(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* Ids are unique in a model (Reconstruction::AddCamera / AddImage check). */
static int unique_ids(const colmap_model *m, int images, rr_error *err)
{
    size_t n = images ? m->nimages : m->ncameras;
    uint32_t *ids = malloc((n ? n : 1) * sizeof *ids);
    if (!ids)
        return rr_fail(err, "out of memory");
    for (size_t i = 0; i < n; i++)
        ids[i] = images ? m->images[i].id : m->cameras[i].id;
    qsort(ids, n, sizeof *ids, compare_ids);
    int rc = 0;
    for (size_t i = 1; i < n && !rc; i++)
        if (ids[i] == ids[i - 1])
            rc = rr_fail(err, "%s: %s id %u appears twice", images ? m->images_file : m->cameras_file,
                         images ? "image" : "camera", ids[i]);
    free(ids);
    return rc;
}

static int parse_file(const char *name, const char *data, size_t len, int text, int images, colmap_model *m,
                      rr_error *err)
{
    char **file = images ? &m->images_file : &m->cameras_file;
    free(*file);
    if (!(*file = strdup(name)))
        return rr_fail(err, "out of memory");
    int rc = text ? parse_text(name, data, len, images, m, err) : parse_binary(name, data, len, images, m, err);
    if (!rc)
        m->text = text;
    return rc || unique_ids(m, images, err);
}

int colmap_parse_cameras(const char *name, const char *data, size_t len, int text, colmap_model *m, rr_error *err)
{
    return parse_file(name, data, len, text, 0, m, err);
}

int colmap_parse_images(const char *name, const char *data, size_t len, int text, colmap_model *m, rr_error *err)
{
    return parse_file(name, data, len, text, 1, m, err);
}

/* ---- the model directory ---------------------------------------------------- */

static int is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static int load_one(const char *path, int text, int images, colmap_model *m, uint64_t *content_hash, rr_error *err)
{
    input_file in;
    if (input_file_stream(path, COLMAP_MAX_BYTES, &in, err))
        return -1;
    if (content_hash)
        in.hash = *content_hash;
    int rc = parse_file(path, in.data, in.len, text, images, m, err);
    if (!rc && content_hash)
        *content_hash = input_file_hash(&in);
    input_file_free(&in);
    return rc;
}

int colmap_load(const char *dir, colmap_model *m, uint64_t *content_hash, char *files[2], rr_error *err)
{
    static const char *const names[2][2] = {{"cameras.bin", "images.bin"}, {"cameras.txt", "images.txt"}};
    char *path[2] = {NULL, NULL};
    memset(m, 0, sizeof *m);
    struct stat st;
    if (stat(dir, &st) || !S_ISDIR(st.st_mode))
        return rr_fail(err, "%s: not a directory (a COLMAP sparse model: the folder holding cameras.bin and "
                            "images.bin, or cameras.txt and images.txt)", dir);
    int text = 0, rc = 0;
    for (; text < 2; text++) {
        for (int k = 0; k < 2; k++) {
            free(path[k]);
            if (asprintf(&path[k], "%s/%s", dir, names[text][k]) < 0)
                path[k] = NULL;
        }
        if (!path[0] || !path[1] || (is_file(path[0]) && is_file(path[1])))
            break;
    }
    if (!path[0] || !path[1])
        rc = rr_fail(err, "out of memory");
    else if (text == 2)
        rc = rr_fail(err, "%s: holds neither cameras.bin and images.bin nor cameras.txt and images.txt (a COLMAP "
                          "sparse model, such as sparse/0)", dir);
    for (int k = 0; k < 2 && !rc; k++)
        rc = load_one(path[k], text, k, m, content_hash, err);
    for (int k = 0; k < 2; k++) {
        if (files && !rc)
            files[k] = path[k];
        else
            free(path[k]);
    }
    if (rc)
        colmap_free(m);
    return rc;
}

/* ---- one image's camera ------------------------------------------------------- */

static long find_image(const colmap_model *m, const char *name, long image_id, rr_error *err)
{
    long found = -1;
    for (size_t i = 0; i < m->nimages; i++) {
        const colmap_image *im = &m->images[i];
        if (image_id >= 0 ? im->id != (uint64_t)image_id : strcmp(im->name, name))
            continue;
        if (found >= 0)
            return rr_fail(err, "%s: images %u and %u are both named '%.200s': which is meant is ambiguous (select "
                                "by imageId)", m->images_file, m->images[found].id, im->id, name), -1;
        found = (long)i;
    }
    if (found >= 0)
        return found;
    char have[256] = "";
    size_t len = 0;
    for (size_t i = 0; i < m->nimages && i < 4 && len + 1 < sizeof have; i++)
        len += (size_t)snprintf(have + len, sizeof have - len, "%s%u '%.40s'", i ? ", " : "", m->images[i].id,
                                m->images[i].name);
    if (image_id >= 0)
        return rr_fail(err, "%s: no image of IMAGE_ID %ld; it has %s%s (%zu images)", m->images_file, image_id, have,
                       m->nimages > 4 ? ", ..." : "", m->nimages), -1;
    return rr_fail(err, "%s: no image named '%.200s'; it has %s%s (%zu images)", m->images_file, name, have,
                   m->nimages > 4 ? ", ..." : "", m->nimages), -1;
}

/* The pinhole of camera cam into out's size and intrinsics. */
static int pinhole(const colmap_model *m, const char *at, const colmap_camera *cam, camjson_camera *out,
                   rr_error *err)
{
    char cat[4200];
    where(cat, sizeof cat, m->cameras_file, m->text, cam->record, "camera");
    if (cam->model != PINHOLE && cam->model != SIMPLE_PINHOLE)
        return rr_fail(err, "%s: its camera %u (%s) is %s%s: refrender renders a pinhole (PINHOLE or "
                            "SIMPLE_PINHOLE); undistort the images first (colmap image_undistorter writes such a "
                            "model)", at, cam->id, cat, cam->model_name, cam->model < 0 ? ", a model COLMAP does not "
                            "know" : "");
    if (cam->width < 1 || cam->width > 65536 || cam->height < 1 || cam->height > 65536 ||
        (long long)(cam->width * cam->height) > RR_MAX_PIXELS)
        return rr_fail(err, "%s: camera %u is %llux%llu: each side in [1, 65536] and at most %lld pixels", cat,
                       cam->id, (unsigned long long)cam->width, (unsigned long long)cam->height, RR_MAX_PIXELS);
    const double *p = cam->params;
    int simple = cam->model == SIMPLE_PINHOLE;
    out->width = (int)cam->width, out->height = (int)cam->height;
    out->fx = p[0], out->fy = simple ? p[0] : p[1], out->cx = p[2 - simple], out->cy = p[3 - simple];
    double f[2] = {out->fx, out->fy}, c[2] = {out->cx, out->cy}, size[2] = {out->width, out->height};
    for (int k = 0; k < 2; k++)
        if (!(f[k] > 0) || !camera_focal_usable(f[k], size[k]) || !camera_principal_usable(f[k], c[k], size[k]))
            return rr_fail(err, "%s: camera %u: focal %.9g and principal point %.9g over %g pixels give no usable "
                                "view (a focal length > 0 with a field of view inside (0, 180) degrees, both image "
                                "edges inside 90 degrees of the axis, each fitting the EXR header's float32)", cat,
                           cam->id, f[k], c[k], size[k]);
    return 0;
}

int colmap_find(const colmap_model *m, const char *name, long image_id, camjson_camera *out, rr_error *err)
{
    long i = find_image(m, name, image_id, err);
    if (i < 0)
        return -1;
    const colmap_image *im = &m->images[i];
    char at[4600];
    where(at, sizeof at - 300, m->images_file, m->text, im->record, "image");
    snprintf(at + strlen(at), 300, ": image %u ('%.200s')", im->id, im->name);
    const colmap_camera *cam = NULL;
    for (size_t k = 0; k < m->ncameras && !cam; k++)
        if (m->cameras[k].id == im->camera_id)
            cam = &m->cameras[k];
    if (!cam)
        return rr_fail(err, "%s: its camera %u is not in %s", at, im->camera_id, m->cameras_file);
    memset(out, 0, sizeof *out);
    snprintf(out->img_name, sizeof out->img_name, "%.255s", im->name);
    if (pinhole(m, at, cam, out, err))
        return -1;
    double r[3][3], pos[3];
    quat_matrix(im->q, r); /* cam_from_world's rotation: its rows are the camera's axes in world */
    for (int a = 0; a < 3; a++) {
        for (int b = 0; b < 3; b++)
            out->c2w[a][b] = r[b][a] + 0.0;
        pos[a] = -(r[0][a] * im->t[0] + r[1][a] * im->t[1] + r[2][a] * im->t[2]) + 0.0;
    }
    if (!camjson_direction_survives(pos, out->c2w))
        return rr_fail(err, "%s: its centre (%g %g %g) is too far out for its view direction to survive position + "
                            "direction in double precision (within 1e-6)", at, pos[0], pos[1], pos[2]);
    out->position = v3(pos[0], pos[1], pos[2]);
    return 0;
}

void colmap_free(colmap_model *m)
{
    for (size_t i = 0; i < m->nimages; i++)
        free(m->images[i].name);
    free(m->images);
    free(m->cameras);
    free(m->cameras_file);
    free(m->images_file);
    memset(m, 0, sizeof *m);
}
