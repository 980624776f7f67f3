/* A scratch arena: a chunked bump allocator, one per render thread, reset
 * between batches (after pbrt-v4's ScratchBuffer, util/scratch.h there,
 * and Hanson's "arena" in C Interfaces and Implementations, ch. 6).
 * Allocation takes the next aligned bytes of the current chunk; a request
 * that does not fit moves on to the next chunk, which is malloc'd (twice
 * the size of the last, at least the request) only when the arena has
 * none left. Reset rewinds to the first chunk and keeps every chunk, so
 * a thread whose batches need the same memory mallocs nothing after its
 * first batch. Nothing is freed one by one: a block that was grown out of
 * (rr_arena_grow) stays until the reset. Out of memory is a NULL (or -1),
 * never an abort: the callers report it. Not thread-safe: one per thread. */
#ifndef RR_ARENA_H
#define RR_ARENA_H

#include <stddef.h>
#include <stdint.h>

typedef struct rr_arena_chunk rr_arena_chunk;

typedef struct {
    rr_arena_chunk *first, *cur; /* the chunks in order; the one being filled */
    size_t first_size;           /* bytes of the first chunk */
    size_t limit;                /* bytes all chunks together may take; 0: no limit */
    size_t bytes;                /* bytes all chunks take */
    uint64_t mallocs;            /* chunks malloc'd over the arena's life (tests, statistics) */
} rr_arena;

/* An empty arena whose first chunk (malloc'd at the first allocation) has
 * first_size bytes (0: 64 KiB). */
void rr_arena_init(rr_arena *a, size_t first_size);
/* Frees every chunk; the arena is empty again (its first size, limit and
 * malloc count kept) and may be used anew. */
void rr_arena_free(rr_arena *a);
/* Every block handed out is gone; the chunks stay for the next ones. */
void rr_arena_reset(rr_arena *a);

/* size bytes aligned to align (a power of two, at most 4096), or NULL when
 * out of memory, beyond the limit, or the size overflows. */
void *rr_arena_alloc(rr_arena *a, size_t size, size_t align);

/* rr_grow's contract (core/common.h) inside the arena: makes room for at
 * least `need` elements of elem bytes in the array *p of *cap elements,
 * its contents kept, the capacity doubling from 64 so that n appends cost
 * O(n) copying in all; aligned for any type (max_align_t). The block is
 * extended where it lies when it is the chunk's last and the chunk has
 * room, else moved and the old block left to the reset. *p = NULL,
 * *cap = 0 is an empty array. 0, or -1 (*p and *cap unchanged) when out of
 * memory or the size overflows. */
int rr_arena_grow(rr_arena *a, void **p, size_t *cap, size_t need, size_t elem);

/* Right after a reset: a new block for an array of the capacity *cap it
 * had before the reset (elements of elem bytes; its contents are gone),
 * so that an array that reached n elements in one batch takes them at
 * once in the next, where growing from nothing would copy it
 * log2(n / 64) times, batch after batch, into memory the batch before
 * had left warm elsewhere. *p = NULL and *cap = 0 when *cap was 0 or
 * the block cannot be had (it then grows on demand). */
void rr_arena_renew(rr_arena *a, void **p, size_t *cap, size_t elem);

#endif
