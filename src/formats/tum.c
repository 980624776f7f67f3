#include "formats/tum.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "core/inputfile.h"
#include "core/rotation.h"

/* ---- the TUM reader -------------------------------------------------------- */

static const char *const TUM_FIELDS[8] = {"t", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};

/* Up to n bytes of s for a message, quoted: printable ASCII as it is,
 * any other byte as \xHH (a byte order mark or a stray control byte is
 * otherwise invisible in the message), "..." where it is cut. */
static const char *quoted(const char *s, size_t n, char out[96])
{
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        unsigned char b = (unsigned char)s[i];
        if (k + 8 >= 96) { /* room for one escape and the "..." */
            memcpy(out + k, "...", 4);
            return out;
        }
        k += (size_t)snprintf(out + k, 96 - k, b >= 0x20 && b < 0x7f ? "%c" : "\\x%02x", b);
    }
    out[k] = 0;
    return out;
}

static int tum_space(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/* One line's fields into v; line is NUL-free and ends at end. */
static int tum_fields(const char *line, const char *end, const char *name, long lineno, double v[8], rr_error *err)
{
    const char *s = line;
    char q[96];
    for (int f = 0; f < 8; f++) {
        while (s < end && tum_space(*s))
            s++;
        if (s == end)
            return rr_fail(err, "%s:%ld: field '%s' is missing (a TUM line is t tx ty tz qx qy qz qw)", name, lineno,
                           TUM_FIELDS[f]);
        char buf[64], *stop;
        size_t n = 0;
        while (s + n < end && !tum_space(s[n]))
            n++;
        if (n >= sizeof buf)
            return rr_fail(err, "%s:%ld: field '%s' is not a number ('%s...')", name, lineno, TUM_FIELDS[f],
                           quoted(s, 20, q));
        memcpy(buf, s, n), buf[n] = 0;
        errno = 0;
        v[f] = strtod(buf, &stop);
        if (*stop || stop == buf || !isfinite(v[f]))
            return rr_fail(err, "%s:%ld: field '%s' is not a finite number ('%s')", name, lineno, TUM_FIELDS[f],
                           quoted(buf, n, q));
        s += n;
    }
    while (s < end && tum_space(*s))
        s++;
    if (s != end)
        return rr_fail(err, "%s:%ld: more than the 8 fields t tx ty tz qx qy qz qw ('%s')", name, lineno,
                       quoted(s, (size_t)(end - s < 20 ? end - s : 20), q));
    return 0;
}

/* The knot of one line's values; a quaternion within 1e-14 of unit length
 * is kept as written, so that a file this program wrote reads back bit for
 * bit; one off by up to 1e-3 (written with few digits) is normalised. */
static int tum_knot(const double v[8], const char *name, long lineno, trajectory_knot *k, rr_error *err)
{
    k->t = v[0];
    k->p = v3(v[1] + 0.0, v[2] + 0.0, v[3] + 0.0); /* +0 for -0, as export writes them (export_cmd.c) */
    double q[4] = {v[7], v[4], v[5], v[6]};
    double n = quat_norm(q);
    if (!(n > 0) || !isfinite(n))
        return rr_fail(err, "%s:%ld: the quaternion (qx qy qz qw) = (%g %g %g %g) has no direction", name, lineno,
                       v[4], v[5], v[6], v[7]);
    if (fabs(n - 1.0) > 1e-3)
        return rr_fail(err, "%s:%ld: the quaternion (qx qy qz qw) has length %.9g, not 1: is this a TUM pose?", name,
                       lineno, n);
    double s = fabs(n - 1.0) > 1e-14 ? 1.0 / n : 1.0;
    for (int i = 0; i < 4; i++)
        k->q[i] = q[i] * s + 0.0;
    for (int i = 1; i <= 3; i++) /* the renderer traces no farther (accel.h), and Log/Exp stay finite */
        if (!(fabs(v[i]) <= RR_MAX_REACH))
            return rr_fail(err, "%s:%ld: field '%s' is %g, beyond the %g a position may reach", name, lineno,
                           TUM_FIELDS[i], v[i], RR_MAX_REACH);
    return 0;
}

static int add_knot(trajectory *out, size_t *cap, const trajectory_knot *k, const char *name, long lineno,
                    rr_error *err)
{
    if (out->count && !(k->t > out->knots[out->count - 1].t))
        return rr_fail(err, "%s:%ld: time %.17g does not follow the previous line's %.17g (times must increase)",
                       name, lineno, k->t, out->knots[out->count - 1].t);
    if (out->count && !isfinite(k->t - out->knots[0].t))
        return rr_fail(err, "%s:%ld: time %.17g is too far from the first line's %.17g (their difference overflows)",
                       name, lineno, k->t, out->knots[0].t);
    size_t need = (size_t)out->count + 1, knots_cap = *cap, lines_cap = *cap; /* one capacity for both */
    if (need > (1 << 24) || rr_grow((void **)&out->knots, &knots_cap, need, sizeof *out->knots) ||
        rr_grow((void **)&out->lines, &lines_cap, need, sizeof *out->lines))
        return rr_fail(err, "%s:%ld: out of memory (more than %zu poses?)", name, lineno, *cap);
    *cap = knots_cap;
    out->lines[out->count] = lineno;
    out->knots[out->count++] = *k;
    return 0;
}

static int blank_or_comment(const char *s, const char *end)
{
    while (s < end && tum_space(*s))
        s++;
    return s == end || *s == '#';
}

int tum_parse(const char *text, size_t len, const char *name, trajectory *out, rr_error *err)
{
    size_t cap = 0;
    out->knots = NULL, out->lines = NULL, out->count = 0, out->name = NULL;
    const char *s = text, *end = text + len;
    if (memchr(text, 0, len))
        return rr_fail(err, "%s: contains a NUL byte: not a TUM text file", name);
    if (len >= 3 && !memcmp(text, "\xEF\xBB\xBF", 3)) /* a UTF-8 byte order mark, as Windows editors write */
        s += 3;
    for (long lineno = 1; s < end; lineno++) {
        const char *nl = memchr(s, '\n', (size_t)(end - s)), *eol = nl ? nl : end;
        if (!blank_or_comment(s, eol)) {
            double v[8];
            trajectory_knot k;
            if (tum_fields(s, eol, name, lineno, v, err) || tum_knot(v, name, lineno, &k, err) ||
                add_knot(out, &cap, &k, name, lineno, err)) {
                trajectory_free(out);
                return -1;
            }
        }
        s = nl ? nl + 1 : end;
    }
    return 0;
}

int tum_load(const char *path, trajectory *out, uint64_t *content_hash, rr_error *err)
{
    input_file in;
    if (input_file_read(path, TUM_MAX_BYTES, &in, err))
        return -1;
    int rc = tum_parse(in.data, in.len, path, out, err);
    if (!rc && !(out->name = strdup(path)))
        rc = rr_fail(err, "out of memory"), trajectory_free(out);
    if (!rc && content_hash)
        *content_hash = input_hash(*content_hash, in.data, in.len);
    input_file_free(&in);
    return rc;
}

/* ---- the TUM writer -------------------------------------------------------- */

void tum_write_line(FILE *f, double t, vec3 p, const double q[4], int opengl_axes)
{
    double w[4];
    trajectory_quat_to_axes(q, w, opengl_axes);
    for (int i = 0; i < 4; i++) /* +0 for -0: the reader keeps none (tum_knot) */
        w[i] += 0.0;
    fprintf(f, "%.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", t, p.x, p.y, p.z, w[1], w[2], w[3], w[0]);
}

