/* core/arena.h, the per-thread scratch arena: every block aligned as
 * asked and writable without overlapping the others (each filled with its
 * own byte, all checked after); requests past the first chunk go on into
 * new ones; a reset reuses the chunks, so the same requests again malloc
 * nothing; rr_arena_grow keeps the contents and grows geometrically (n
 * appends: O(log n) moves, O(n) bytes copied); out of memory (a limit, an
 * overflowing size) is NULL or -1 with the array unchanged, never an abort. */
#include <stdint.h>
#include <string.h>

#include "core/arena.h"
#include "harness.h"

/* Does block p of n bytes hold byte v throughout? */
static int holds(const unsigned char *p, size_t n, unsigned char v)
{
    for (size_t i = 0; i < n; i++)
        if (p[i] != v)
            return 0;
    return 1;
}

TEST(arena_blocks_are_aligned_and_do_not_overlap)
{
    rr_arena a;
    rr_arena_init(&a, 1000);
    enum { N = 200 };
    unsigned char *blk[N];
    size_t size[N];
    for (int i = 0; i < N; i++) {
        size_t align = (size_t)1 << (i % 13); /* 1 .. 4096 */
        size[i] = (size_t)(i * 37 % 301);     /* 0 .. 300, some across a chunk's end */
        blk[i] = rr_arena_alloc(&a, size[i], align);
        CHECK(blk[i] != NULL);
        CHECK((uintptr_t)blk[i] % align == 0);
        memset(blk[i], i & 0xff, size[i]);
    }
    for (int i = 0; i < N; i++)
        CHECK(holds(blk[i], size[i], (unsigned char)(i & 0xff)));
    CHECK(a.mallocs > 1); /* 200 blocks of ~150 bytes do not fit a chunk of 1000 */
    rr_arena_free(&a);
    CHECK(a.first == NULL && a.bytes == 0);
}

TEST(arena_grows_into_new_chunks_and_a_reset_mallocs_nothing_more)
{
    rr_arena a;
    rr_arena_init(&a, 256);
    for (int round = 0; round < 3; round++) {
        rr_arena_reset(&a);
        for (int i = 0; i < 50; i++) /* 50 x 100 bytes: chunks of 256, 512, 1024, 2048, 4096 */
            CHECK(rr_arena_alloc(&a, 100, 8) != NULL);
        CHECK(rr_arena_alloc(&a, 10000, 16) != NULL); /* larger than twice the last chunk */
        if (round == 0)
            CHECK(a.mallocs >= 5);
    }
    uint64_t after_first = a.mallocs;
    size_t bytes = a.bytes;
    for (int round = 0; round < 5; round++) { /* the same requests again and again */
        rr_arena_reset(&a);
        for (int i = 0; i < 50; i++)
            CHECK(rr_arena_alloc(&a, 100, 8) != NULL);
        CHECK(rr_arena_alloc(&a, 10000, 16) != NULL);
    }
    CHECK(a.mallocs == after_first);
    CHECK(a.bytes == bytes);
    /* the first block after a reset is where the first block was */
    rr_arena_reset(&a);
    void *p = rr_arena_alloc(&a, 8, 8);
    rr_arena_reset(&a);
    CHECK(rr_arena_alloc(&a, 8, 8) == p);
    rr_arena_free(&a);
}

TEST(arena_grow_keeps_contents_and_is_geometric)
{
    rr_arena a;
    rr_arena_init(&a, 512);
    uint32_t *v = NULL;
    size_t cap = 0, moves = 0;
    enum { N = 100000 };
    for (size_t n = 0; n < N; n++) { /* one append at a time, as the scratch sets grow */
        uint32_t *before = v;
        /* another array growing in between, so that v is not always the last block */
        if (n % 1000 == 0)
            CHECK(rr_arena_alloc(&a, 24, 8) != NULL);
        CHECK(rr_arena_grow(&a, (void **)&v, &cap, n + 1, sizeof *v) == 0);
        moves += v != before;
        CHECK(cap >= n + 1 && (uintptr_t)v % 16 == 0);
        v[n] = (uint32_t)(n * 2654435761u);
    }
    for (size_t n = 0; n < N; n++)
        if (v[n] != (uint32_t)(n * 2654435761u)) {
            CHECK(!"contents lost in a move");
            break;
        }
    /* capacity 64 doubling to 131072: 12 doublings, each at most one move */
    CHECK(cap == 131072);
    CHECK(moves <= 12);
    /* memory taken: the abandoned blocks are a geometric series (< 2x the
     * last), the chunks double: a few times the array, not N times */
    CHECK(a.bytes < 8 * cap * sizeof *v);
    rr_arena_free(&a);
}

