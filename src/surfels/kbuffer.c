#include "surfels/kbuffer.h"

#include "core/common.h"

#include <math.h>
#include <string.h>

void kbuffer_reset(kbuffer *kb, float epsilon)
{
    kb->count = 0;
    kb->dropped_t = INFINITY;
    kb->closest = INFINITY;
    kb->epsilon = epsilon;
}

static int hit_before(const surface_hit *a, const surface_hit *b)
{
    if (a->t != b->t)
        return a->t < b->t;
    if (a->obj != b->obj)
        return a->obj < b->obj;
    return a->prim < b->prim;
}

void kbuffer_insert(kbuffer *kb, const surface_hit *h)
{
    if (!kbuffer_within(h->t, kb->closest, kb->epsilon))
        return;
    int pos = kb->count;
    while (pos > 0 && hit_before(h, &kb->hits[pos - 1]))
        pos--;
    if (kb->count == KBUFFER_MAX) {
        float lost = pos == KBUFFER_MAX ? h->t : kb->hits[KBUFFER_MAX - 1].t;
        kb->dropped_t = lost < kb->dropped_t ? lost : kb->dropped_t;
        if (pos == KBUFFER_MAX)
            return;
        kb->count--; /* the farthest entry makes room */
    }
    RR_DCHECK(pos >= 0 && pos <= kb->count && kb->count < KBUFFER_MAX); /* room for one more */
    memmove(&kb->hits[pos + 1], &kb->hits[pos], (size_t)(kb->count - pos) * sizeof *h);
    kb->hits[pos] = *h;
    kb->count++;
    if (h->t < kb->closest) {
        kb->closest = h->t;
        /* entries are sorted by t: drop the tail now beyond the window */
        while (kb->count > 0 && !kbuffer_within(kb->hits[kb->count - 1].t, kb->closest, kb->epsilon))
            kb->count--;
    }
}

int kbuffer_overflowed(const kbuffer *kb)
{
    /* the window's test in kbuffer_insert, with the final closest; a drop
     * leaves the buffer full (without any hit, closest + epsilon is inf) */
    return kb->count == KBUFFER_MAX && kb->dropped_t <= kb->closest + kb->epsilon;
}

float kbuffer_cutoff(const kbuffer *kb)
{
    return nextafterf(kb->closest + kb->epsilon, INFINITY);
}
