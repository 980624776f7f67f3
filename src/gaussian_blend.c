/* Compositing a ray's Gaussian hits front to back (gaussian_hit.h): their
 * order, each formation's stopping rule and the colour they leave. */
#include "gaussian_hit.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

void gaussian_hits_add(gaussian_hits *h, const gaussian_hit *hit)
{
    if (h->count == h->cap) {
        size_t cap = h->cap ? 2 * h->cap : 256;
        gaussian_hit *grown = realloc(h->hits, cap * sizeof *grown);
        if (!grown) {
            h->dropped++;
            return;
        }
        h->hits = grown, h->cap = cap;
    }
    h->hits[h->count++] = *hit;
    h->added++;
}

void gaussian_hits_free(gaussian_hits *h)
{
    free(h->hits);
    free(h->order);
    free(h->rays);
    free(h->candidates);
    free(h->candidate_order);
    memset(h, 0, sizeof *h);
}

/* Compositing order: key, then object, then Gaussian (ties in key are
 * rare but must not depend on the order the traversal found them in). */
static int hit_before(const gaussian_hit *a, const gaussian_hit *b)
{
    if (a->key != b->key)
        return a->key < b->key;
    if (a->obj != b->obj)
        return a->obj < b->obj;
    return a->prim < b->prim;
}

/* qsort_r's order of two sort words of equal key (hit_before). */
static int tie_order(const void *a, const void *b, void *hits)
{
    const gaussian_hit *h = hits, *x = &h[(uint32_t)*(const uint64_t *)a], *y = &h[(uint32_t)*(const uint64_t *)b];
    return hit_before(x, y) ? -1 : hit_before(y, x) ? 1 : 0;
}

/* h->order holds, per hit: its sort word, the merge sort's scratch word,
 * and room for the hits kept for later (gaussian_blend_hits). */
enum { ORDER_WORDS = 2 + (sizeof(gaussian_hit) + sizeof(uint64_t) - 1) / sizeof(uint64_t) };

/* Puts h->order[] in compositing order (h->hits stay where they are). */
static int sort_hits(gaussian_hits *h)
{
    if (h->count > h->order_cap) {
        uint64_t *grown = realloc(h->order, ORDER_WORDS * h->count * sizeof *grown);
        if (!grown)
            return -1;
        h->order = grown, h->order_cap = h->count;
    }
    for (size_t k = 0; k < h->count; k++)
        h->order[k] = (uint64_t)rr_float_order_bits(h->hits[k].key) << 32 | (uint64_t)k;
    rr_sort_u64(h->order, h->order + h->count, h->count);
    /* runs of equal keys: by object and Gaussian, O(m log m) (an insertion
     * sort took 17 s for one ray with 256k equal keys, issue 32.5) */
    for (size_t k = 0, end; k < h->count; k = end) {
        for (end = k + 1; end < h->count && h->order[end] >> 32 == h->order[k] >> 32; end++)
            ;
        if (end - k > 1)
            qsort_r(h->order + k, end - k, sizeof *h->order, tie_order, h->hits);
    }
    return 0;
}

void gaussian_blend_init(gaussian_blend *b)
{
    b->T = 1.0, b->sum = v3(0, 0, 0), b->composited = 0, b->done = 0;
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

static void blend_one(gaussian_blend *b, const gaussian_hit *g, const gaussian_model *m)
{
    if (blend_stops(b, g, m)) {
        b->done = 1;
        return;
    }
    double next = b->T * (1.0 - g->alpha);
    vec3 c = gaussian_sh_color(&m->sh[(size_t)3 * m->sh_coeffs * g->prim], m->sh_degree,
                               v3(g->dir[0], g->dir[1], g->dir[2]));
    b->sum = v3_add(b->sum, v3_scale(c, g->alpha * b->T));
    b->T = next;
    b->composited++;
}

enum { SH_PREFETCH_AHEAD = 4 };

void gaussian_blend_hits(gaussian_blend *b, gaussian_hits *h, const gaussian_model *const *models,
                         double final_below)
{
    if (!h->count)
        return;
    if (sort_hits(h)) { /* no memory to order them: the hits are dropped, and counted */
        h->dropped += h->count;
        h->count = 0;
        return;
    }
    size_t k = 0;
    for (size_t p = 0; p < SH_PREFETCH_AHEAD && p < h->count; p++) {
        const gaussian_hit *g = &h->hits[(uint32_t)h->order[p]];
        gaussian_prefetch_sh(models[g->obj], g->prim);
    }
    for (; k < h->count && !b->done; k++) {
        if (k + SH_PREFETCH_AHEAD < h->count) { /* the colour of a hit a few ahead (gaussian_prefetch_sh) */
            const gaussian_hit *ahead = &h->hits[(uint32_t)h->order[k + SH_PREFETCH_AHEAD]];
            gaussian_prefetch_sh(models[ahead->obj], ahead->prim);
        }
        const gaussian_hit *g = &h->hits[(uint32_t)h->order[k]];
        if (!(g->key < final_below))
            break;
        blend_one(b, g, models[g->obj]);
    }
    if (b->done) {
        h->count = 0;
        return;
    }
    /* keep the rest, in order (gathered hits are appended after them) */
    size_t rest = h->count - k;
    gaussian_hit *kept = (gaussian_hit *)(h->order + 2 * h->count);
    for (size_t j = 0; j < rest; j++)
        kept[j] = h->hits[(uint32_t)h->order[k + j]];
    memcpy(h->hits, kept, rest * sizeof *kept);
    h->count = rest;
}

vec3 gaussian_blend_over(const gaussian_blend *b, vec3 behind) { return v3_add(b->sum, v3_scale(behind, b->T)); }
