#include "formats/llff.h"

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/camera.h"
#include "core/inputfile.h"

#define LLFF_MAX_BYTES ((size_t)256 << 20)
#define NPY_MAX_HEADER 10000 /* numpy's _MAX_HEADER_SIZE (format.py 194) */
#define LLFF_COLUMNS 17

/* ---- the .npy header: a Python dict literal ------------------------------------ */

typedef struct {
    const char *s, *end;
} scan;

static void skip_space(scan *p)
{
    while (p->s < p->end && (*p->s == ' ' || *p->s == '\t' || *p->s == '\n' || *p->s == '\r'))
        p->s++;
}

static int eat(scan *p, char c)
{
    skip_space(p);
    if (p->s < p->end && *p->s == c)
        return p->s++, 1;
    return 0;
}

/* A quoted string ('...' or "...", no escapes: numpy writes none) into out. */
static int string_literal(scan *p, char *out, size_t size)
{
    skip_space(p);
    if (p->s >= p->end || (*p->s != '\'' && *p->s != '"'))
        return -1;
    char q = *p->s++;
    const char *close = memchr(p->s, q, (size_t)(p->end - p->s));
    if (!close || (size_t)(close - p->s) >= size || memchr(p->s, '\\', (size_t)(close - p->s)))
        return -1;
    memcpy(out, p->s, (size_t)(close - p->s));
    out[close - p->s] = 0;
    p->s = close + 1;
    return 0;
}

/* (a, b) or (a, b,): the shape; only two dimensions are an LLFF file's. */
static int shape_literal(scan *p, unsigned long long dims[3], int *ndims)
{
    if (!eat(p, '('))
        return -1;
    *ndims = 0;
    while (!eat(p, ')')) {
        skip_space(p);
        char *end;
        if (*ndims == 3 || p->s >= p->end || *p->s < '0' || *p->s > '9')
            return -1;
        errno = 0;
        dims[(*ndims)++] = strtoull(p->s, &end, 10); /* the copy is NUL-terminated */
        if (errno || end > p->end)
            return -1;
        p->s = end;
        if (!eat(p, ',') && !(skip_space(p), p->s < p->end && *p->s == ')'))
            return -1;
    }
    return 0;
}

typedef struct {
    char descr[8];
    int fortran;
    unsigned long long dims[3];
    int ndims, seen;
} npy_header;

static int dict_entry(scan *p, npy_header *h)
{
    char key[32];
    if (string_literal(p, key, sizeof key) || !eat(p, ':'))
        return -1;
    skip_space(p);
    if (!strcmp(key, "descr") && !(h->seen & 1))
        return h->seen |= 1, string_literal(p, h->descr, sizeof h->descr);
    if (!strcmp(key, "shape") && !(h->seen & 4))
        return h->seen |= 4, shape_literal(p, h->dims, &h->ndims);
    if (strcmp(key, "fortran_order") || (h->seen & 2))
        return -1;
    h->seen |= 2;
    size_t left = (size_t)(p->end - p->s);
    if (left >= 4 && !memcmp(p->s, "True", 4))
        return h->fortran = 1, p->s += 4, 0;
    if (left >= 5 && !memcmp(p->s, "False", 5))
        return h->fortran = 0, p->s += 5, 0;
    return -1;
}

static int parse_header(const char *text, size_t len, npy_header *h)
{
    scan p = {text, text + len};
    memset(h, 0, sizeof *h);
    if (!eat(&p, '{'))
        return -1;
    while (!eat(&p, '}')) {
        if (dict_entry(&p, h))
            return -1;
        if (!eat(&p, ',') && !(skip_space(&p), p.s < p.end && *p.s == '}'))
            return -1;
    }
    skip_space(&p);
    return p.s == p.end && h->seen == 7 ? 0 : -1;
}

/* The header's text: magic, version, length (format.py 93-110, 145-147). */
static int header_text(const char *name, const unsigned char *d, size_t len, const char **text, size_t *hlen,
                       rr_error *err)
{
    if (len < 10 || memcmp(d, "\x93NUMPY", 6))
        return rr_fail(err, "%s: not a NumPy .npy file (it does not start with \\x93NUMPY)", name);
    int major = d[6], minor = d[7];
    if ((major != 1 && major != 2 && major != 3) || minor != 0)
        return rr_fail(err, "%s: .npy format version %d.%d (numpy writes 1.0, 2.0 and 3.0)", name, major, minor);
    size_t at = major == 1 ? 10 : 12;
    if (len < at)
        return rr_fail(err, "%s: truncated in its .npy header", name);
    *hlen = major == 1 ? (size_t)d[8] | (size_t)d[9] << 8
                       : (size_t)d[8] | (size_t)d[9] << 8 | (size_t)d[10] << 16 | (size_t)d[11] << 24;
    if (*hlen > NPY_MAX_HEADER)
        return rr_fail(err, "%s: a .npy header of %zu bytes, more than numpy reads (%d)", name, *hlen,
                       NPY_MAX_HEADER);
    if (len - at < *hlen)
        return rr_fail(err, "%s: truncated in its .npy header", name);
    *text = (const char *)d + at;
    return 0;
}

