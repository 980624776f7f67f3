#include "formats/ply.h"

#include <math.h>

#include <errno.h>
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/atomicfile.h"
#include "core/inputfile.h"

enum ply_format { PLY_ASCII, PLY_LE, PLY_BE };
enum { SLOT_X, SLOT_Y, SLOT_Z, SLOT_NX, SLOT_NY, SLOT_NZ, SLOT_RADIUS, SLOT_UX, SLOT_UY,
       SLOT_UZ, SLOT_VX, SLOT_VY, SLOT_VZ, SLOT_R, SLOT_G, SLOT_B, SLOT_COUNT };
static const char *const slot_names[SLOT_COUNT] = {
    "x", "y", "z", "nx", "ny", "nz", "radius", "ux", "uy", "uz", "vx", "vy", "vz",
    "red", "green", "blue"};
/* Surfels: integer colors are divided by their type's maximum. */
static const ply_schema surfel_schema = {slot_names, SLOT_COUNT, SLOT_R};

typedef struct {
    int type;       /* scalar type index into type_table */
    int list_count; /* for list properties: type of the count, else -1 */
    int slot;       /* SLOT_* or -1 when ignored */
    char name[64];  /* for messages */
} ply_property;

typedef struct {
    char name[64];
    size_t count;
    int nprops;
    ply_property props[PLY_MAX_PROPERTIES];
} ply_element;

/* The file is parsed from memory (inputfile.h): cur walks from the start of
 * the data to end. */
typedef struct {
    const char *path;
    const char *data, *cur, *end;
    enum ply_format format;
    int nelements;
    ply_element elements[16]; /* 265 KB with their property tables */
    long line; /* current line (header and ascii body) */
    const ply_schema *schema; /* the vertex properties read, by name */
    const ply_visitor *visitor;
    rr_error *err;
    input_file *src; /* the file being read, when streamed: what is read is released (inputfile.h) */
} ply_reader;

static const struct {
    const char *name, *alias;
    int size, is_int, is_signed;
    double max;
} type_table[] = {
    {"char", "int8", 1, 1, 1, 127.0},        {"uchar", "uint8", 1, 1, 0, 255.0},
    {"short", "int16", 2, 1, 1, 32767.0},    {"ushort", "uint16", 2, 1, 0, 65535.0},
    {"int", "int32", 4, 1, 1, 2147483647.0}, {"uint", "uint32", 4, 1, 0, 4294967295.0},
    {"float", "float32", 4, 0, 1, 1.0},      {"double", "float64", 8, 0, 1, 1.0},
};
#define NTYPES ((int)(sizeof type_table / sizeof type_table[0]))

static int type_index(const char *name)
{
    for (int i = 0; i < NTYPES; i++)
        if (!strcmp(name, type_table[i].name) || !strcmp(name, type_table[i].alias))
            return i;
    return -1;
}

static int slot_index(const ply_schema *schema, const char *name)
{
    for (int i = 0; i < schema->count; i++)
        if (!strcmp(name, schema->names[i]))
            return i;
    return -1;
}

/* ---- header ---------------------------------------------------------- */

static int header_fail(ply_reader *r, const char *what)
{
    return rr_fail(r->err, "%s:%ld: %s", r->path, r->line, what);
}

/* Tells the visitor (if it asks) of a vertex property. */
static int report_property(ply_reader *r, const ply_element *e, const char *name)
{
    if (strcmp(e->name, "vertex") || !r->visitor || !r->visitor->property)
        return 0;
    return r->visitor->property(r->visitor->user, r->path, r->line, name, r->err);
}

