#include "core/common.h"

#include <ctype.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

int rr_fail(rr_error *err, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
    }
    return -1;
}

void rr_warn(rr_warnings *w, const char *fmt, ...)
{
    if (!w)
        return;
    if (w->count < RR_WARNINGS_KEPT) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(w->msg[w->count], sizeof w->msg[w->count], fmt, ap);
        va_end(ap);
    }
    w->count++;
}


enum { SORT_RUN = 16 };

static void insertion_sort_u64(uint64_t *a, size_t n)
{
    for (size_t i = 1; i < n; i++) {
        uint64_t w = a[i];
        size_t j = i;
        for (; j > 0 && a[j - 1] > w; j--)
            a[j] = a[j - 1];
        a[j] = w;
    }
}

static void merge_u64(const uint64_t *src, uint64_t *dst, size_t lo, size_t mid, size_t hi)
{
    size_t i = lo, j = mid, k = lo;
    while (i < mid && j < hi)
        dst[k++] = src[j] < src[i] ? src[j++] : src[i++];
    while (i < mid)
        dst[k++] = src[i++];
    while (j < hi)
        dst[k++] = src[j++];
}

static void merge_sort_u64(uint64_t *a, uint64_t *tmp, size_t n)
{
    for (size_t lo = 0; lo < n; lo += SORT_RUN)
        insertion_sort_u64(a + lo, n - lo < SORT_RUN ? n - lo : SORT_RUN);
    uint64_t *src = a, *dst = tmp;
    for (size_t width = SORT_RUN; width < n; width *= 2) {
        for (size_t lo = 0; lo < n; lo += 2 * width) {
            size_t mid = lo + width < n ? lo + width : n, hi = lo + 2 * width < n ? lo + 2 * width : n;
            merge_u64(src, dst, lo, mid, hi);
        }
        uint64_t *t = src;
        src = dst, dst = t;
    }
    if (src != a)
        memcpy(a, src, n * sizeof *a);
}

void rr_sort_u64(uint64_t *a, uint64_t *tmp, size_t n)
{
    size_t sorted = 1; /* an ascending prefix is kept, and merged with the rest sorted */
    while (sorted < n && a[sorted - 1] < a[sorted])
        sorted++;
    if (sorted >= n)
        return;
    if (sorted <= SORT_RUN) {
        merge_sort_u64(a, tmp, n);
        return;
    }
    merge_sort_u64(a + sorted, tmp, n - sorted);
    merge_u64(a, tmp, 0, sorted, n);
    memcpy(a, tmp, n * sizeof *a);
}

void rr_lazy_sort_begin(rr_lazy_sort *s, uint64_t *a, uint64_t *scratch, size_t n)
{
    /* scratch: n words for the scatter (then the big buckets' merges);
     * after them the bucket starts (n / 2 + 2 of 32 bits) and each word's
     * bucket (n of 32 bits) */
    size_t buckets = n / 2;
    s->a = a, s->tmp = scratch, s->start = NULL, s->done = 0, s->next = 0;
    if (n <= SORT_RUN) { /* (and the room above holds the buckets: n >= 4) */
        insertion_sort_u64(a, n);
        s->done = n, s->n_buckets = 0;
        return;
    }
    s->start = (uint32_t *)(scratch + n), s->n_buckets = buckets;
    uint32_t *start = s->start, *bucket = start + buckets + 2, lo = UINT32_MAX, hi = 0;
    for (size_t k = 0; k < n; k++) {
        uint32_t key = (uint32_t)(a[k] >> 32);
        lo = key < lo ? key : lo, hi = key > hi ? key : hi;
    }
    /* bucket = (key - lo) * scale >> 32: monotone in the key (so the
     * buckets in order hold the words in order), below `buckets` for every
     * key up to hi, and no division per word */
    uint64_t scale = ((uint64_t)buckets << 32) / ((uint64_t)(hi - lo) + 1);
    memset(start, 0, (buckets + 2) * sizeof *start);
    for (size_t k = 0; k < n; k++) { /* counts, shifted by two: after the sums start[b + 1] is bucket b's start */
        bucket[k] = (uint32_t)((uint64_t)((uint32_t)(a[k] >> 32) - lo) * scale >> 32);
        start[bucket[k] + 2]++;
    }
    for (size_t b = 2; b < buckets + 2; b++)
        start[b] += start[b - 1];
    for (size_t k = 0; k < n; k++)
        scratch[start[bucket[k] + 1]++] = a[k];
    memcpy(a, scratch, n * sizeof *a);
}

void rr_lazy_sort_through(rr_lazy_sort *s, size_t k)
{
    while (s->done < k && s->next < s->n_buckets) {
        size_t from = s->start[s->next], to = s->start[s->next + 1];
        if (to - from <= SORT_RUN)
            insertion_sort_u64(s->a + from, to - from);
        else
            rr_sort_u64(s->a + from, s->tmp, to - from);
        s->done = to, s->next++;
    }
}

