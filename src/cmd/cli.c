#include "cmd/cli.h"

#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

int cli_int(const char *opt, const char *text, long lo, long hi, int *out, rr_error *err)
{
    char *end;
    errno = 0;
    long v = strtol(text, &end, 10);
    if (errno || end == text || *end || v < lo || v > hi)
        return rr_fail(err, "%s: expected an integer in [%ld, %ld], got '%s'", opt, lo, hi, text);
    *out = (int)v;
    return 0;
}

int cli_u64(const char *opt, const char *text, uint64_t *out, rr_error *err)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno || end == text || *end || text[0] == '-')
        return rr_fail(err, "%s: expected a non-negative integer, got '%s'", opt, text);
    *out = (uint64_t)v;
    return 0;
}

int cli_double(const char *opt, const char *text, double lo, double *out, rr_error *err)
{
    char *end;
    double v = strtod(text, &end);
    if (end == text || *end || !isfinite(v) || v < lo)
        return isinf(lo) ? rr_fail(err, "%s: expected a finite number, got '%s'", opt, text)
                         : rr_fail(err, "%s: expected a finite number >= %g, got '%s'", opt, lo, text);
    *out = v;
    return 0;
}

int cli_resolution(const char *opt, const char *text, int *w, int *h, rr_error *err)
{
    int a, b;
    char extra;
    if (sscanf(text, "%dx%d%c", &a, &b, &extra) != 2 || a < 1 || b < 1 || a > 65536 || b > 65536)
        return rr_fail(err, "%s: expected WIDTHxHEIGHT (e.g. 640x480), got '%s'", opt, text);
    *w = a;
    *h = b;
    return 0;
}

int cli_vec3(const char *opt, const char *text, vec3 *out, rr_error *err)
{
    double a, b, c;
    char extra;
    if (sscanf(text, "%lf %lf %lf %c", &a, &b, &c, &extra) != 3 || !isfinite(a + b + c))
        return rr_fail(err, "%s: expected three numbers like \"0.8 0.2 0.1\", got '%s'", opt, text);
    *out = v3(a, b, c);
    return 0;
}

int cli_check_writable(const char *option, const char *path, rr_error *err)
{
    struct stat st;
    if (strlen(path) > PATH_MAX - 64)
        return rr_fail(err, "%.200s...: path is too long (%zu characters, at most %d)", path, strlen(path),
                       PATH_MAX - 64);
    if (!*path)
        return rr_fail(err, "%s: the file name is empty", option);
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return rr_fail(err, "%s %s: is a directory, not a file name", option, path);
    /* outputs are renamed into place: a FIFO, a device (/dev/null, /dev/stdout)
     * or a socket would be replaced by a regular file, for every program */
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode))
        return rr_fail(err, "%s %s: is not a regular file (a device, FIFO or socket): outputs are written to a "
                            "temporary file and renamed into place, which would replace it", option, path);
    char probe[PATH_MAX + 64];
    snprintf(probe, sizeof probe, "%s.probe-XXXXXX", path);
    int fd = mkstemp(probe);
    if (fd < 0)
        return rr_fail(err, "%s %s: cannot create files there: %s", option, path, strerror(errno));
    close(fd);
    unlink(probe);
    return 0;
}

int cli_check_exr_name(const char *opt, const char *path, int has_preview, rr_error *err)
{
    const char *dot = rr_extension(path), *ext = *dot ? dot + 1 : dot;
    if (!*ext || !strcasecmp(ext, "exr"))
        return 0;
    int stem = (int)(dot - path);
    /* "out.exr.png": the EXR is out.exr (not out.exr.exr), the preview out.png */
    if (stem > 4 && !strncasecmp(dot - 4, ".exr", 4) && dot[-5] != '/')
        stem -= 4;
    if (!has_preview)
        return rr_fail(err, "%s %s: refrender writes OpenEXR only, not .%s: use %s %.*s.exr", opt, path, ext, opt,
                       stem, path);
    return rr_fail(err, "%s %s: refrender writes OpenEXR only, not .%s: use %s %.*s.exr, and --preview %.*s.png for "
                        "an 8-bit sRGB preview beside it", opt, path, ext, opt, stem, path, stem, path);
}

