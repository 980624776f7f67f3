/* See gaussian_test_util.h. */
#include "gaussian_test_util.h"

#include <stdio.h>
#include <string.h>

static int kept(const char *name, const char *skip)
{
    return !skip || strcmp(skip, name);
}

size_t ply_ascii_header(char *buf, size_t size, int n, const char *const *names, int count, const char *skip,
                        const char *extra)
{
    size_t len = (size_t)snprintf(buf, size, "ply\nformat ascii 1.0\nelement vertex %d\n", n);
    for (int k = 0; k < count; k++)
        if (kept(names[k], skip))
            len += (size_t)snprintf(buf + len, size - len, "property float %s\n", names[k]);
    if (extra)
        len += (size_t)snprintf(buf + len, size - len, "property float %s\n", extra);
    return len + (size_t)snprintf(buf + len, size - len, "end_header\n");
}

size_t ply_ascii_row(char *buf, size_t size, size_t len, const char *const *names, const double *values, int count,
                     int digits, const char *skip, const char *extra)
{
    for (int k = 0; k < count; k++)
        if (kept(names[k], skip))
            len += (size_t)snprintf(buf + len, size - len, "%.*g ", digits, values[k]);
    return len + (size_t)snprintf(buf + len, size - len, extra ? "0\n" : "\n");
}

int parse_gaussian_text(const char *name, const char *buf, size_t len, gaussian_model *m, rr_error *e)
{
    gaussian_model_init(m);
    return gaussian_parse(name, buf, len, GAUSSIAN_AUTO, m, e);
}

int gaussian_text_refused(const char *name, const char *buf, size_t len, gaussian_kind kind, const char *needle)
{
    gaussian_model m;
    rr_error e = {{0}};
    gaussian_model_init(&m);
    int ok = gaussian_parse(name, buf, len, kind, &m, &e) == -1 && strstr(e.msg, name) && strstr(e.msg, needle) &&
             !m.mean && !m.dynamic;
    if (!ok)
        printf("    expected an error with '%s', got '%s'\n", needle, e.msg);
    return ok;
}

double lcg_uniform(uint64_t *s, double lo, double hi)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return lo + (hi - lo) * (double)(*s >> 11) / 9007199254740992.0;
}
