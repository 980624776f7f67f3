#include "render/sampler.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { DIM_X = 0, DIM_Y = 1, DIM_TIME_JITTER = 2, DIM_TIME_PICK = 3, DIM_T = 4, DIM_SHIFT = 5 };

int sampler_grid_for_spp(int spp)
{
    int k = (int)lround(sqrt((double)(spp > 0 ? spp : 1)));
    return k < 1 ? 1 : k;
}

static const char *const names[] = {"thesis", "jittered3d", "sobol"};

const char *sampler_name(sampler_kind k) { return names[k]; }

int sampler_from_name(const char *name, sampler_kind *k)
{
    for (int i = 0; i < (int)(sizeof names / sizeof *names); i++)
        if (!strcmp(name, names[i])) {
            *k = (sampler_kind)i;
            return 0;
        }
    return -1;
}

/* SplitMix64 finaliser: a bijective mixer with good avalanche. */
static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Random values are counter-based (no state carried between pixels, so any
 * thread order gives the same image): a key from (seed, pixel), then value
 * (b, dim) is SplitMix64 at position 8 b + dim + 1 of the stream seeded by
 * the key. The key is computed once per pixel. */
static uint64_t hash_key(uint64_t seed, uint64_t a)
{
    return mix64(mix64(seed + 0x9e3779b97f4a7c15ULL) ^ (a + 0x632be59bd9b4e019ULL));
}

static uint64_t hash_keyed(uint64_t key, uint64_t b, uint32_t dim)
{
    return mix64(key + ((b << 3) + dim + 1) * 0x9e3779b97f4a7c15ULL);
}

static uint64_t hash4(uint64_t seed, uint64_t a, uint64_t b, uint32_t dim)
{
    return hash_keyed(hash_key(seed, a), b, dim);
}

static double uniform_keyed(uint64_t key, uint64_t b, uint32_t dim)
{
    return (double)(hash_keyed(key, b, dim) >> 11) * (1.0 / 9007199254740992.0); /* 53 bits */
}

double sampler_uniform(uint64_t seed, uint64_t a, uint64_t b, uint32_t dim)
{
    return uniform_keyed(hash_key(seed, a), b, dim);
}

int sampler_scratch_init(sampler_scratch *sc, const sampler *s)
{
    size_t m = (size_t)s->tspp * (size_t)s->time_factor, n = (size_t)sampler_count(s);
    sc->jitter = malloc(m * sizeof *sc->jitter);
    sc->perm = malloc(m * sizeof *sc->perm);
    sc->taken = malloc((m + 63) / 64 * sizeof *sc->taken);
    int sobol = s->kind == SAMPLER_SOBOL; /* only sobol sorts a batch */
    sc->keys = sobol ? malloc(n * sizeof *sc->keys) : NULL;
    sc->points = sobol ? malloc(3 * n * sizeof *sc->points) : NULL;
    return sc->jitter && sc->perm && sc->taken && (!sobol || (sc->keys && sc->points)) ? 0 : -1;
}

void sampler_scratch_free(sampler_scratch *sc)
{
    free(sc->jitter);
    free(sc->perm);
    free(sc->taken);
    free(sc->keys);
    free(sc->points);
    sc->keys = NULL;
    sc->points = NULL;
    sc->jitter = NULL;
    sc->perm = NULL;
    sc->taken = NULL;
}

/* ---- thesis ------------------------------------------------------------- */

/* The times of one ray come out in increasing order (the strata taken are
 * listed in order): successive object-space rays of a moving object are
 * then neighbours, so their BVH nodes and splats are still in cache. The
 * set of samples does not depend on the order. */
static void thesis_times(const sampler *s, double t0, double t1, uint64_t key, int i, sampler_scratch *sc,
                         double *times)
{
    int m = s->tspp * s->time_factor, words = (m + 63) / 64;
    for (int j = 0; j < m; j++)
        sc->perm[j] = j;
    memset(sc->taken, 0, (size_t)words * sizeof *sc->taken);
    for (int k = 0; k < s->tspp; k++) {
        /* choose uniformly among the strata not yet taken (partial Fisher-Yates) */
        uint64_t counter = (uint64_t)i * (uint64_t)m + (uint64_t)k;
        int pick = k + (int)(uniform_keyed(key, counter, DIM_TIME_PICK) * (m - k));
        if (pick >= m)
            pick = m - 1;
        int stratum = sc->perm[pick];
        sc->perm[pick] = sc->perm[k];
        sc->perm[k] = stratum;
        sc->taken[stratum >> 6] |= 1ULL << (stratum & 63);
    }
    /* list the taken strata in order: set bits, lowest first */
    int k = 0;
    for (int w = 0; w < words; w++)
        for (uint64_t bits = sc->taken[w]; bits; bits &= bits - 1) {
            int j = 64 * w + __builtin_ctzll(bits);
            double t = t0 + (t1 - t0) * (j + sc->jitter[j]) / m;
            times[k++] = t < t1 ? t : nextafter(t1, t0);
        }
}

