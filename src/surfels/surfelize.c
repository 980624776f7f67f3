#include "surfels/surfelize.h"

#include <stdlib.h>

static vec3 at(const double *a, size_t i) { return v3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }

int surfels_from_mesh(const double *pos, const double *nrm, size_t nv, const unsigned *tri, size_t nt,
                      double overlap, surfel **out, size_t *n, rr_error *err)
{
    double *area = calloc(nv ? nv : 1, sizeof *area);
    surfel *s = malloc((nv ? nv : 1) * sizeof *s);
    if (!area || !s) {
        free(area), free(s);
        return rr_fail(err, "out of memory for %zu vertices", nv);
    }
    for (size_t t = 0; t < nt; t++) {
        const unsigned *v = &tri[3 * t];
        if (v[0] >= nv || v[1] >= nv || v[2] >= nv) {
            free(area), free(s);
            return rr_fail(err, "triangle %zu refers to a vertex beyond the %zu given", t, nv);
        }
        vec3 a = at(pos, v[0]), e1 = v3_sub(at(pos, v[1]), a), e2 = v3_sub(at(pos, v[2]), a);
        double third = 0.5 * v3_len(v3_cross(e1, e2)) / 3.0;
        for (int k = 0; k < 3; k++)
            area[v[k]] += third;
    }
    size_t m = 0;
    for (size_t i = 0; i < nv; i++) {
        vec3 normal = at(nrm, i);
        if (!(area[i] > 0) || !(v3_len(normal) > 0))
            continue; /* unreferenced, degenerate or without a normal */
        s[m].center = at(pos, i);
        s[m].normal = v3_normalize(normal);
        s[m].radius = overlap * sqrt(area[i] / M_PI);
        s[m].color = rr_default_color();
        m++;
    }
    free(area);
    if (!m) {
        free(s);
        return rr_fail(err, "the mesh has no triangles with area");
    }
    *out = s, *n = m;
    return 0;
}

/* ---- k nearest neighbours on a uniform grid ---------------------------- */

#define KNN 6

typedef struct {
    aabb box;
    double cell;
    int dim[3];
    size_t *start, *items; /* counting-sort layout: cell c holds items[start[c] .. start[c+1]) */
} point_grid;

static int cell_coord(const point_grid *g, double v, double lo, int k)
{
    int c = (int)((v - lo) / g->cell);
    return c < 0 ? 0 : c >= g->dim[k] ? g->dim[k] - 1 : c;
}

static size_t cell_of(const point_grid *g, vec3 p)
{
    int x = cell_coord(g, p.x, g->box.lo.x, 0), y = cell_coord(g, p.y, g->box.lo.y, 1);
    int z = cell_coord(g, p.z, g->box.lo.z, 2);
    return ((size_t)z * g->dim[1] + y) * g->dim[0] + x;
}

static int grid_build(point_grid *g, const double *pos, size_t np)
{
    g->box = aabb_empty();
    for (size_t i = 0; i < np; i++)
        aabb_add_point(&g->box, at(pos, i));
    vec3 ext = v3_sub(g->box.hi, g->box.lo);
    double vol = fmax(ext.x, 1e-12) * fmax(ext.y, 1e-12) * fmax(ext.z, 1e-12);
    g->cell = fmax(cbrt(vol / (double)np) * 2.0, 1e-9 * fmax(ext.x, fmax(ext.y, ext.z)) + 1e-30);
    double e[3] = {ext.x, ext.y, ext.z};
    size_t cells;
    do { /* flat or thin clouds: grow the cells until their number is moderate */
        cells = 1;
        for (int k = 0; k < 3; k++) {
            g->dim[k] = (int)fmin(e[k] / g->cell + 1, 1024);
            cells *= (size_t)g->dim[k];
        }
        g->cell *= 1.5;
    } while (cells > 8 * np + 64);
    g->cell /= 1.5;
    g->start = calloc(cells + 1, sizeof *g->start);
    g->items = malloc(np * sizeof *g->items);
    if (!g->start || !g->items)
        return -1;
    for (size_t i = 0; i < np; i++)
        g->start[cell_of(g, at(pos, i)) + 1]++;
    for (size_t c = 0; c < cells; c++)
        g->start[c + 1] += g->start[c];
    size_t *fill = malloc((cells + 1) * sizeof *fill);
    if (!fill)
        return -1;
    for (size_t c = 0; c <= cells; c++)
        fill[c] = g->start[c];
    for (size_t i = 0; i < np; i++)
        g->items[fill[cell_of(g, at(pos, i))]++] = i;
    free(fill);
    return 0;
}

