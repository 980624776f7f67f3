/* Compositing a ray's Gaussian hits front to back (gaussian_hit.h): their
 * order, each formation's stopping rule and the colour they leave. */
#include "gaussians/gaussian_hit.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "gaussians/gaussian_dynamic.h"

/* Compositing order: key, then object, then Gaussian (ties in key are
 * rare but must not depend on the order the traversal found them in). Keys
 * equal as floats but not in bits (-0 and +0) go by their order bits, as a
 * sort by rr_float_order_bits would put them. */
static inline __attribute__((always_inline)) int hit_before(const gaussian_hit *a, const gaussian_hit *b)
{
    if (a->key < b->key)
        return 1;
    if (b->key < a->key)
        return 0;
    uint32_t ka = rr_float_order_bits(a->key), kb = rr_float_order_bits(b->key);
    if (ka != kb)
        return ka < kb;
    if (a->obj != b->obj)
        return a->obj < b->obj;
    return a->prim < b->prim;
}

/* h->hits[0..count) is a binary min-heap in compositing order: a hit goes
 * in and the first comes out in O(log n) moves, however many wait. A
 * ray's windows and chunks composite after each chunk only the hits below
 * every key still to come (gaussian_integrator.c), and the rest wait: re-sorting the
 * waiting hits after every chunk was quadratic where they are many: one
 * ray through 256k Gaussians of one key took 135 s of CPU; a dense
 * see-through 2DGS cloud is the same shape. */
void gaussian_hits_add(gaussian_hits *h, const gaussian_hit *hit)
{
    if (rr_arena_grow(h->arena, (void **)&h->hits, &h->cap, h->count + 1, sizeof *h->hits)) {
        h->dropped++;
        return;
    }
    /* hits found in compositing order (a rasterizer's key is its floor, and a
     * chunk's candidates come in order of their floors) keep the array sorted */
    h->in_order = !h->count || (h->in_order && hit_before(&h->hits[h->count - 1], hit));
    size_t i = h->count++, moved = 0;
    for (; i > 0 && hit_before(hit, &h->hits[(i - 1) / 2]); i = (i - 1) / 2, moved++)
        h->hits[i] = h->hits[(i - 1) / 2];
    h->hits[i] = *hit;
    h->added++;
    h->moved += moved;
}

/* Removes and returns the first hit in compositing order (h->count > 0).
 * Floyd's order of moves: the hole goes down to a leaf, each level to the
 * child that comes first (one comparison a level), then the last hit,
 * which most often belongs near the leaves, rises into it. */
static gaussian_hit take_first(gaussian_hits *h)
{
    gaussian_hit first = h->hits[0], last = h->hits[--h->count];
    size_t n = h->count, i = 0, moved = 0;
    for (size_t c = 1; c < n; i = c, c = 2 * c + 1, moved++) {
        if (c + 1 < n) { /* the right child if it comes first: a flag, not a branch, but on a tie */
            const gaussian_hit *l = &h->hits[c], *r = &h->hits[c + 1];
            int before = r->key < l->key, after = l->key < r->key;
            c += (size_t)(before | (!(before | after) && hit_before(r, l)));
        }
        h->hits[i] = h->hits[c];
    }
    for (; i > 0 && hit_before(&last, &h->hits[(i - 1) / 2]); i = (i - 1) / 2, moved++)
        h->hits[i] = h->hits[(i - 1) / 2];
    h->hits[i] = last;
    h->moved += moved;
    h->in_order = 0;
    return first;
}

void gaussian_hits_init(gaussian_hits *h, rr_arena *arena)
{
    memset(h, 0, sizeof *h);
    h->arena = arena;
}

void gaussian_hits_begin(gaussian_hits *h)
{
    h->count = 0;
    rr_arena_renew(h->arena, (void **)&h->hits, &h->cap, sizeof *h->hits);
}

void gaussian_blend_init(gaussian_blend *b)
{
    b->T = 1.0, b->sum = v3(0, 0, 0), b->composited = 0, b->done = 0, b->time = 0.0;
}

/* Each formation's own stopping rule (gaussian_hit.h): the rasterizers do
 * not composite the hit that would bring T below 1e-4 (forward.cu's
 * test_T < 0.0001f; gsplat's next_T <= 1e-4f); 3DGRT composites each
 * while T > 1e-3. */
static int blend_stops(const gaussian_blend *b, const gaussian_hit *g, const gaussian_model *m)
{
    double next = b->T * (1.0 - g->alpha);
    switch (gaussian_formation_of(m)) {
    case GAUSSIAN_FORMATION_3DGRT: return !(b->T > GAUSSIAN_GRT_MIN_TRANSMITTANCE);
    case GAUSSIAN_FORMATION_GSPLAT:
    case GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED: return next <= GAUSSIAN_MIN_TRANSMITTANCE;
    default: return next < GAUSSIAN_MIN_TRANSMITTANCE;
    }
}