static void thesis_batch(const sampler *s, double t0, double t1, uint64_t seed, uint64_t pixel, int px, int py,
                         sampler_scratch *sc, double *x, double *y, double *t)
{
    int k = s->grid, m = s->tspp * s->time_factor;
    uint64_t key = hash_key(seed, pixel);
    for (int j = 0; j < m; j++)
        sc->jitter[j] = uniform_keyed(key, (uint64_t)j, DIM_TIME_JITTER);
    for (int i = 0; i < k * k; i++) {
        double sx = px + (i % k + uniform_keyed(key, (uint64_t)i, DIM_X)) / k;
        double sy = py + (i / k + uniform_keyed(key, (uint64_t)i, DIM_Y)) / k;
        thesis_times(s, t0, t1, key, i, sc, t + (size_t)i * s->tspp);
        for (int j = 0; j < s->tspp; j++) {
            x[(size_t)i * s->tspp + j] = sx;
            y[(size_t)i * s->tspp + j] = sy;
        }
    }
}

/* ---- time halves with a random boundary --------------------------------- */

/* A batch of a stratified sampler puts its times one in each of n equal
 * strata. With the same strata in every batch, a pixel whose value steps
 * at instants inside the shutter gets batch estimates on a lattice (a
 * count of times over n): the B batches often agree exactly, the standard
 * error is 0 and the pixel is off by up to 1/n (jittered3d and sobol did
 * this; a common shift of the strata does not help, the steps' places in
 * their strata move together). Here each batch cuts the shutter into m
 * coarse pieces at boundaries of its own, b_k = (k + d_k) / m with d_k
 * uniform in [-1/2, 1/2) (b_0 = 0, b_m = 1), and stretches each piece
 * [k/m, (k+1)/m) of the sampler's time linearly onto [b_k, b_{k+1}), with
 * weight m (b_{k+1} - b_k), the inverse of its density: unbiased, and when
 * each piece holds n/m times the weights sum to n. The fine strata inside
 * a piece keep their stratification, stretched by a random factor, so a
 * step's place in its fine stratum is continuous and independent in each
 * batch, and the batches' spread measures the error (tests/test_error_bars.py).
 * m = 2 where the count is even: a weight multiplies the whole sample, and
 * with more pieces the weights' own randomness costs more than it buys
 * where a pixel varies in space (measured, the default scene with the box
 * filter: 1.05x the error of equal strata per batch at m = 2, 1.09x at 4,
 * 1.47x at m = n; on pixels stepping in time 1.15x at 2, 1.25x at n). With
 * an odd count jittered3d gives each time its own piece (m = its count:
 * one time in each, the weights still sum to it) and sobol keeps equal
 * strata (an odd n has no exact halves). Used only where error bars are asked for and the shutter has a
 * length (sampler.random_strata; a batch alone keeps the equal strata). */
static double random_boundary(uint64_t key, uint64_t stream, int k, int m)
{
    if (k <= 0)
        return 0.0;
    if (k >= m)
        return 1.0;
    return (k + uniform_keyed(key, stream * (uint64_t)m + (uint64_t)k, DIM_SHIFT) - 0.5) / m;
}

/* The pieces for `count` times, one per stratum of [0, 1): 2 for an even
 * count, else `odd` (1: equal strata). */
static int time_pieces(int count, int odd) { return count % 2 == 0 ? 2 : odd; }

static double stratified_time(const sampler *s, double t0, double t1, double u, int m, uint64_t key,
                              uint64_t stream, double *w)
{
    if (m < 2 || !s->random_strata || !(t1 > t0)) { /* no error bars, or no time to stratify (--time) */
        *w = 1.0;
        return u;
    }
    int k = (int)(u * m);
    if (k > m - 1)
        k = m - 1;
    double lo = random_boundary(key, stream, k, m), hi = random_boundary(key, stream, k + 1, m);
    *w = m * (hi - lo);
    return lo + (u * m - k) * (hi - lo);
}