/* The absolute name path has or would have: the real path of its directory
 * (which exists: outputs are checked writable first) and its base name. */
static int canonical_name(const char *path, char *out, size_t size)
{
    char dir[PATH_MAX], real[PATH_MAX];
    const char *slash = strrchr(path, '/'), *base = slash ? slash + 1 : path;
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) + (slash == path) : 1, slash ? path : ".");
    if (!realpath(dir, real))
        return -1;
    return snprintf(out, size, "%s/%s", real, base) < (int)size ? 0 : -1;
}

int cli_same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char ca[2 * PATH_MAX], cb[2 * PATH_MAX];
    if (canonical_name(a, ca, sizeof ca) || canonical_name(b, cb, sizeof cb))
        return !strcmp(a, b);
    return !strcmp(ca, cb);
}

int cli_shutter(const char *arg, double *open, double *close, rr_error *err)
{
    char extra;
    if (sscanf(arg, "%lf,%lf%c", open, close, &extra) != 2 || !isfinite(*open) || !isfinite(*close) ||
        !(*close > *open))
        return rr_fail(err, "--shutter: expected OPEN,CLOSE with OPEN < CLOSE, got '%s'", arg);
    return 0;
}

int cli_refuse_overwriting_inputs(const char *output, char *const *inputs, int n, rr_error *err)
{
    for (int i = 0; i < n; i++)
        if (cli_same_file(output, inputs[i]))
            return rr_fail(err, "output %s is the input %s: refusing to overwrite it", output, inputs[i]);
    return 0;
}

/* Finds the one frame-number field "%d", "%4d" or "%04d" (width < 100). */
static int frame_field(const char *pattern, const char **start, const char **end, int *zero, int *width)
{
    const char *p = strchr(pattern, '%');
    if (!p || strchr(p + 1, '%'))
        return 0;
    const char *q = p + 1;
    *zero = *q == '0';
    q += *zero;
    *width = 0;
    for (int digits = 0; isdigit((unsigned char)*q); q++, digits++) {
        if (digits == 2)
            return 0;
        *width = *width * 10 + (*q - '0');
    }
    if (*q != 'd')
        return 0;
    *start = p, *end = q + 1;
    return 1;
}

int cli_frame_pattern_ok(const char *pattern)
{
    const char *a, *b;
    int zero, width;
    return frame_field(pattern, &a, &b, &zero, &width);
}

void cli_frame_path(const char *pattern, int frame, char *out, size_t size)
{
    const char *a, *b;
    int zero, width;
    if (!frame_field(pattern, &a, &b, &zero, &width)) {
        snprintf(out, size, "%s", pattern);
        return;
    }
    snprintf(out, size, zero ? "%.*s%0*d%s" : "%.*s%*d%s", (int)(a - pattern), pattern, width, frame, b);
}

void cli_suggest_option(const char *prog, const char *arg, const struct option *longopts)
{
    enum { MAX_OPTIONS = 64 };
    const char *names[MAX_OPTIONS + 1];
    char word[64];
    int n = 0;
    if (!arg || strncmp(arg, "--", 2) || snprintf(word, sizeof word, "%.*s", (int)strcspn(arg + 2, "="), arg + 2) >=
                                             (int)sizeof word)
        return;
    for (const struct option *o = longopts; o->name && n < MAX_OPTIONS; o++) {
        if (!strncmp(o->name, word, strlen(word)))
            return; /* the option itself, or an abbreviation of it */
        names[n++] = o->name;
    }
    names[n] = NULL;
    const char *near = rr_nearest_name(word, names);
    if (near)
        fprintf(stderr, "%s: did you mean '--%s'?\n", prog, near);
}

#ifndef RR_SOURCE_DIR
#define RR_SOURCE_DIR "."
#endif

const char *cli_tree_file(const char *rel, char *buf, size_t size)
{
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = 0;
        char *slash = strrchr(exe, '/');
        if (slash) {
            *slash = 0;
            snprintf(buf, size, "%s/../%s", exe, rel);
            if (access(buf, R_OK) == 0)
                return buf;
        }
    }
    snprintf(buf, size, "%s/%s", RR_SOURCE_DIR, rel);
    return buf;
}