/* ---- the rows ------------------------------------------------------------------- */

static double value_at(const unsigned char *data, size_t index, int size, int big)
{
    unsigned char b[8];
    for (int i = 0; i < size; i++)
        b[i] = data[index * (size_t)size + (size_t)(big ? size - 1 - i : i)];
    if (size == 4) {
        float f;
        memcpy(&f, b, 4);
        return f;
    }
    double v;
    memcpy(&v, b, 8);
    return v;
}

/* Row k's matrix as an OpenCV camera-to-world rotation (columns [right,
 * down, forward] = LLFF's columns 1, 0, -2) and its centre. */
static void row_pose(const double *row, double r[3][3], double pos[3])
{
    for (int a = 0; a < 3; a++) {
        const double *m = row + 5 * a; /* row a of the 3x5 matrix */
        r[a][0] = m[1] + 0.0, r[a][1] = m[0] + 0.0, r[a][2] = -m[2] + 0.0;
        pos[a] = m[3] + 0.0;
    }
}

static int is_rotation(const double r[3][3])
{
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            if (!(fabs(r[0][a] * r[0][b] + r[1][a] * r[1][b] + r[2][a] * r[2][b] - (a == b)) <= 1e-4))
                return 0;
    return r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
               r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]) > 0;
}

static int whole_size(double v)
{
    return v >= 1 && v <= 65536 && v == floor(v);
}

static int check_row(const char *name, size_t k, const double *row, rr_error *err)
{
    for (int j = 0; j < LLFF_COLUMNS; j++)
        if (!isfinite(row[j]))
            return rr_fail(err, "%s: row %zu: value %d is not finite", name, k, j);
    double r[3][3], pos[3], h = row[4], w = row[9], f = row[14];
    row_pose(row, r, pos);
    if (!is_rotation(r))
        return rr_fail(err, "%s: row %zu: columns 0-2 of its 3x5 pose are not a rotation (orthonormal within 1e-4, "
                            "determinant 1 as LLFF's [down, right, back] is)", name, k);
    if (!whole_size(h) || !whole_size(w) || (long long)h * (long long)w > RR_MAX_PIXELS)
        return rr_fail(err, "%s: row %zu: height %g and width %g (column 4 of its 3x5 pose) must be whole numbers in "
                            "[1, 65536], at most %lld pixels", name, k, h, w, RR_MAX_PIXELS);
    if (!(f > 0) || !camera_focal_usable(f, w) || !camera_focal_usable(f, h))
        return rr_fail(err, "%s: row %zu: focal %g gives no usable field of view for %gx%g (inside (0, 180) "
                            "degrees, fitting the EXR header's float32)", name, k, f, w, h);
    if (!camjson_direction_survives(pos, r))
        return rr_fail(err, "%s: row %zu: its centre (%g %g %g) is too far out for its view direction to survive "
                            "position + direction in double precision (within 1e-6)", name, k, pos[0], pos[1], pos[2]);
    return 0;
}

static int check_header(const char *name, const npy_header *h, size_t data_len, int *size, int *big, rr_error *err)
{
    static const char *const types[4] = {"<f8", ">f8", "<f4", ">f4"};
    int t = 0;
    while (t < 4 && strcmp(h->descr, types[t]))
        t++;
    if (t == 4)
        return rr_fail(err, "%s: dtype '%s': poses_bounds.npy holds floats ('<f8', as LLFF writes, or '<f4')", name,
                       h->descr);
    *size = t < 2 ? 8 : 4, *big = t & 1;
    if (h->ndims != 2 || h->dims[1] != LLFF_COLUMNS || h->dims[0] < 1)
        return rr_fail(err, "%s: shape (%llu%s%llu%s): poses_bounds.npy is (N, 17), N >= 1 (a 3x5 pose and two "
                            "bounds a row)", name, h->ndims > 0 ? h->dims[0] : 0ULL, h->ndims > 1 ? ", " : "",
                       h->ndims > 1 ? h->dims[1] : 0ULL, h->ndims > 2 ? ", ..." : "");
    int short_data = h->dims[0] > data_len / (LLFF_COLUMNS * (size_t)*size);
    if (short_data || h->dims[0] * LLFF_COLUMNS * (size_t)*size != data_len)
        return rr_fail(err, "%s: shape (%llu, 17) of %d-byte values needs %s bytes of data than the %zu it has "
                            "(truncated, or not what its header says)", name, h->dims[0], *size,
                       short_data ? "more" : "fewer", data_len);
    return 0;
}