TEST(arena_out_of_memory_is_null_not_an_abort)
{
    rr_arena a;
    rr_arena_init(&a, 1024);
    a.limit = 4096; /* stands for malloc failing: the arena may hold 4 KiB */
    CHECK(rr_arena_alloc(&a, 1000, 8) != NULL);
    CHECK(rr_arena_alloc(&a, 5000, 8) == NULL);
    CHECK(rr_arena_alloc(&a, 1000, 8) != NULL); /* the arena still works */
    CHECK(a.bytes <= 4096);
    CHECK(rr_arena_alloc(&a, SIZE_MAX - 8, 16) == NULL); /* overflowing sizes */
    CHECK(rr_arena_alloc(&a, SIZE_MAX, 1) == NULL);
    double *v = NULL;
    size_t cap = 0;
    if (rr_arena_grow(&a, (void **)&v, &cap, 100, sizeof *v)) { /* (chunks of 1024 and 2048 so far) */
        CHECK(!"no room for 100 doubles");
        return;
    }
    v[99] = 7;
    double *before = v;
    CHECK(rr_arena_grow(&a, (void **)&v, &cap, 10000, sizeof *v) == -1); /* 80 KB past the limit */
    CHECK(v == before && cap == 128 && v[99] == 7);
    CHECK(rr_arena_grow(&a, (void **)&v, &cap, SIZE_MAX / 4, sizeof *v) == -1); /* bytes overflow */
    CHECK(v == before && cap == 128);
    /* 3072 bytes taken: a doubled chunk of 4096 would pass the limit, one of 1007 does not */
    CHECK(rr_arena_alloc(&a, 1000, 8) != NULL);
    CHECK(a.bytes <= 4096);
    rr_arena_free(&a);
}

/* rr_arena_renew: an array that reached n elements in one batch is taken
 * anew at that capacity after the reset, so the next batch's n appends
 * never move it (growing from nothing moves it log2(n / 64) times); an
 * array that had none gets none; one the arena cannot hold is NULL, 0
 * and grows on demand. */
TEST(arena_renew_takes_an_array_at_its_capacity_so_the_next_batch_never_moves_it)
{
    rr_arena a;
    rr_arena_init(&a, 512);
    int *v = NULL, *none = NULL;
    size_t cap = 0, none_cap = 0, n = 5000;
    for (int batch = 0; batch < 3; batch++) {
        int moves = 0;
        for (size_t i = 0; i < n; i++) {
            int *before = v;
            CHECK(rr_arena_grow(&a, (void **)&v, &cap, i + 1, sizeof *v) == 0);
            moves += v != before;
            v[i] = (int)i;
        }
        printf("    batch %d: %d moves\n", batch, moves);
        CHECK(batch == 0 ? moves > 0 : moves == 0);
        rr_arena_reset(&a);
        rr_arena_renew(&a, (void **)&v, &cap, sizeof *v);
        rr_arena_renew(&a, (void **)&none, &none_cap, sizeof *none);
        CHECK(v != NULL && cap == 8192 && none == NULL && none_cap == 0);
    }
    rr_arena_free(&a);
    rr_arena tight;
    rr_arena_init(&tight, 256);
    tight.limit = 1024;
    int *w = NULL;
    size_t wcap = 1000; /* as if it had reached 1000 ints: 4000 bytes, past the limit */
    rr_arena_renew(&tight, (void **)&w, &wcap, sizeof *w);
    CHECK(w == NULL && wcap == 0);
    CHECK(rr_arena_grow(&tight, (void **)&w, &wcap, 10, sizeof *w) == 0 && w != NULL); /* on demand */
    rr_arena_free(&tight);
}
