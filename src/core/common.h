/* Shared small types: error values and double-precision 3-vectors.
 * Errors are values (they travel up to the command, which alone decides
 * to print and exit): a function that can fail returns 0 on
 * success or -1 after filling an rr_error with "file:line: reason". */
#ifndef RR_COMMON_H
#define RR_COMMON_H

#include "core/interval.h"

#include <math.h>
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define RR_VERSION "0.1.0"

#ifdef __cplusplus
extern "C" { /* preview.cpp reports through rr_error too */
#endif

typedef struct {
    char msg[1024];
} rr_error;

/* Largest image refrender renders or reads: 2^26 pixels (8192 x 8192). A
 * render state holds ~112 bytes a pixel, so this bounds what any file,
 * crafted or not, can make the readers allocate (7.5 GB). */
/* How far from the origin anything may reach, in every space (world and
 * each object's own), in every input: splat, Gaussian and trajectory
 * coordinates, activated Gaussian scales, splat radii, and what a scene
 * sweeps through during a shutter. Readers refuse values beyond it, and
 * accel_build refuses scenes that reach past it. Why 1e15: values are stored
 * in floats and squared in ray tests (1e15^2 is far below FLT_MAX =
 * 3.4e38), and Embree drops boxes beyond about 1.8e18 without a word (a
 * Gaussian at 1e19 vanished from the image). */
#define RR_MAX_REACH 1e15

#define RR_MAX_PIXELS ((long long)1 << 26)

/* Formats msg into err (if err is non-NULL) and returns -1. */
int rr_fail(rr_error *err, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* Warnings a reader returns to its caller, who decides to print them (only
 * main() prints). The first RR_WARNINGS_KEPT are kept, the rest counted. */
#define RR_WARNINGS_KEPT 8
typedef struct {
    int count; /* all warnings, kept or not */
    char msg[RR_WARNINGS_KEPT][512];
} rr_warnings;

void rr_warn(rr_warnings *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Invariant checks (after pbrt-v4's util/check.h): a failed check prints
 * "file:line: check failed: cond" (with the values, for RR_CHECK_LT/LE) and
 * aborts, because past a broken invariant (a scratch index, a split depth, a
 * sample count) the output can no longer be trusted. RR_CHECK is always on;
 * RR_DCHECK only in builds with RR_DCHECKS defined (make test, SAN=1 and the
 * fuzz targets), so it costs nothing in the renderer users run. */
void rr_check_failed(const char *file, int line, const char *cond) __attribute__((noreturn));
void rr_check_failed_values(const char *file, int line, const char *cond, long long a, long long b)
    __attribute__((noreturn));
#define RR_CHECK(cond) ((cond) ? (void)0 : rr_check_failed(__FILE__, __LINE__, #cond))
#define RR_CHECK_OP(a, op, b)                                                                   \
    (((long long)(a) op (long long)(b))                                                         \
         ? (void)0                                                                              \
         : rr_check_failed_values(__FILE__, __LINE__, #a " " #op " " #b, (long long)(a), (long long)(b)))
#define RR_CHECK_LT(a, b) RR_CHECK_OP(a, <, b)
#define RR_CHECK_LE(a, b) RR_CHECK_OP(a, <=, b)
#ifdef RR_DCHECKS
#define RR_DCHECK(cond) RR_CHECK(cond)
#define RR_DCHECK_LT(a, b) RR_CHECK_LT(a, b)
#define RR_DCHECK_LE(a, b) RR_CHECK_LE(a, b)
#else
#define RR_DCHECK(cond) ((void)0)
#define RR_DCHECK_LT(a, b) ((void)0)
#define RR_DCHECK_LE(a, b) ((void)0)
#endif

/* qsort comparator for doubles, ascending. */
int cmp_double(const void *a, const void *b);

/* Room for at least need elements of elem bytes in the malloc'ed (or NULL)
 * array *p of *cap elements, its contents kept: the capacity doubles from
 * 64, so n appends cost O(n) copying in all. 0, or -1 when out of memory or
 * the size overflows (then *p and *cap are unchanged, *p still valid). */
int rr_grow(void **p, size_t *cap, size_t need, size_t elem);
/* rr_grow's capacity rule (also rr_arena_grow's): the capacity that holds
 * need elements of elem bytes, doubling cap (64 if 0), into *n; -1 when
 * the count or its bytes overflow. */
int rr_grown_capacity(size_t cap, size_t need, size_t elem, size_t *n);

/* A float's bits as an unsigned that sorts as the float does (a sort
 * key's upper half, rr_sort_u64). */
static inline uint32_t rr_float_order_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u & 0x80000000u ? ~u : u | 0x80000000u;
}

/* Sorts n 64-bit words ascending (tmp: room for n more): insertion sort in
 * runs of 16, then bottom-up merges between a and tmp; an ascending
 * prefix longer than a run is kept and merged with the rest, sorted. Its callers sort
 * tens to hundreds of words (a key above, an index below: all distinct,
 * so any correct sort gives the one order), nearly in order already:
 * the Gaussian candidates' buckets (rr_lazy_sort). Through qsort's
 * callback such a sort took twice as long (make bench). */
void rr_sort_u64(uint64_t *a, uint64_t *tmp, size_t n);

/* rr_sort_u64's order, finished a prefix at a time: for callers that
 * consume the smallest words first and often stop early (a ray's
 * candidates, in order of their key floors, until its transmittance is
 * spent: it sorted 165 words to use about 55). _begin distributes the n
 * words of a into buckets of their upper halves' ranges (a counting
 * sort, O(n)); _through(k) sorts buckets until a[0..k) is final. scratch:
 * room for 2n words, kept until the last _through. */
typedef struct {
    uint64_t *a, *tmp;
    uint32_t *start; /* bucket b holds a[start[b] .. start[b + 1]) */
    size_t done;     /* a[0..done) final */
    size_t next;     /* the first bucket not yet sorted */
    size_t n_buckets;
} rr_lazy_sort;
void rr_lazy_sort_begin(rr_lazy_sort *s, uint64_t *a, uint64_t *scratch, size_t n);
void rr_lazy_sort_through(rr_lazy_sort *s, size_t k);

/* Round trips through a lossy conversion pair (a value read from a file, kept
 * in another form and written back, e.g. a rotation matrix kept as a
 * quaternion, must write back as the file had it) are made exact by keeping a
 * fixed representative: f (the write-then-read map on n <= 4 doubles) is a
 * function on a finite set, so its orbit from v ends in a cycle; v becomes the
 * cycle's smallest member (lexicographically), which f's orbit from any member
 * of the cycle finds again, so read(write(v)) == v bit for bit. Returns 0, or
 * -1 (v unchanged) if no cycle shows within 512 steps (none did in a million
 * random rotations through transforms.c's matrices). */
int rr_round_trip_representative(double *v, int n, void (*f)(const double *in, double *out, void *ctx), void *ctx);

/* out = a b for 4x4 matrices (out may not alias a or b). */
void mat4_mul(double a[4][4], double b[4][4], double out[4][4]);

/* "Did you mean": of the NULL-terminated names, the one nearest to word, or
 * NULL when none is near enough to be a slip of the keyboard. Near: an
 * edit distance (insertions, deletions, substitutions and swaps of two
 * neighbours, letter case ignored) of at most a third of the name's length,
 * at least 1 and at most 3; ties go to the first. One rule for the command
 * line's options and the scene file's elements and attributes. */
const char *rr_nearest_name(const char *word, const char *const *names);
/* " (did you mean 'NAME'?)" with the nearest name quoted as given by
 * prefix (e.g. "--" for options, "<" ">" for elements), or "" when none is
 * near; formatted into buf. */
const char *rr_did_you_mean(const char *word, const char *const *names, const char *prefix, const char *suffix,
                            char *buf, size_t size);

/* A file name's extension: from the last '.' of its base name (after the
 * last '/'), or "" (the end of path) when it has none. A base name's
 * leading dot starts no extension: ".png" is a hidden file without one, as
 * os.path.splitext has it. One rule for -o's check and the preview's
 * format (which once disagreed on ".png"). */
const char *rr_extension(const char *path);

/* Monotonic wall-clock seconds (for progress, checkpoints and timings). */
double rr_seconds(void);

#ifdef __cplusplus
}
#endif

typedef struct {
    double x, y, z;
} vec3;

/* fmax and fmin with glibc's values (the number when one is NaN; which
 * zero a tie of +0 and -0 gives, C leaves open, and GCC may swap libm's
 * operands), inlined: at -O2 GCC calls libm's, 3% of a Gaussian render's
 * time (src/bench/BENCH.md). */
static inline double rr_fmax(double x, double y) { return x >= y || y != y ? x : y; }
static inline double rr_fmin(double x, double y) { return x <= y || y != y ? x : y; }

static inline vec3 v3(double x, double y, double z) { vec3 r = {x, y, z}; return r; }
static inline vec3 v3_add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline vec3 v3_sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline vec3 v3_scale(vec3 a, double s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline double v3_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline vec3 v3_cross(vec3 a, vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double v3_len(vec3 a) { return sqrt(v3_dot(a, a)); }
static inline vec3 v3_normalize(vec3 a)
{
    double l = v3_len(a);
    return l > 0 ? v3_scale(a, 1.0 / l) : a;
}
/* The color of a splat, sphere or model that gives none (scenes/README.md: 0.8 grey);
 * rr_default_color2 is the second color of generated checkerboards. */
static inline vec3 rr_default_color(void) { return v3(0.8, 0.8, 0.8); }
static inline vec3 rr_default_color2(void) { return v3(0.2, 0.2, 0.2); }
static inline int v3_finite(vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* Axis-aligned box; empty when lo > hi. */
typedef struct {
    vec3 lo, hi;
} aabb;

static inline aabb aabb_empty(void)
{
    aabb b = {v3(INFINITY, INFINITY, INFINITY), v3(-INFINITY, -INFINITY, -INFINITY)};
    return b;
}
static inline void aabb_add_point(aabb *b, vec3 p)
{
    b->lo = v3(fmin(b->lo.x, p.x), fmin(b->lo.y, p.y), fmin(b->lo.z, p.z));
    b->hi = v3(fmax(b->hi.x, p.x), fmax(b->hi.y, p.y), fmax(b->hi.z, p.z));
}
static inline void aabb_add_box(aabb *b, aabb o)
{
    aabb_add_point(b, o.lo);
    aabb_add_point(b, o.hi);
}

/* b's corners rounded outward to floats (interval_round_out_f). */
static inline void aabb_round_out(aabb b, float lo[3], float hi[3])
{
    interval_round_out_f(interval_make(b.lo.x, b.hi.x), &lo[0], &hi[0]);
    interval_round_out_f(interval_make(b.lo.y, b.hi.y), &lo[1], &hi[1]);
    interval_round_out_f(interval_make(b.lo.z, b.hi.z), &lo[2], &hi[2]);
}

#endif