int llff_parse(const char *name, const char *data, size_t len, llff_poses *p, rr_error *err)
{
    const unsigned char *d = (const unsigned char *)data;
    const char *text = NULL;
    size_t hlen = 0;
    npy_header h;
    int size = 8, big = 0;
    memset(p, 0, sizeof *p);
    char copy[NPY_MAX_HEADER + 1]; /* NUL-terminated: strtoull reads past no end */
    if (header_text(name, d, len, &text, &hlen, err))
        return -1;
    memcpy(copy, text, hlen);
    copy[hlen] = 0;
    if (parse_header(copy, hlen, &h))
        return rr_fail(err, "%s: its .npy header is not the dict numpy writes ({'descr': ..., 'fortran_order': ..., "
                            "'shape': (...)}, those keys once each): '%.80s'", name, copy);
    size_t at = (size_t)(text - data) + hlen;
    if (check_header(name, &h, len - at, &size, &big, err))
        return -1;
    size_t n = (size_t)h.dims[0];
    if (!(p->rows = malloc(n * LLFF_COLUMNS * sizeof *p->rows)) || !(p->name = strdup(name))) {
        llff_free(p);
        return rr_fail(err, "out of memory");
    }
    p->n = n;
    for (size_t k = 0; k < n; k++) {
        double *row = p->rows + k * LLFF_COLUMNS;
        for (size_t j = 0; j < LLFF_COLUMNS; j++)
            row[j] = value_at(d + at, h.fortran ? j * n + k : k * LLFF_COLUMNS + j, size, big);
        if (check_row(name, k, row, err)) {
            llff_free(p);
            return -1;
        }
    }
    return 0;
}

int llff_load(const char *path, llff_poses *p, uint64_t *content_hash, rr_error *err)
{
    input_file in;
    if (input_file_read(path, LLFF_MAX_BYTES, &in, err))
        return -1;
    int rc = llff_parse(path, in.data, in.len, p, err);
    if (!rc && content_hash)
        *content_hash = input_hash(*content_hash, in.data, in.len);
    input_file_free(&in);
    return rc;
}

/* ---- the images' names ---------------------------------------------------------- */

/* Deblur-NeRF's _load_data filter: f.endswith('JPG') or 'jpg' or 'png'. */
static int counted(const char *name)
{
    size_t n = strlen(name);
    return n >= 3 && (!strcmp(name + n - 3, "JPG") || !strcmp(name + n - 3, "jpg") || !strcmp(name + n - 3, "png"));
}

static int by_bytes(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int read_names(DIR *d, llff_poses *p, rr_error *err)
{
    size_t cap = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!counted(e->d_name))
            continue;
        if (p->nnames == cap) {
            char **grown = realloc(p->image_names, (cap = cap ? 2 * cap : 64) * sizeof *grown);
            if (!grown)
                return rr_fail(err, "out of memory");
            p->image_names = grown;
        }
        if (!(p->image_names[p->nnames] = strdup(e->d_name)))
            return rr_fail(err, "out of memory");
        p->nnames++;
    }
    return 0;
}

int llff_list_images(llff_poses *p, const char *dir, uint64_t *content_hash, rr_error *err)
{
    DIR *d = opendir(dir);
    if (!d)
        return rr_fail(err, "%s: cannot list the images beside %s to select one by name (%s); select by index",
                       dir, p->name, strerror(errno));
    int rc = read_names(d, p, err);
    closedir(d);
    if (rc)
        return -1;
    qsort(p->image_names, p->nnames, sizeof *p->image_names, by_bytes);
    if (p->nnames != p->n)
        return rr_fail(err, "%s: %zu images (names ending in JPG, jpg or png) but %s has %zu rows: which row is which "
                            "image is unknown (Deblur-NeRF's loader stops likewise)", dir, p->nnames, p->name, p->n);
    for (size_t i = 0; content_hash && i < p->nnames; i++)
        *content_hash = input_hash(*content_hash, p->image_names[i], strlen(p->image_names[i]) + 1);
    return 0;
}

int llff_find(const llff_poses *p, const char *name, long index, camjson_camera *out, rr_error *err)
{
    if (name) {
        index = -1;
        for (size_t i = 0; i < p->nnames && index < 0; i++)
            if (!strcmp(p->image_names[i], name))
                index = (long)i;
        if (index < 0)
            return rr_fail(err, "%s: no image named '%.200s' among its %zu images (%s%s%s ...)", p->name, name,
                           p->nnames, p->nnames ? "'" : "", p->nnames ? p->image_names[0] : "", p->nnames ? "'" : "");
    }
    if (index < 0 || (size_t)index >= p->n)
        return rr_fail(err, "%s: no row %ld (it has %zu, from 0)", p->name, index, p->n);
    const double *row = p->rows + (size_t)index * LLFF_COLUMNS;
    double pos[3];
    memset(out, 0, sizeof *out);
    row_pose(row, out->c2w, pos);
    out->position = v3(pos[0], pos[1], pos[2]);
    out->height = (int)row[4], out->width = (int)row[9];
    out->fx = out->fy = row[14];
    out->cx = 0.5 * out->width, out->cy = 0.5 * out->height;
    snprintf(out->img_name, sizeof out->img_name, "%.255s", name ? name : "");
    return 0;
}

void llff_free(llff_poses *p)
{
    for (size_t i = 0; i < p->nnames; i++)
        free(p->image_names[i]);
    free(p->image_names);
    free(p->rows);
    free(p->name);
    memset(p, 0, sizeof *p);
}
