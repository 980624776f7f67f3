/* Point model storage: the spatial (Morton) reordering. */
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "surfels/pointmodel.h"
#include "surfels/shapes.h"

static double mean_step(const pointmodel *m)
{
    double sum = 0;
    for (size_t i = 1; i < m->count; i++) {
        const float *a = m->geom[i - 1].center, *b = m->geom[i].center;
        sum += v3_len(v3(a[0] - b[0], a[1] - b[1], a[2] - b[2]));
    }
    return sum / (double)(m->count - 1);
}

/* Sorting moves each splat whole (geometry, shading, extent together), keeps
 * every splat exactly once, and puts space neighbours next to each other:
 * a Z-order curve through n near-uniform points on a unit sphere steps about
 * one splat spacing, sqrt(4 pi / n), far below the generator's order. */
TEST(spatial_sort_is_a_permutation_that_brings_neighbours_together)
{
    shape_params p;
    shape_params_default(&p);
    p.count = 20000;
    surfel *f;
    size_t n;
    rr_error err;
    CHECK(shape_generate(&p, &f, &n, &err) == 0);
    pointmodel m, orig;
    pointmodel_init(&m);
    pointmodel_init(&orig);
    for (size_t i = 0; i < n; i++) {
        vec3 color = v3((double)i, 0, 0); /* tags each splat with its old index */
        CHECK(pointmodel_add_circle(&m, f[i].center, f[i].normal, f[i].radius, color, &err) == 0);
        CHECK(pointmodel_add_circle(&orig, f[i].center, f[i].normal, f[i].radius, color, &err) == 0);
    }
    size_t *order;
    CHECK(pointmodel_sort_spatially(&m, &order, &err) == 0);
    char *seen = calloc(n, 1);
    int moved_whole = 1, once = 1;
    for (size_t i = 0; i < n; i++) {
        size_t k = order[i];
        once &= k < n && !seen[k];
        seen[k < n ? k : 0] = 1;
        moved_whole &= !memcmp(&m.geom[i], &orig.geom[k], sizeof m.geom[i]) &&
                       !memcmp(&m.shading[6 * i], &orig.shading[6 * k], 6 * sizeof *m.shading) &&
                       !memcmp(&m.extent[3 * i], &orig.extent[3 * k], 3 * sizeof *m.extent) &&
                       pointmodel_color(&m, i)[0] == (float)k;
    }
    CHECK(once && moved_whole);
    double spacing = sqrt(4 * M_PI / (double)n), before = mean_step(&orig), after = mean_step(&m);
    printf("    mean step between consecutive splats: %.4f before, %.4f after (spacing %.4f)\n", before, after,
           spacing);
    CHECK(after < 3 * spacing);
    CHECK(after < 0.2 * before);
    free(seen);
    free(order);
    free(f);
    pointmodel_free(&m);
    pointmodel_free(&orig);
}

TEST(spatial_sort_of_an_empty_model_is_a_no_op)
{
    pointmodel m;
    pointmodel_init(&m);
    size_t *order = (size_t *)&m;
    rr_error err;
    CHECK(pointmodel_sort_spatially(&m, &order, &err) == 0);
    CHECK(order == NULL && m.count == 0);
}