int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int rr_grown_capacity(size_t cap, size_t need, size_t elem, size_t *n)
{
    *n = cap ? cap : 64;
    while (*n < need) {
        if (*n > SIZE_MAX / 2)
            return -1;
        *n *= 2;
    }
    return elem && *n > SIZE_MAX / elem ? -1 : 0;
}

int rr_grow(void **p, size_t *cap, size_t need, size_t elem)
{
    size_t n;
    if (need <= *cap)
        return 0;
    if (rr_grown_capacity(*cap, need, elem, &n))
        return -1;
    void *grown = realloc(*p, n * elem);
    if (!grown)
        return -1;
    *p = grown, *cap = n;
    return 0;
}

/* A total order on the values' bits: by value, -0 before +0. */
static int lex_less(const double *a, const double *b, int n)
{
    for (int i = 0; i < n; i++) {
        if (a[i] != b[i])
            return a[i] < b[i];
        if (signbit(a[i]) != signbit(b[i]))
            return signbit(a[i]) != 0;
    }
    return 0;
}

int rr_round_trip_representative(double *v, int n, void (*f)(const double *in, double *out, void *ctx), void *ctx)
{
    enum { STEPS = 512 };
    double orbit[STEPS + 1][4];
    memcpy(orbit[0], v, (size_t)n * sizeof *v);
    for (int k = 0; k < STEPS; k++) {
        f(orbit[k], orbit[k + 1], ctx);
        for (int j = 0; j <= k; j++) /* bitwise: a signed zero is a different file */
            if (!memcmp(orbit[j], orbit[k + 1], (size_t)n * sizeof *v)) {
                int best = j;
                for (int c = j + 1; c <= k; c++)
                    if (lex_less(orbit[c], orbit[best], n))
                        best = c;
                memcpy(v, orbit[best], (size_t)n * sizeof *v);
                return 0;
            }
    }
    return -1;
}

double rr_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void mat4_mul(double a[4][4], double b[4][4], double out[4][4])
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            out[r][c] = a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c] + a[r][3] * b[3][c];
}

void rr_check_failed(const char *file, int line, const char *cond)
{
    fprintf(stderr, "%s:%d: check failed: %s\n", file, line, cond);
    abort();
}

void rr_check_failed_values(const char *file, int line, const char *cond, long long a, long long b)
{
    fprintf(stderr, "%s:%d: check failed: %s (%lld vs %lld)\n", file, line, cond, a, b);
    abort();
}

/* Optimal string alignment distance (Damerau-Levenshtein without moving a
 * letter twice), case-insensitive; words longer than the row are far. */
static int edit_distance(const char *a, const char *b)
{
    enum { MAX = 64 };
    size_t la = strlen(a), lb = strlen(b);
    if (la >= MAX || lb >= MAX)
        return INT_MAX;
    int d[MAX][MAX];
    for (size_t i = 0; i <= la; i++)
        d[i][0] = (int)i;
    for (size_t j = 0; j <= lb; j++)
        d[0][j] = (int)j;
    for (size_t i = 1; i <= la; i++)
        for (size_t j = 1; j <= lb; j++) {
            int ai = tolower((unsigned char)a[i - 1]), bj = tolower((unsigned char)b[j - 1]);
            int best = d[i - 1][j - 1] + (ai != bj);
            best = d[i - 1][j] + 1 < best ? d[i - 1][j] + 1 : best;
            best = d[i][j - 1] + 1 < best ? d[i][j - 1] + 1 : best;
            if (i > 1 && j > 1 && ai == tolower((unsigned char)b[j - 2]) && tolower((unsigned char)a[i - 2]) == bj &&
                d[i - 2][j - 2] + 1 < best)
                best = d[i - 2][j - 2] + 1;
            d[i][j] = best;
        }
    return d[la][lb];
}

const char *rr_extension(const char *path)
{
    const char *slash = strrchr(path, '/'), *base = slash ? slash + 1 : path, *dot = strrchr(base, '.');
    return dot && dot != base ? dot : path + strlen(path);
}

const char *rr_nearest_name(const char *word, const char *const *names)
{
    const char *best = NULL;
    int best_d = INT_MAX;
    for (const char *const *p = names; *p; p++) {
        int limit = (int)strlen(*p) / 3, d = edit_distance(word, *p);
        limit = limit < 1 ? 1 : limit > 3 ? 3 : limit;
        if (d <= limit && d < best_d)
            best = *p, best_d = d;
    }
    return best;
}

const char *rr_did_you_mean(const char *word, const char *const *names, const char *prefix, const char *suffix,
                            char *buf, size_t size)
{
    const char *near = rr_nearest_name(word, names);
    if (!near)
        return "";
    snprintf(buf, size, " (did you mean '%s%s%s'?)", prefix, near, suffix);
    return buf;
}