/* Keeps the KNN smallest squared distances, sorted. */
static void keep_nearest(double *best, int *count, double d2)
{
    if (*count == KNN && d2 >= best[KNN - 1])
        return;
    int i = *count < KNN ? (*count)++ : KNN - 1;
    while (i > 0 && best[i - 1] > d2) {
        best[i] = best[i - 1];
        i--;
    }
    best[i] = d2;
}

/* Distance to the KNN-th nearest other point: search shells of cells
 * until the next shell cannot hold anything nearer. */
static double kth_distance(const point_grid *g, const double *pos, size_t self)
{
    vec3 p = at(pos, self);
    int c[3] = {cell_coord(g, p.x, g->box.lo.x, 0), cell_coord(g, p.y, g->box.lo.y, 1),
                cell_coord(g, p.z, g->box.lo.z, 2)};
    double best[KNN];
    int count = 0, maxdim = g->dim[0] > g->dim[1] ? g->dim[0] : g->dim[1];
    maxdim = maxdim > g->dim[2] ? maxdim : g->dim[2];
    for (int r = 0; r <= maxdim; r++) {
        for (int z = c[2] - r; z <= c[2] + r; z++)
            for (int y = c[1] - r; y <= c[1] + r; y++)
                for (int x = c[0] - r; x <= c[0] + r; x++) {
                    int on_shell = abs(x - c[0]) == r || abs(y - c[1]) == r || abs(z - c[2]) == r;
                    if (!on_shell || x < 0 || y < 0 || z < 0 || x >= g->dim[0] || y >= g->dim[1] || z >= g->dim[2])
                        continue;
                    size_t cell = ((size_t)z * g->dim[1] + y) * g->dim[0] + x;
                    for (size_t k = g->start[cell]; k < g->start[cell + 1]; k++)
                        if (g->items[k] != self)
                            keep_nearest(best, &count, v3_dot(v3_sub(at(pos, g->items[k]), p), v3_sub(at(pos, g->items[k]), p)));
                }
        /* every point outside shells 0..r is at least r cells away */
        if (count == KNN && best[KNN - 1] <= pow(r * g->cell, 2))
            break;
    }
    return count ? sqrt(best[count - 1]) : 0.0;
}

int surfels_from_points(const double *pos, const double *nrm, size_t np, double overlap, surfel **out,
                        size_t *n, rr_error *err)
{
    if (np < KNN + 1)
        return rr_fail(err, "a point cloud needs at least %d points to estimate splat sizes", KNN + 1);
    point_grid g = {0};
    surfel *s = malloc(np * sizeof *s);
    if (!s || grid_build(&g, pos, np)) {
        free(s), free(g.start), free(g.items);
        return rr_fail(err, "out of memory for %zu points", np);
    }
    size_t m = 0, no_normal = 0, crowded = 0;
    for (size_t i = 0; i < np; i++) {
        vec3 normal = at(nrm, i);
        double d = kth_distance(&g, pos, i);
        int has_normal = v3_len(normal) > 0, sized = d > 0;
        no_normal += !has_normal, crowded += has_normal && !sized; /* counted to say why none is left */
        if (!has_normal || !sized)
            continue;
        s[m].center = at(pos, i);
        s[m].normal = v3_normalize(normal);
        s[m].radius = overlap * d / sqrt(KNN + 1.0); /* disk of area pi d^2 / (KNN + 1) */
        s[m].color = rr_default_color();
        m++;
    }
    free(g.start), free(g.items);
    if (!m) { /* say why here: the writer would only see an empty list and blame its file */
        free(s);
        return rr_fail(err, "no splat is left of %zu points: %zu have no normal and %zu have %d or more duplicates "
                            "(their %dth nearest neighbour is at distance 0, so no splat size can be estimated)",
                       np, no_normal, crowded, KNN, KNN);
    }
    *out = s, *n = m;
    return 0;
}

void surfels_color(surfel *s, size_t n, vec3 c1, vec3 c2, double cell)
{
    for (size_t i = 0; i < n; i++) {
        if (!(cell > 0)) {
            s[i].color = c1;
            continue;
        }
        vec3 p = s[i].center;
        long parity = (long)floor(p.x / cell) + (long)floor(p.y / cell) + (long)floor(p.z / cell);
        s[i].color = parity & 1 ? c2 : c1;
    }
}
