/* The scratch arena (arena.h). */
#include "core/arena.h"

#include <stdalign.h>
#include <stdlib.h>
#include <string.h>

#include "core/common.h"

#define ARENA_FIRST_SIZE ((size_t)64 << 10)
#define ARENA_MAX_ALIGN ((size_t)4096)

struct rr_arena_chunk {
    rr_arena_chunk *next;
    size_t size, used; /* bytes of data; bytes handed out since the chunk was entered */
    unsigned char data[];
};

void rr_arena_init(rr_arena *a, size_t first_size)
{
    memset(a, 0, sizeof *a);
    a->first_size = first_size ? first_size : ARENA_FIRST_SIZE;
}

void rr_arena_free(rr_arena *a)
{
    size_t first_size = a->first_size, limit = a->limit;
    uint64_t mallocs = a->mallocs;
    for (rr_arena_chunk *c = a->first, *next; c; c = next) {
        next = c->next;
        free(c);
    }
    rr_arena_init(a, first_size);
    a->limit = limit, a->mallocs = mallocs;
}

void rr_arena_reset(rr_arena *a)
{
    a->cur = a->first;
    if (a->cur)
        a->cur->used = 0;
}

/* Where in chunk c a block of size bytes aligned to align would start,
 * or SIZE_MAX when it does not fit. */
static size_t fit(const rr_arena_chunk *c, size_t size, size_t align)
{
    uintptr_t base = (uintptr_t)c->data;
    size_t at = (size_t)(((base + c->used + align - 1) & ~(uintptr_t)(align - 1)) - base);
    return at <= c->size && size <= c->size - at ? at : SIZE_MAX;
}

/* A new last chunk holding at least `room` bytes: twice the last one's
 * size, within the limit; NULL when out of memory. */
static rr_arena_chunk *append_chunk(rr_arena *a, rr_arena_chunk *last, size_t room)
{
    size_t size = last ? last->size : a->first_size;
    if (last && size <= SIZE_MAX / 2)
        size *= 2;
    if (size < room)
        size = room;
    if (a->limit && (a->bytes > a->limit || size > a->limit - a->bytes))
        size = room; /* the doubling would pass the limit: only what is asked */
    if ((a->limit && (a->bytes > a->limit || size > a->limit - a->bytes)) ||
        size > SIZE_MAX - sizeof(rr_arena_chunk))
        return NULL;
    rr_arena_chunk *c = malloc(sizeof *c + size);
    if (!c)
        return NULL;
    c->next = NULL, c->size = size, c->used = 0;
    if (last)
        last->next = c;
    else
        a->first = c;
    a->bytes += size, a->mallocs++;
    return c;
}

void *rr_arena_alloc(rr_arena *a, size_t size, size_t align)
{
    RR_CHECK(align && !(align & (align - 1)) && align <= ARENA_MAX_ALIGN);
    if (size > SIZE_MAX - align)
        return NULL;
    rr_arena_chunk *c = a->cur;
    size_t at = c ? fit(c, size, align) : SIZE_MAX;
    /* on to the next chunks (entered empty: they were used before the
     * reset), past those too small, and a new one at the end */
    while (at == SIZE_MAX) {
        rr_arena_chunk *next = c ? c->next : a->first;
        if (!next && !(next = append_chunk(a, c, size + align - 1))) /* (c is the last chunk) */
            return NULL;
        c = next, c->used = 0;
        at = fit(c, size, align);
    }
    a->cur = c;
    c->used = at + size;
    return c->data + at;
}

/* Is block p of `bytes` the last one handed out from the current chunk? */
static int is_last_block(const rr_arena *a, const void *p, size_t bytes)
{
    const rr_arena_chunk *c = a->cur;
    return p && c && (const unsigned char *)p >= c->data &&
           (size_t)((const unsigned char *)p - c->data) + bytes == c->used;
}

void rr_arena_renew(rr_arena *a, void **p, size_t *cap, size_t elem)
{
    size_t want = *cap;
    *p = NULL, *cap = 0;
    if (want)
        (void)rr_arena_grow(a, p, cap, want, elem); /* (on failure *p, *cap stay NULL, 0) */
}

int rr_arena_grow(rr_arena *a, void **p, size_t *cap, size_t need, size_t elem)
{
    size_t n;
    if (need <= *cap)
        return 0;
    if (rr_grown_capacity(*cap, need, elem, &n))
        return -1;
    size_t old = *cap * elem, bytes = n * elem;
    if (is_last_block(a, *p, old)) { /* extended where it lies, when the chunk has room */
        size_t at = (size_t)((unsigned char *)*p - a->cur->data);
        if (bytes <= a->cur->size - at) {
            a->cur->used = at + bytes;
            *cap = n;
            return 0;
        }
    }
    void *grown = rr_arena_alloc(a, bytes, alignof(max_align_t));
    if (!grown)
        return -1;
    if (old)
        memcpy(grown, *p, old);
    *p = grown, *cap = n;
    return 0;
}