/* A hit's colour: its SH seen along the hit's direction, or for a
 * dynamic model its kind's colour at the ray's time (SpacetimeGaussians-
 * lite's stored RGB, 4DGS's 4D SH seen from the direction its row's
 * view_dir put in the hit: gaussian_dynamic.h). */
static vec3 hit_color(const gaussian_blend *b, const gaussian_hit *g, const gaussian_model *m)
{
    const float *sh = &m->sh[(size_t)3 * m->sh_coeffs * g->prim];
    vec3 dir = v3(g->dir[0], g->dir[1], g->dir[2]);
    if (m->dynamic)
        return gaussian_dynamic_color(m, g->prim, b->time, dir);
    return gaussian_sh_color(sh, m->sh_degree, dir);
}

static void blend_one(gaussian_blend *b, const gaussian_hit *g, const gaussian_model *m)
{
    if (blend_stops(b, g, m)) {
        b->done = 1;
        return;
    }
    double next = b->T * (1.0 - g->alpha);
    vec3 c = hit_color(b, g, m);
    b->sum = v3_add(b->sum, v3_scale(c, g->alpha * b->T));
    b->T = next;
    b->composited++;
}

/* The colour of the hit a few ahead is prefetched (gaussian_prefetch_sh):
 * hits are taken from the heap that far ahead of compositing, into a ring. */
enum { SH_PREFETCH_AHEAD = 4 };

static int first_below(const gaussian_hits *h, double final_below)
{
    return h->count && h->hits[0].key < final_below;
}

/* All of h's hits, in order (h->in_order: the array is sorted). */
static void blend_in_order(gaussian_blend *b, gaussian_hits *h, const gaussian_model *const *models)
{
    for (size_t k = 0; k < SH_PREFETCH_AHEAD && k < h->count; k++)
        gaussian_prefetch_sh(models[h->hits[k].obj], h->hits[k].prim);
    for (size_t k = 0; k < h->count && !b->done; k++) {
        if (k + SH_PREFETCH_AHEAD < h->count) {
            const gaussian_hit *ahead = &h->hits[k + SH_PREFETCH_AHEAD];
            gaussian_prefetch_sh(models[ahead->obj], ahead->prim);
        }
        blend_one(b, &h->hits[k], models[h->hits[k].obj]);
    }
    h->count = 0;
}

/* Whether a few hits are all below final_below: then they are sorted in
 * place (insertion sort: a heap of up to SMALL_SORT hits is nearly in order,
 * and its (k - 1) / 2 moves a hit on average stay below 2 log2 k) and
 * composited as they lie, cheaper than taking them one by one. */
enum { SMALL_SORT = 16 };
static int few_all_below(gaussian_hits *h, double final_below)
{
    if (h->count > SMALL_SORT)
        return 0;
    for (size_t k = 0; k < h->count; k++)
        if (!(h->hits[k].key < final_below))
            return 0;
    size_t moved = 0;
    for (size_t k = 1; k < h->count; k++) {
        gaussian_hit g = h->hits[k];
        size_t j = k;
        for (; j > 0 && hit_before(&g, &h->hits[j - 1]); j--, moved++)
            h->hits[j] = h->hits[j - 1];
        h->hits[j] = g;
    }
    h->moved += moved;
    return 1;
}

void gaussian_blend_hits(gaussian_blend *b, gaussian_hits *h, const gaussian_model *const *models,
                         double final_below)
{
    /* a sorted array all below final_below (its first and last are: the
     * order is the keys' order bits, in which no NaN lies between two
     * numbers) is composited as it lies */
    if ((h->in_order && first_below(h, final_below) && h->hits[h->count - 1].key < final_below) ||
        few_all_below(h, final_below)) {
        blend_in_order(b, h, models);
        return;
    }
    gaussian_hit ahead[SH_PREFETCH_AHEAD];
    size_t taken = 0, used = 0;
    for (; taken < SH_PREFETCH_AHEAD && first_below(h, final_below); taken++) {
        ahead[taken] = take_first(h);
        gaussian_prefetch_sh(models[ahead[taken].obj], ahead[taken].prim);
    }
    for (; used < taken && !b->done; used++) {
        gaussian_hit *g = &ahead[used % SH_PREFETCH_AHEAD];
        blend_one(b, g, models[g->obj]);
        if (!b->done && first_below(h, final_below)) { /* into the place just composited */
            gaussian_hit *next = &ahead[taken++ % SH_PREFETCH_AHEAD];
            *next = take_first(h);
            gaussian_prefetch_sh(models[next->obj], next->prim);
        }
    }
    if (b->done) /* nothing behind is wanted */
        h->count = 0;
}

vec3 gaussian_blend_over(const gaussian_blend *b, vec3 behind) { return v3_add(b->sum, v3_scale(behind, b->T)); }
