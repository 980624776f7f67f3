#include "surfels/pointmodel.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

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

/* Room for one more splat in the three arrays, which share one capacity. */
static int grow(pointmodel *m, rr_error *err)
{
    size_t need = m->count + 1, geom_cap = m->capacity, shading_cap = m->capacity, extent_cap = m->capacity;
    if (rr_grow((void **)&m->geom, &geom_cap, need, sizeof *m->geom) ||
        rr_grow((void **)&m->shading, &shading_cap, need, 6 * sizeof *m->shading) ||
        rr_grow((void **)&m->extent, &extent_cap, need, 3 * sizeof *m->extent))
        return rr_fail(err, "out of memory for %zu splats", need);
    m->capacity = geom_cap;
    return 0;
}

static double largest_abs(vec3 a) { return fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z))); }

int pointmodel_add(pointmodel *m, vec3 c, vec3 u, vec3 v, vec3 n, vec3 color, rr_error *err)
{
    if (!v3_finite(c) || !v3_finite(u) || !v3_finite(v) || !v3_finite(n) || !v3_finite(color))
        return rr_fail(err, "splat has a NaN or infinite value");
    double big = fmax(fmax(largest_abs(c), largest_abs(u)), fmax(largest_abs(v), largest_abs(color)));
    if (big > RR_MAX_REACH || largest_abs(n) > RR_MAX_REACH)
        return rr_fail(err, "splat value %g is out of range (at most %g in magnitude)",
                       fmax(big, largest_abs(n)), RR_MAX_REACH);
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
    if (!(radius > 0) || !(radius <= RR_MAX_REACH))
        return rr_fail(err, "splat radius must be positive and at most %g, got %g", RR_MAX_REACH, radius);
    if (!v3_finite(n) || v3_len(n) == 0)
        return rr_fail(err, "splat normal is zero or not finite");
    vec3 u, v;
    splat_axes_from_normal(n, radius, &u, &v);
    return pointmodel_add(m, c, u, v, n, color, err);
}

/* ---- spatial order ------------------------------------------------------- */

/* The low 21 bits of v spread to every third bit (for a 63-bit Morton code). */
static uint64_t spread_bits3(uint64_t v)
{
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

typedef struct {
    uint64_t code;
    size_t index;
} morton_key;

static int cmp_morton_key(const void *a, const void *b)
{
    const morton_key *x = a, *y = b;
    if (x->code != y->code)
        return x->code < y->code ? -1 : 1;
    return (x->index > y->index) - (x->index < y->index); /* unique keys: a deterministic order */
}

/* Splat centers on a 2^21 grid over the model's bounds (cubic cells). */
static morton_key *morton_keys(const pointmodel *m)
{
    morton_key *k = malloc(m->count * sizeof *k);
    if (!k)
        return NULL;
    vec3 lo = m->bounds.lo, size = v3_sub(m->bounds.hi, m->bounds.lo);
    double extent = fmax(size.x, fmax(size.y, size.z)), scale = extent > 0 ? 2097151.0 / extent : 0.0;
    for (size_t i = 0; i < m->count; i++) {
        const float *c = m->geom[i].center;
        uint64_t q[3];
        for (int a = 0; a < 3; a++) {
            double f = (c[a] - (&lo.x)[a]) * scale;
            q[a] = f <= 0 ? 0 : f >= 2097151.0 ? 2097151 : (uint64_t)f;
        }
        k[i] = (morton_key){spread_bits3(q[0]) | spread_bits3(q[1]) << 1 | spread_bits3(q[2]) << 2, i};
    }
    qsort(k, m->count, sizeof *k, cmp_morton_key);
    return k;
}

/* Reorders n items of `size` bytes: item i becomes old item order[i]. */
static int permute(void *items, size_t n, size_t size, const morton_key *order)
{
    char *copy = malloc(n * size);
    if (!copy)
        return -1;
    memcpy(copy, items, n * size);
    for (size_t i = 0; i < n; i++)
        memcpy((char *)items + i * size, copy + order[i].index * size, size);
    free(copy);
    return 0;
}

int pointmodel_sort_spatially(pointmodel *m, size_t **order_out, rr_error *err)
{
    if (order_out)
        *order_out = NULL;
    if (m->count == 0)
        return 0;
    morton_key *k = morton_keys(m);
    size_t *order = order_out ? malloc(m->count * sizeof *order) : NULL;
    if (!k || (order_out && !order) || permute(m->geom, m->count, sizeof *m->geom, k) ||
        permute(m->shading, m->count, 6 * sizeof *m->shading, k) ||
        permute(m->extent, m->count, 3 * sizeof *m->extent, k)) {
        free(k);
        free(order);
        return rr_fail(err, "out of memory sorting %zu splats", m->count);
    }
    for (size_t i = 0; order && i < m->count; i++)
        order[i] = k[i].index;
    if (order_out)
        *order_out = order;
    free(k);
    return 0;
}