static int parse_property(ply_reader *r, ply_element *e, char *rest)
{
    char a[64] = "", b[64] = "", c[64] = "";
    int n = sscanf(rest, "%63s %63s %63s", a, b, c);
    (void)c;
    if (e->nprops == PLY_MAX_PROPERTIES)
        return header_fail(r, "too many properties (at most 256)");
    ply_property *p = &e->props[e->nprops];
    if (n >= 1 && !strcmp(a, "list")) {
        char item[64] = "", name[64] = "";
        if (sscanf(rest, "%*s %63s %63s %63s", a, item, name) != 3)
            return header_fail(r, "malformed 'property list <count type> <item type> <name>'");
        memcpy(p->name, name, sizeof p->name);
        if (report_property(r, e, name))
            return -1;
        p->list_count = type_index(a);
        p->type = type_index(item);
        if (p->list_count < 0 || !type_table[p->list_count].is_int || p->type < 0)
            return header_fail(r, "unknown or non-integer list count type");
        p->slot = -1;
    } else {
        if (n != 2)
            return header_fail(r, "malformed 'property <type> <name>'");
        p->type = type_index(a);
        p->list_count = -1;
        memcpy(p->name, b, sizeof p->name);
        if (p->type < 0)
            return header_fail(r, "unknown property type");
        p->slot = strcmp(e->name, "vertex") ? -1 : slot_index(r->schema, b);
        for (int i = 0; p->slot >= 0 && i < e->nprops; i++)
            if (e->props[i].slot == p->slot) {
                char what[128];
                snprintf(what, sizeof what, "duplicate vertex property '%s'", b);
                return header_fail(r, what);
            }
        if (report_property(r, e, b))
            return -1;
    }
    e->nprops++;
    return 0;
}