/* A sampler time u in [0, 1) on the shutter [t0, t1): strictly below t1. */
static double shutter_time(double t0, double t1, double u)
{
    return fmin(t0 + (t1 - t0) * u, nextafter(t1, t0));
}

/* ---- jittered 3D --------------------------------------------------------- */

static void jittered3d_batch(const sampler *s, double t0, double t1, uint64_t seed, uint64_t pixel, int px, int py,
                             double *x, double *y, double *t, double *w)
{
    int k = s->grid, n = (int)sampler_count(s), m = time_pieces(s->tspp, s->tspp);
    uint64_t key = hash_key(seed, pixel);
    for (int i = 0; i < n; i++) {
        int cell = i / s->tspp, slot = i % s->tspp;
        x[i] = px + (cell % k + uniform_keyed(key, (uint64_t)i, DIM_X)) / k;
        y[i] = py + (cell / k + uniform_keyed(key, (uint64_t)i, DIM_Y)) / k;
        /* each spatial cell's tspp times: one per stratum, its own boundaries */
        double u = (slot + uniform_keyed(key, (uint64_t)i, DIM_T)) / s->tspp;
        t[i] = shutter_time(t0, t1, stratified_time(s, t0, t1, u, m, key, (uint64_t)cell, &w[i]));
    }
}

/* ---- Owen-scrambled Sobol' ----------------------------------------------- */

/* Direction numbers v[j] = m_j << (31 - j): dimension 0 is van der Corput
 * (m_j = 1); dimensions 1 and 2 use the primitive polynomials x + 1 (m_1 =
 * 1) and x^2 + x + 1 (m_1 = 1, m_2 = 3; Joe & Kuo's first entries) with the
 * recurrences m_k = 2 m_{k-1} ^ m_{k-1} and m_k = 2 m_{k-1} ^ 4 m_{k-2} ^
 * m_{k-2}, generated as the index's bits are read (tests/test_sampler.c
 * checks them against the recurrences independently). */
static uint32_t sobol_next_m(int dim, uint32_t m1, uint32_t m2)
{
    if (dim == 0)
        return 1;
    if (dim == 1)
        return 2 * m1 ^ m1;
    return 2 * m1 ^ 4 * m2 ^ m2;
}

uint32_t sobol_u32(uint32_t index, int dim)
{
    uint32_t r = 0, m1 = 1, m2 = 0; /* m_j and m_{j-1} */
    for (int j = 0; index; index >>= 1, j++) {
        if (j > 0) {
            /* x^2 + x + 1 starts with two initial values (1, 3) */
            uint32_t next = j == 1 && dim == 2 ? 3 : sobol_next_m(dim, m1, m2);
            m2 = m1, m1 = next;
        }
        if (index & 1)
            r ^= m1 << (31 - j);
    }
    return r;
}

