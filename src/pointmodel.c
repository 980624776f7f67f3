#include "pointmodel.h"

#include <stdlib.h>

void pointmodel_init(pointmodel *m)
{
    m->count = m->capacity = 0;
    m->geom = NULL;
    m->shading = m->extent = NULL;
    m->bounds = aabb_empty();
}

void pointmodel_free(pointmodel *m)
{
    free(m->geom);
    free(m->shading);
    free(m->extent);
    pointmodel_init(m);
}

static int grow(pointmodel *m, rr_error *err)
{
    size_t cap = m->capacity ? 2 * m->capacity : 256;
    splat_geom *g = realloc(m->geom, cap * sizeof *g);
    if (g)
        m->geom = g;
    float *sh = realloc(m->shading, cap * 6 * sizeof *sh);
    if (sh)
        m->shading = sh;
    float *e = realloc(m->extent, cap * 3 * sizeof *e);
    if (e)
        m->extent = e;
    if (!g || !sh || !e)
        return rr_fail(err, "out of memory for %zu splats", cap);
    m->capacity = cap;
    return 0;
}

int pointmodel_add(pointmodel *m, vec3 c, vec3 u, vec3 v, vec3 n, vec3 color, rr_error *err)
{
    if (!v3_finite(c) || !v3_finite(u) || !v3_finite(v) || !v3_finite(n) || !v3_finite(color))
        return rr_fail(err, "splat has a NaN or infinite value");
    if (m->count == m->capacity && grow(m, err))
        return -1;
    splat_geom *g = &m->geom[m->count];
    if (splat_geom_init(g, c, u, v))
        return rr_fail(err, "splat axes are zero or parallel (degenerate ellipse)");
    if (v3_len(n) == 0)
        n = v3_cross(u, v);
    n = v3_normalize(n);
    float *dn = &m->shading[6 * m->count], *dc = dn + 3;
    dn[0] = (float)n.x, dn[1] = (float)n.y, dn[2] = (float)n.z;
    dc[0] = (float)color.x, dc[1] = (float)color.y, dc[2] = (float)color.z;
    aabb box = splat_bounds(c, u, v);
    float *de = &m->extent[3 * m->count];
    de[0] = (float)(box.hi.x - c.x), de[1] = (float)(box.hi.y - c.y), de[2] = (float)(box.hi.z - c.z);
    aabb_add_box(&m->bounds, box);
    m->count++;
    return 0;
}

int pointmodel_add_circle(pointmodel *m, vec3 c, vec3 n, double radius, vec3 color, rr_error *err)
{
    if (!(radius > 0) || !isfinite(radius))
        return rr_fail(err, "splat radius must be positive and finite, got %g", radius);
    if (!v3_finite(n) || v3_len(n) == 0)
        return rr_fail(err, "splat normal is zero or not finite");
    vec3 u, v;
    splat_axes_from_normal(n, radius, &u, &v);
    return pointmodel_add(m, c, u, v, n, color, err);
}