static int parse_header_line(ply_reader *r, char *line, int *done)
{
    char word[64] = "";
    int off = 0;
    if (sscanf(line, "%63s %n", word, &off) < 1)
        return 0; /* blank line */
    char *rest = line + off;
    if (!strcmp(word, "comment") || !strcmp(word, "obj_info"))
        return 0;
    if (!strcmp(word, "end_header")) {
        *done = 1;
        return 0;
    }
    if (!strcmp(word, "format")) {
        char fmt[64] = "", ver[64] = "";
        if (sscanf(rest, "%63s %63s", fmt, ver) != 2 || strcmp(ver, "1.0"))
            return header_fail(r, "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
        if (!strcmp(fmt, "ascii")) r->format = PLY_ASCII;
        else if (!strcmp(fmt, "binary_little_endian")) r->format = PLY_LE;
        else if (!strcmp(fmt, "binary_big_endian")) r->format = PLY_BE;
        else return header_fail(r, "unknown PLY format");
        return 0;
    }
    if (!strcmp(word, "element")) {
        if (r->nelements == 16)
            return header_fail(r, "too many elements (at most 16)");
        ply_element *e = &r->elements[r->nelements];
        unsigned long long count;
        char extra;
        if (sscanf(rest, "%63s %llu %c", e->name, &count, &extra) != 2 || rest[0] == '-')
            return header_fail(r, "malformed 'element <name> <count>'");
        for (int k = 0; k < r->nelements; k++) /* a second 'vertex' would otherwise be ignored */
            if (!strcmp(r->elements[k].name, e->name)) {
                char what[128];
                snprintf(what, sizeof what, "duplicate element '%s'", e->name);
                return header_fail(r, what);
            }
        e->count = (size_t)count;
        e->nprops = 0;
        r->nelements++;
        return 0;
    }
    if (!strcmp(word, "property")) {
        if (r->nelements == 0)
            return header_fail(r, "'property' before any 'element'");
        return parse_property(r, &r->elements[r->nelements - 1], rest);
    }
    return header_fail(r, "unknown header keyword");
}

/* Copies the next line (without its newline) into buf; 0 at the end of
 * the data, -1 if the line does not fit. */
static int next_line(ply_reader *r, char *buf, size_t size)
{
    if (r->cur >= r->end)
        return 0;
    const char *eol = memchr(r->cur, '\n', (size_t)(r->end - r->cur));
    size_t len = (size_t)((eol ? eol : r->end) - r->cur);
    if (len >= size)
        return -1;
    memcpy(buf, r->cur, len);
    buf[len] = 0;
    if (len && buf[len - 1] == '\r')
        buf[len - 1] = 0;
    r->cur = eol ? eol + 1 : r->end;
    return 1;
}

static int read_header(ply_reader *r)
{
    char line[1024];
    r->line = 1;
    if (next_line(r, line, sizeof line) != 1 || strcmp(line, "ply"))
        return header_fail(r, "not a PLY file (first line must be 'ply')");
    int format_seen = 0, done = 0;
    while (!done) {
        r->line++;
        int got = next_line(r, line, sizeof line);
        if (got == 0)
            return header_fail(r, "file ends inside the header (no 'end_header')");
        if (got < 0)
            return header_fail(r, "header line too long");
        if (!strncmp(line, "format", 6))
            format_seen = 1;
        if (parse_header_line(r, line, &done))
            return -1;
    }
    if (!format_seen)
        return header_fail(r, "missing 'format' line");
    return 0;
}

/* ---- body ------------------------------------------------------------ */

static int host_is_little_endian(void)
{
    const uint16_t one = 1;
    return *(const uint8_t *)&one == 1;
}

static double decode_binary(const unsigned char *bytes, int type, int swap)
{
    unsigned char b[8];
    int size = type_table[type].size;
    for (int i = 0; i < size; i++)
        b[i] = swap ? bytes[size - 1 - i] : bytes[i];
    switch (type) {
    case 0: { int8_t v; memcpy(&v, b, 1); return v; }
    case 1: { uint8_t v; memcpy(&v, b, 1); return v; }
    case 2: { int16_t v; memcpy(&v, b, 2); return v; }
    case 3: { uint16_t v; memcpy(&v, b, 2); return v; }
    case 4: { int32_t v; memcpy(&v, b, 4); return v; }
    case 5: { uint32_t v; memcpy(&v, b, 4); return v; }
    case 6: { float v; memcpy(&v, b, 4); return v; }
    default: { double v; memcpy(&v, b, 8); return v; }
    }
}

/* Reads one binary scalar; returns -1 at end of file. */
static int read_binary_value(ply_reader *r, int type, double *out)
{
    size_t size = (size_t)type_table[type].size;
    if ((size_t)(r->end - r->cur) < size)
        return -1;
    int swap = (r->format == PLY_LE) != host_is_little_endian();
    *out = decode_binary((const unsigned char *)r->cur, type, swap);
    r->cur += size;
    return 0;
}

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/* Reads the next number of the current ascii line (an instance is one line,
 * PLY 1.0); returns -1 at the end of the line, -2 if the token is not a
 * number (or longer than 511 characters, which no PLY writer makes). */
static int read_ascii_value(ply_reader *r, double *out)
{
    while (r->cur < r->end && is_blank(*r->cur))
        r->cur++;
    if (r->cur >= r->end || *r->cur == '\n')
        return -1;
    const char *tok = r->cur;
    while (r->cur < r->end && !is_blank(*r->cur) && *r->cur != '\n' && *r->cur)
        r->cur++;
    /* strtod needs a terminated string: the data need not have one after
     * its last token (ply_parse takes any buffer; fuzzing found the read
     * past its end). A token too long for the copy is no PLY number. */
    char word[512];
    size_t len = (size_t)(r->cur - tok);
    if (len >= sizeof word)
        return -2;
    memcpy(word, tok, len);
    word[len] = 0;
    char *stop;
    *out = strtod(word, &stop);
    return stop == word + len && len > 0 ? 0 : -2;
}

static int element_fail(ply_reader *r, const ply_element *e, size_t index, const char *what)
{
    if (r->format == PLY_ASCII)
        return rr_fail(r->err, "%s:%ld: %s %zu: %s", r->path, r->line, e->name, index, what);
    return rr_fail(r->err, "%s: %s %zu (byte offset %ld): %s", r->path, e->name, index,
                   (long)(r->cur - r->data), what);
}

/* Ends an ascii instance: nothing but blanks may follow on its line. */
static int end_ascii_line(ply_reader *r, const ply_element *e, size_t index, int values)
{
    while (r->cur < r->end && is_blank(*r->cur))
        r->cur++;
    if (r->cur < r->end && *r->cur != '\n') {
        char what[128];
        snprintf(what, sizeof what, "more values on the line than the %d its properties declare", values);
        return element_fail(r, e, index, what);
    }
    if (r->cur < r->end)
        r->cur++;
    return 0;
}

/* An ascii value must be one its declared integer type holds (2.5 for an
 * int or 300 for a uchar must not be taken as is); binary values always
 * are. */
static int check_ascii_int(ply_reader *r, const ply_element *e, size_t index, const ply_property *p, int type,
                           double v)
{
    double max = type_table[type].max, min = type_table[type].is_signed ? -max - 1 : 0;
    if (r->format != PLY_ASCII || !type_table[type].is_int || (v == floor(v) && v >= min && v <= max))
        return 0;
    char what[256];
    const char *t = type_table[type].name;
    snprintf(what, sizeof what, "property '%s' = %.17g: %.17g is not a%s %s (whole numbers %.0f to %.0f)", p->name, v,
             v, t[0] == 'i' ? "n" : "", t, min, max);
    return element_fail(r, e, index, what);
}

static int read_value(ply_reader *r, const ply_element *e, size_t index, int type, int nth, double *out)
{
    int rc = r->format == PLY_ASCII ? read_ascii_value(r, out) : read_binary_value(r, type, out);
    if (rc == -1 && r->format == PLY_ASCII && r->cur < r->end) { /* the line ended, not the file */
        char what[128];
        snprintf(what, sizeof what, "the line ends after %d values: a short or truncated line", nth);
        return element_fail(r, e, index, what);
    }
    if (rc == -1)
        return element_fail(r, e, index, "file is truncated (ends before all declared data)");
    if (rc == -2)
        return element_fail(r, e, index, "value is not a number");
    return 0;
}

/* Reads the properties of one element instance; slot values land in vals. */
static int read_instance(ply_reader *r, const ply_element *e, size_t index, double *vals)
{
    int nth = 0;
    for (int i = 0; i < e->nprops; i++) {
        const ply_property *p = &e->props[i];
        double v;
        if (p->list_count >= 0) {
            if (read_value(r, e, index, p->list_count, nth++, &v) || check_ascii_int(r, e, index, p, p->list_count, v))
                return -1;
            if (v < 0 || v > 1e6 || v != floor(v))
                return element_fail(r, e, index, "list length out of range");
            for (long k = 0; k < (long)v; k++) {
                double item;
                if (read_value(r, e, index, p->type, nth++, &item) || check_ascii_int(r, e, index, p, p->type, item))
                    return -1;
            }
            continue;
        }
        if (read_value(r, e, index, p->type, nth++, &v) || check_ascii_int(r, e, index, p, p->type, v))
            return -1;
        if (p->slot >= 0 && vals) {
            if (type_table[p->type].is_int && p->slot >= r->schema->scale_ints_from)
                v /= type_table[p->type].max;
            vals[p->slot] = v;
        }
    }
    return r->format == PLY_ASCII ? end_ascii_line(r, e, index, nth) : 0;
}

static int has_slots(const int *present, int first, int n)
{
    for (int s = first; s < first + n; s++)
        if (!present[s])
            return 0;
    return 1;
}

typedef struct {
    vec3 default_color;
    pointmodel *m;
    unsigned gaussian_properties; /* bit i: the header declares GAUSSIAN_MARKS[i] */
} surfel_sink;

/* Properties every trained 3DGS/2DGS PLY has (the official save_ply) and no
 * surfel file needs: a file with all three is a Gaussian-splat model. */
static const char *const GAUSSIAN_MARKS[] = {"scale_0", "rot_0", "opacity"};

static int note_gaussian_property(void *user, const char *path, long line, const char *name, rr_error *err)
{
    (void)path, (void)line, (void)err;
    surfel_sink *sink = user;
    for (size_t i = 0; i < sizeof GAUSSIAN_MARKS / sizeof *GAUSSIAN_MARKS; i++)
        if (!strcmp(name, GAUSSIAN_MARKS[i]))
            sink->gaussian_properties |= 1u << i;
    return 0;
}

/* Checks the vertex element declares what a splat needs. */
static int check_surfel_properties(void *user, const char *p, const int *present, size_t count, rr_error *err)
{
    const surfel_sink *sink = user;
    (void)count;
    if (!has_slots(present, SLOT_X, 3))
        return rr_fail(err, "%s: vertex element lacks one of the required properties x y z", p);
    int any_color = present[SLOT_R] || present[SLOT_G] || present[SLOT_B];
    if (any_color && !has_slots(present, SLOT_R, 3))
        return rr_fail(err, "%s: vertex color needs all of red green blue", p);
    int any_axis = 0;
    for (int s = SLOT_UX; s <= SLOT_VZ; s++)
        any_axis |= present[s];
    if (any_axis && !has_slots(present, SLOT_UX, 6))
        return rr_fail(err, "%s: elliptical splats need all of ux uy uz vx vy vz", p);
    if (any_axis)
        return 0;
    if (!present[SLOT_RADIUS] && sink->gaussian_properties == 7)
        return rr_fail(err, "%s: vertices have no splat size, but scale_0, rot_0 and opacity: this is a trained "
                            "Gaussian-splat model; name it with <gaussianModel file=\"...\"/>, not <pointModel>", p);
    if (!present[SLOT_RADIUS])
        return rr_fail(err, "%s: vertices have no splat size: add a 'radius' property "
                            "(with nx ny nz) or tangent axes 'ux uy uz vx vy vz'", p);
    if (!has_slots(present, SLOT_NX, 3))
        return rr_fail(err, "%s: circular splats ('radius') need normals nx ny nz", p);
    return 0;
}

/* The fewest bytes one instance can take: each scalar (and list count) at
 * its binary size, or in ascii one character and a separator. */
static size_t instance_min_bytes(const ply_reader *r, const ply_element *e)
{
    size_t s = 0;
    for (int i = 0; i < e->nprops; i++) {
        const ply_property *p = &e->props[i];
        s += r->format == PLY_ASCII ? 2 : (size_t)type_table[p->list_count >= 0 ? p->list_count : p->type].size;
    }
    return s;
}

/* Rejects a declared count that cannot fit the rest of the file before
 * reading or allocating anything for it (a count of 10^15 would otherwise
 * loop for days). */
static int check_element_size(ply_reader *r, const ply_element *e)
{
    size_t least = instance_min_bytes(r, e), remaining = (size_t)(r->end - r->cur) + 1;
    if (e->count > 0 && least == 0)
        return rr_fail(r->err, "%s: element '%s' declares %zu instances but no properties", r->path, e->name,
                       e->count);
    if (least && e->count > remaining / least)
        return rr_fail(r->err, "%s: header declares %zu '%s' elements (at least %zu bytes each) but only %zu "
                               "bytes remain: file truncated or count wrong",
                       r->path, e->count, e->name, least, remaining - 1);
    return 0;
}


static int add_surfel(void *user, const double *v, const int *present, char *why, size_t why_size)
{
    const surfel_sink *sink = user;
    for (int s = 0; s < SLOT_COUNT; s++)
        if (present[s] && !isfinite(v[s]))
            return snprintf(why, why_size, "NaN or infinite value"), -1;
    vec3 c = v3(v[SLOT_X], v[SLOT_Y], v[SLOT_Z]);
    vec3 n = present[SLOT_NX] ? v3(v[SLOT_NX], v[SLOT_NY], v[SLOT_NZ]) : v3(0, 0, 0);
    if (present[SLOT_NX] && v3_len(n) == 0)
        return snprintf(why, why_size, "zero-length normal"), -1;
    vec3 col = present[SLOT_R] ? v3(v[SLOT_R], v[SLOT_G], v[SLOT_B]) : sink->default_color;
    rr_error sub;
    int rc;
    if (present[SLOT_UX]) {
        rc = pointmodel_add(sink->m, c, v3(v[SLOT_UX], v[SLOT_UY], v[SLOT_UZ]),
                            v3(v[SLOT_VX], v[SLOT_VY], v[SLOT_VZ]), n, col, &sub);
    } else {
        if (!(v[SLOT_RADIUS] > 0))
            return snprintf(why, why_size, "%s", v[SLOT_RADIUS] < 0 ? "negative radius" : "zero radius"), -1;
        rc = pointmodel_add_circle(sink->m, c, n, v[SLOT_RADIUS], col, &sub);
    }
    if (rc)
        snprintf(why, why_size, "%s", sub.msg);
    return rc;
}

/* Which schema slots the vertex element declares. */
static void vertex_present(const ply_reader *r, const ply_element *e, int *present)
{
    memset(present, 0, (size_t)r->schema->count * sizeof *present);
    for (int i = 0; i < e->nprops; i++)
        if (e->props[i].slot >= 0)
            present[e->props[i].slot] = 1;
}

static int read_vertices(ply_reader *r, const ply_element *e, const ply_visitor *v)
{
    int present[PLY_MAX_SLOTS];
    vertex_present(r, e, present);
    if (v->begin(v->user, r->path, present, e->count, r->err) || check_element_size(r, e))
        return -1;
    for (size_t i = 0; i < e->count; i++) {
        double vals[PLY_MAX_SLOTS];
        memset(vals, 0, (size_t)r->schema->count * sizeof *vals); /* (only the schema's slots are read) */
        char why[512];
        if (i % 65536 == 0 && r->src && r->src->cancel && *r->src->cancel) /* millions of vertices take seconds */
            return rr_fail(r->err, "%s: interrupted while reading vertex %zu of %zu", r->path, i, e->count);
        if (i % 65536 == 0 && r->src) /* the file need not stay in memory beside the model */
            input_file_consume(r->src, (size_t)(r->cur - r->data));
        if (read_instance(r, e, i, vals))
            return -1;
        if (v->vertex(v->user, vals, present, why, sizeof why))
            return element_fail(r, e, i, why);
        r->line += r->format == PLY_ASCII; /* the next instance's line */
    }
    return 0;
}

/* Reads past an element that is not needed (faces, ...), checking it. */
static int skip_element(ply_reader *r, const ply_element *e)
{
    if (check_element_size(r, e))
        return -1;
    for (size_t i = 0; i < e->count; i++) {
        if (read_instance(r, e, i, NULL))
            return -1;
        r->line += r->format == PLY_ASCII;
    }
    return 0;
}

/* Every element is read, the ones after the vertices too, so that a binary
 * file's bytes beyond the declared elements are seen (two vertices' data
 * under 'element vertex 1' must not read as one vertex). */
static int read_elements(ply_reader *r, const ply_visitor *v)
{
    const ply_element *vertex = NULL;
    for (int k = 0; k < r->nelements; k++) {
        const ply_element *e = &r->elements[k];
        int vert = !strcmp(e->name, "vertex");
        vertex = vert ? e : vertex;
        if (vert ? read_vertices(r, e, v) : skip_element(r, e))
            return -1;
    }
    if (!vertex)
        return rr_fail(r->err, "%s: no 'vertex' element", r->path);
    if (r->format != PLY_ASCII && r->cur < r->end)
        return rr_fail(r->err, "%s: %zu bytes after the declared elements (%zu vertices): the header's counts are "
                               "wrong or other data follows", r->path, (size_t)(r->end - r->cur), vertex->count);
    return 0;
}

static int parse_vertices(const char *name, const char *data, size_t len, input_file *src, const ply_schema *schema,
                          const ply_visitor *v, rr_error *err)
{
    RR_CHECK(schema->count <= PLY_MAX_SLOTS);
    ply_reader *r = calloc(1, sizeof *r); /* 49 KB of property tables: not on the stack */
    if (!r)
        return rr_fail(err, "%s: out of memory", name);
    r->path = name;
    r->err = err;
    r->format = PLY_ASCII;
    r->data = r->cur = data;
    r->end = data + len;
    r->schema = schema;
    r->visitor = v;
    r->src = src;
    int rc = read_header(r);
    if (!rc) {
        r->line++; /* ascii body starts on the line after end_header */
        rc = read_elements(r, v);
    }
    free(r);
    return rc;
}

int ply_parse_vertices(const char *name, const char *data, size_t len, const ply_schema *schema,
                       const ply_visitor *v, rr_error *err)
{
    return parse_vertices(name, data, len, NULL, schema, v, err);
}

int ply_parse(const char *name, const char *data, size_t len, vec3 default_color, pointmodel *m, rr_error *err)
{
    surfel_sink sink = {default_color, m, 0};
    ply_visitor v = {check_surfel_properties, add_surfel, &sink, note_gaussian_property};
    return ply_parse_vertices(name, data, len, &surfel_schema, &v, err);
}

int ply_stream_vertices(const char *name, input_file *src, const ply_schema *schema, const ply_visitor *v,
                        rr_error *err)
{
    return parse_vertices(name, src->data, src->len, src, schema, v, err);
}

int ply_read_vertices(const char *path, const ply_schema *schema, const ply_visitor *v, uint64_t *content_hash,
                      volatile sig_atomic_t *cancel, rr_error *err)
{
    input_file in;
    if (input_file_stream(path, PLY_MAX_BYTES, &in, err))
        return -1;
    in.hash = content_hash ? *content_hash : INPUT_HASH_INIT;
    in.cancel = cancel;
    int rc = ply_stream_vertices(path, &in, schema, v, err);
    if (content_hash)
        *content_hash = input_file_hash(&in);
    input_file_free(&in);
    return rc;
}

int ply_read(const char *path, vec3 default_color, pointmodel *m, uint64_t *content_hash, volatile sig_atomic_t *cancel,
             rr_error *err)
{
    surfel_sink sink = {default_color, m, 0};
    ply_visitor v = {check_surfel_properties, add_surfel, &sink, note_gaussian_property};
    return ply_read_vertices(path, &surfel_schema, &v, content_hash, cancel, err);
}

/* ---- writer ---------------------------------------------------------- */

/* Returns 1 when written. */
static int put_f32le(FILE *f, double v)
{
    float x = (float)v;
    unsigned char b[4];
    memcpy(b, &x, 4);
    if (!host_is_little_endian()) {
        unsigned char t = b[0]; b[0] = b[3]; b[3] = t;
        t = b[1]; b[1] = b[2]; b[2] = t;
    }
    return fwrite(b, 4, 1, f) == 1;
}

static unsigned char to_u8(double c)
{
    c = c < 0 ? 0 : (c > 1 ? 1 : c);
    return (unsigned char)lrint(c * 255.0);
}

/* Returns 1 when every byte was written. */
static int write_surfels(FILE *f, const surfel *s, size_t n)
{
    int ok = fprintf(f, "ply\nformat binary_little_endian 1.0\ncomment written by refrender %s\n"
                        "element vertex %zu\n", RR_VERSION, n) > 0;
    ok = ok && fputs("property float x\nproperty float y\nproperty float z\nproperty float nx\n"
                     "property float ny\nproperty float nz\nproperty float radius\n"
                     "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n", f) >= 0;
    for (size_t i = 0; i < n && ok; i++) {
        const surfel *p = &s[i];
        double vals[7] = {p->center.x, p->center.y, p->center.z, p->normal.x, p->normal.y,
                          p->normal.z, p->radius};
        for (int k = 0; k < 7; k++)
            ok = ok && put_f32le(f, vals[k]);
        unsigned char rgb[3] = {to_u8(p->color.x), to_u8(p->color.y), to_u8(p->color.z)};
        ok = ok && fwrite(rgb, 3, 1, f) == 1;
    }
    return ok && !ferror(f);
}

/* Refuses what would not read back as the same splats: none at all, or
 * values a float cannot hold (inf after the conversion). */
static int check_surfels(const char *path, const surfel *s, size_t n, rr_error *err)
{
    if (n == 0)
        return rr_fail(err, "%s: no splats to write", path);
    for (size_t i = 0; i < n; i++) {
        const surfel *p = &s[i];
        double vals[7] = {p->center.x, p->center.y, p->center.z, p->normal.x, p->normal.y, p->normal.z, p->radius};
        for (int k = 0; k < 7; k++)
            if (!(fabs(vals[k]) <= RR_MAX_REACH))
                return rr_fail(err, "%s: splat %zu has a value %g out of range (at most %g in magnitude)", path, i,
                               vals[k], RR_MAX_REACH);
        if (!(p->radius > 0) || v3_len(p->normal) == 0)
            return rr_fail(err, "%s: splat %zu has a zero radius or normal", path, i);
    }
    return 0;
}

typedef struct {
    const char *path;
    const surfel *s;
    size_t n;
} surfel_list;

static int write_surfel_list(FILE *f, void *ctx, rr_error *err)
{
    const surfel_list *l = ctx;
    return write_surfels(f, l->s, l->n) ? 0 : rr_fail(err, "%s: write failed (disk full?)", l->path);
}

int ply_write_surfels(const char *path, const surfel *s, size_t n, rr_error *err)
{
    surfel_list l = {path, s, n};
    if (check_surfels(path, s, n, err))
        return -1;
    return atomic_write_stdio(path, write_surfel_list, &l, err);
}