static uint32_t reverse_bits(uint32_t x)
{
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* Burley 2020: on bit-reversed values the Laine-Karras hash changes each
 * bit only as a function of the bits below it, i.e. each digit of x is
 * permuted depending only on the more significant digits: a nested
 * (Owen) scramble, which keeps net properties. */
uint32_t owen_scramble_u32(uint32_t x, uint32_t seed)
{
    x = reverse_bits(x);
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return reverse_bits(x);
}

static double sobol_sample(uint32_t index, int dim, uint64_t seed, uint64_t pixel)
{
    uint32_t scramble = (uint32_t)hash4(seed, pixel, 0x50b01, (uint32_t)dim);
    uint32_t v = owen_scramble_u32(sobol_u32(index, dim), scramble);
    return (v + 0.5) * (1.0 / 4294967296.0); /* cell center: never 0 or 1 */
}

/* Time order, then the sequence's order: a strict total order, so the
 * sorted batch is the same on every machine and thread. */
static int by_time(const void *a, const void *b)
{
    const sampler_time_key *p = a, *q = b;
    if (p->t != q->t)
        return p->t < q->t ? -1 : 1;
    return (p->index > q->index) - (p->index < q->index);
}

/* Times of a count n that is no power of two: the first n points of the
 * sequence are nets of their power-of-two blocks (400 = 256 + 128 + 16),
 * whose times are even only at the coarsest block's scale (1/16): at 400
 * samples the error of the default scene with the point filter was 1.67x
 * the line from 256 to 512 samples, above the error at 256 itself
 * (src/SAMPLING.md). So the point of time rank k takes a time of its own in
 * the k-th 1/n of the shutter, (k + jitter) / n: one in each, as the times
 * of a power-of-two n already are, in the order the sequence gave.
 * Unbiased: the time scramble and the jitters are independent of the x and
 * y scrambles, each point's (x, y) is uniform and the n times together are
 * one stratified sample of the shutter. keys is sorted by the sequence's
 * times (u); the point of rank k gets sampler time u[k]. */
static void rank_stratified_times(uint64_t key, int n, const sampler_time_key *keys, double *u)
{
    for (int k = 0; k < n; k++)
        u[k] = n & (n - 1) ? (k + uniform_keyed(key, (uint64_t)k, DIM_T)) / n : keys[k].t;
}

/* Each batch is an independent replicate: its own scramble (from the
 * batch's seed) of the sequence's first n points, and with error bars its
 * own time halves. Blocks of one long sequence were not independent (the
 * batches' spread said 3x too much on smooth pixels and up to 16x too
 * little where a pixel steps in time); the price is that B batches average
 * B short sequences, not one long one (src/SAMPLING.md). The points are
 * traced in time order, as the thesis sampler's times are: successive rays
 * then meet the same moving splats and BVH nodes while they are in cache
 * (the sequence's own order jumps across the shutter; on the
 * benchmark-scale view that made a render 2.3x-3.6x slower). */
static void sobol_batch(const sampler *s, double t0, double t1, uint64_t seed, uint64_t pixel, int px, int py,
                        sampler_scratch *sc, double *x, double *y, double *t, double *w)
{
    int n = (int)sampler_count(s);
    uint64_t key = hash_key(seed, pixel);
    int pieces = time_pieces(n, 1); /* with rank-stratified times each half holds n / 2 of them */
    double *p = sc->points; /* x, y of point i at 3 i; its sequence time in its key */
    for (int i = 0; i < n; i++) {
        uint32_t index = (uint32_t)i;
        p[3 * i] = px + sobol_sample(index, 0, seed, pixel);
        p[3 * i + 1] = py + sobol_sample(index, 1, seed, pixel);
        sc->keys[i] = (sampler_time_key){sobol_sample(index, 2, seed, pixel), (uint32_t)i};
    }
    qsort(sc->keys, (size_t)n, sizeof *sc->keys, by_time);
    rank_stratified_times(key, n, sc->keys, t); /* sampler times into t, then mapped in place */
    for (int k = 0; k < n; k++) {
        const double *q = &p[3 * sc->keys[k].index];
        x[k] = q[0], y[k] = q[1];
        t[k] = shutter_time(t0, t1, stratified_time(s, t0, t1, t[k], pieces, key, 0, &w[k]));
    }
}

void sampler_batch(const sampler *s, double t0, double t1, uint64_t pixel, int px, int py, uint32_t batch,
                   sampler_scratch *sc, double *x, double *y, double *t, double *w)
{
    /* batches draw from independent streams */
    uint64_t seed = batch == 0 ? s->seed : mix64(s->seed ^ mix64(0xba7c400000000000ULL + batch));
    switch (s->kind) {
    case SAMPLER_THESIS: /* the thesis weighs its samples equally */
        thesis_batch(s, t0, t1, seed, pixel, px, py, sc, x, y, t);
        for (int64_t i = 0; i < sampler_count(s); i++)
            w[i] = 1.0;
        break;
    case SAMPLER_JITTERED3D:
        jittered3d_batch(s, t0, t1, seed, pixel, px, py, x, y, t, w);
        break;
    case SAMPLER_SOBOL:
        sobol_batch(s, t0, t1, seed, pixel, px, py, sc, x, y, t, w);
        break;
    }
}

int sampler_check(const sampler *s, rr_error *err)
{
    if (s->grid < 1 || s->tspp < 1 || s->time_factor < 1)
        return rr_fail(err, "sample counts must be positive");
    int64_t n = sampler_count(s);
    if ((int64_t)s->tspp * s->time_factor > SAMPLER_MAX_TIME_STRATA || n > SAMPLER_MAX_TIME_STRATA)
        return rr_fail(err, "%lld samples per batch (%dx%d positions x %d times), %lld time strata: at most %d of each",
                       (long long)n, s->grid, s->grid, s->tspp, (long long)s->tspp * s->time_factor,
                       SAMPLER_MAX_TIME_STRATA);
    return 0;
}
