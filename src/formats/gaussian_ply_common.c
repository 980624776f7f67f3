/* What the Gaussian PLY readers share (gaussian_ply_common.h). */
#include "formats/gaussian_ply_common.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

long gaussian_ply_numbered(const char *name, const char *prefix)
{
    size_t n = strlen(prefix);
    if (strncmp(name, prefix, n) || name[n] < '0' || name[n] > '9')
        return -1;
    char *end;
    long k = strtol(name + n, &end, 10);
    return *end ? -1 : k;
}

int gaussian_ply_bad(char *why, size_t size, const char *fmt, const char *name, double value)
{
    snprintf(why, size, fmt, name, value);
    return -1;
}

int gaussian_ply_store(float *dst, double v, const char *name, char *why, size_t why_size)
{
    *dst = (float)v;
    return isfinite(*dst) ? 0 : gaussian_ply_bad(why, why_size, "property '%s' = %g is beyond float range (3.4e38)",
                                                 name, v);
}

int gaussian_ply_check_finite(const double *v, const int *present, const char *const *names, int slots, char *why,
                              size_t why_size)
{
    for (int k = 0; k < slots; k++)
        if (present[k] && !isfinite(v[k]))
            return gaussian_ply_bad(why, why_size, "property '%s' is %g", names[k], v[k]);
    return 0;
}

void gaussian_ply_list_missing(char *missing, size_t size, const int *present, const char *const *names, int first,
                               int end)
{
    for (int k = first; k < end; k++)
        if (!present[k])
            snprintf(missing + strlen(missing), size - strlen(missing), " '%s'", names[k]);
}

int gaussian_ply_begin_3d(gaussian_ply_sink *s, const char *path, const char *layout, size_t count, rr_error *err)
{
    if (s->forced == GAUSSIAN_2D)
        return rr_fail(err, "%s: a %s model is 3D (scale_0..2): kind 2dgs cannot read it", path, layout);
    s->m->kind = GAUSSIAN_3D;
    s->declared = count, s->next = 0;
    return 0;
}

int gaussian_ply_allocate(gaussian_model *m, size_t declared, gaussian_dynamic *(*dynamic_alloc)(size_t), char *why,
                          size_t why_size)
{
    size_t n = declared ? declared : 1;
    if (gaussian_model_alloc(m, n) || (dynamic_alloc && !(m->dynamic = dynamic_alloc(n))))
        return snprintf(why, why_size, "out of memory for %zu Gaussians", declared), -1;
    return 0;
}

int gaussian_ply_store_mean_scale(gaussian_model *m, size_t i, const double *v, const char *const *names, int x,
                                  int scale, int scales, char *why, size_t why_size)
{
    for (int k = 0; k < 3; k++) {
        if (!(fabs(v[x + k]) <= RR_MAX_REACH))
            return snprintf(why, why_size, "property '%s' = %g is beyond %g (RR_MAX_REACH) from the origin, where "
                            "rays can be traced", names[x + k], v[x + k], RR_MAX_REACH), -1;
        double e = k < scales ? exp(v[scale + k]) : 0.0;
        if (!(e <= RR_MAX_REACH))
            return snprintf(why, why_size, "property '%s' = %g: exp() of it is beyond %g (RR_MAX_REACH)",
                            names[scale + k], v[scale + k], RR_MAX_REACH), -1;
        m->mean[3 * i + k] = (float)v[x + k];
        m->scale[3 * i + k] = (float)e;
    }
    return 0;
}

int gaussian_ply_unit_quaternion(const double *rot, float *q, char *why, size_t why_size)
{
    double big = 0, u[4], len2 = 0;
    for (int k = 0; k < 4; k++)
        big = fmax(big, fabs(rot[k]));
    if (!(big > 0))
        return snprintf(why, why_size, "zero-length quaternion (rot_0..rot_3)"), -1;
    for (int k = 0; k < 4; k++)
        u[k] = rot[k] / big, len2 += u[k] * u[k];
    for (int k = 0; k < 4; k++)
        q[k] = (float)(u[k] / sqrt(len2));
    return 0;
}

int gaussian_ply_finish(gaussian_model *m, int rc, const char *name, rr_error *err)
{
    if (!rc && m->count == 0)
        rc = rr_fail(err, "%s: the model has no Gaussians", name);
    if (rc)
        gaussian_model_free(m);
    return rc;
}

int gaussian_ply_load_layout(const char *name, const char *data, size_t len, input_file *src,
                             const ply_schema *schema, const ply_visitor *v, gaussian_model *m, rr_error *err)
{
    gaussian_model_free(m);
    int rc = src ? ply_stream_vertices(name, src, schema, v, err) : ply_parse_vertices(name, data, len, schema, v, err);
    return gaussian_ply_finish(m, rc, name, err);
}
