/* Samplers: the defining property of each (stratification, net property),
 * range, determinism, and unbiasedness of a known integral. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "render/sampler.h"

typedef struct {
    double x[4096], y[4096], t[4096], w[4096];
} batch_buf;

/* every test's shutter: [2, 3.5) */
#define T0 2.0
#define T1 3.5

static sampler make(sampler_kind kind, int grid, int tspp, int factor)
{
    sampler s = {kind, 12345, grid, tspp, factor, 0};
    return s;
}

static void run_batch(const sampler *s, uint64_t pixel, uint32_t batch, batch_buf *b)
{
    sampler_scratch sc;
    CHECK(sampler_scratch_init(&sc, s) == 0);
    sampler_batch(s, T0, T1, pixel, 7, 9, batch, &sc, b->x, b->y, b->t, b->w);
    sampler_scratch_free(&sc);
}

static batch_buf buf, buf2;

TEST(spp_rounds_to_nearest_square_grid)
{
    CHECK(sampler_grid_for_spp(1) == 1);
    CHECK(sampler_grid_for_spp(4) == 2);
    CHECK(sampler_grid_for_spp(5) == 2);
    CHECK(sampler_grid_for_spp(7) == 3);
    CHECK(sampler_grid_for_spp(16) == 4);
    CHECK(sampler_grid_for_spp(0) == 1);
}

TEST(thesis_spatial_samples_hit_every_stratum_once_and_share_their_position)
{
    sampler s = make(SAMPLER_THESIS, 5, 3, 4);
    for (uint64_t pixel = 0; pixel < 30; pixel++) {
        run_batch(&s, pixel, (uint32_t)pixel % 3, &buf);
        int seen[25] = {0};
        for (int i = 0; i < 25; i++) {
            double x = buf.x[3 * i], y = buf.y[3 * i];
            CHECK(x >= 7 && x < 8 && y >= 9 && y < 10);
            seen[(int)((y - 9) * 5) * 5 + (int)((x - 7) * 5)]++;
            CHECK(buf.x[3 * i + 2] == x && buf.y[3 * i + 1] == y);
        }
        for (int c = 0; c < 25; c++)
            CHECK(seen[c] == 1);
    }
}

TEST(thesis_times_are_distinct_fine_strata_inside_shutter)
{
    sampler s = make(SAMPLER_THESIS, 2, 10, 4);
    run_batch(&s, 3, 0, &buf);
    for (int i = 0; i < 4; i++) {
        int used[40] = {0};
        for (int k = 0; k < 10; k++) {
            double t = buf.t[10 * i + k];
            CHECK(t >= 2.0 && t < 3.5);
            int stratum = (int)((t - 2.0) / 1.5 * 40);
            CHECK(used[stratum] == 0);
            used[stratum] = 1;
        }
    }
}

TEST(jittered3d_hits_every_xyt_cell_exactly_once)
{
    sampler s = make(SAMPLER_JITTERED3D, 3, 8, 1);
    for (uint32_t batch = 0; batch < 5; batch++) {
        run_batch(&s, 11, batch, &buf);
        int seen[3 * 3 * 8] = {0};
        for (int i = 0; i < 72; i++) {
            int cx = (int)((buf.x[i] - 7) * 3), cy = (int)((buf.y[i] - 9) * 3);
            int ct = (int)((buf.t[i] - 2.0) / 1.5 * 8);
            CHECK(cx >= 0 && cx < 3 && cy >= 0 && cy < 3 && ct >= 0 && ct < 8);
            seen[(cy * 3 + cx) * 8 + ct]++;
        }
        for (int c = 0; c < 72; c++)
            CHECK(seen[c] == 1);
    }
}

TEST(sobol_directions_follow_their_recurrences)
{
    /* the classic second dimension: 1/2, 3/4, 1/4 at indices 1, 2, 3 */
    CHECK(sobol_u32(1, 1) == 0x80000000u && sobol_u32(2, 1) == 0xc0000000u && sobol_u32(3, 1) == 0x40000000u);
    /* recompute the third dimension's direction numbers from m1 = 1, m2 = 3 */
    uint32_t m[32] = {1, 3};
    for (int k = 2; k < 32; k++)
        m[k] = (2u * m[k - 1]) ^ (4u * m[k - 2]) ^ m[k - 2];
    for (int j = 0; j < 32; j++)
        CHECK(sobol_u32(1u << j, 2) == m[j] << (31 - j));
    CHECK(sobol_u32(1u << 5, 0) == 1u << 26); /* van der Corput */
}

/* Every elementary interval [a/2^i, (a+1)/2^i) x [b/2^j, (b+1)/2^j) with
 * i + j = m holds exactly one of 2^m points. */
static int is_net(const double *x, const double *y, int m)
{
    int n = 1 << m;
    for (int i = 0; i <= m; i++) {
        int j = m - i, *count = calloc((size_t)n, sizeof *count), ok = 1;
        for (int k = 0; k < n; k++)
            count[(int)(x[k] * (1 << i)) * (1 << j) + (int)(y[k] * (1 << j))]++;
        for (int c = 0; c < n; c++)
            ok &= count[c] == 1;
        free(count);
        if (!ok)
            return 0;
    }
    return 1;
}

TEST(sobol_first_dimensions_form_scrambled_0m2_nets)
{
    sampler s = make(SAMPLER_SOBOL, 4, 16, 1); /* 256 samples per batch */
    double x[256], y[256];
    for (uint64_t pixel = 0; pixel < 20; pixel++)
        for (uint32_t batch = 0; batch < 3; batch++) {
            run_batch(&s, pixel, batch, &buf);
            for (int k = 0; k < 256; k++)
                x[k] = buf.x[k] - 7, y[k] = buf.y[k] - 9;
            CHECK(is_net(x, y, 8));
            for (int k = 0; k < 64; k++) /* the batch comes in time order: the 64 points of the shutter's second quarter form a net too */
                x[k] = buf.x[64 + k] - 7, y[k] = buf.y[64 + k] - 9;
            CHECK(is_net(x, y, 6));
        }
    /* scrambling differs between pixels */
    run_batch(&s, 1, 0, &buf);
    run_batch(&s, 2, 0, &buf2);
    CHECK(memcmp(buf.x, buf2.x, 256 * sizeof(double)) != 0);
}

TEST(samplers_are_deterministic_and_batches_differ)
{
    for (int kind = 0; kind < 3; kind++) {
        sampler s = make((sampler_kind)kind, 2, 8, 4);
        run_batch(&s, 77, 1, &buf);
        run_batch(&s, 77, 1, &buf2);
        size_t used = 32 * sizeof(double); /* n = 2*2*8 samples */
        CHECK(memcmp(buf.x, buf2.x, used) == 0 && memcmp(buf.y, buf2.y, used) == 0 &&
              memcmp(buf.t, buf2.t, used) == 0);
        run_batch(&s, 77, 2, &buf2);
        CHECK(memcmp(buf.t, buf2.t, 32 * sizeof(double)) != 0);
    }
}

TEST(samplers_are_unbiased_for_a_known_integral)
{
    /* f(x, y, t) = x' y' + t' (primes: positions in pixel and shutter in
       [0,1)) has mean 1/4 + 1/2 = 0.75. The mean over 400 pixels x 2 batches
       of each batch's estimate must be within 5 standard errors of 0.75,
       the standard error estimated from the spread of the estimates. */
    for (int kind = 0; kind < 3; kind++) {
        sampler s = make((sampler_kind)kind, 2, 4, 4);
        double sum = 0, sumsq = 0;
        int n = 0;
        for (uint64_t pixel = 0; pixel < 400; pixel++)
            for (uint32_t batch = 0; batch < 2; batch++, n++) {
                run_batch(&s, pixel, batch, &buf);
                double est = 0;
                for (int i = 0; i < 16; i++)
                    est += (buf.x[i] - 7) * (buf.y[i] - 9) + (buf.t[i] - 2.0) / 1.5;
                est /= 16;
                sum += est, sumsq += est * est;
            }
        double mean = sum / n, sd = sqrt(fmax(sumsq / n - mean * mean, 0) * n / (n - 1));
        CHECK_NEAR(mean, 0.75, 5 * sd / sqrt(n) + 1e-12);
    }
}

TEST(thesis_times_are_uniform_on_the_shutter)
{
    /* mean within 5 standard errors (sd of U[2,3.5] = 1.5/sqrt 12) and each
       fine stratum picked about equally often (within 5 binomial sd) */
    sampler s = make(SAMPLER_THESIS, 2, 5, 4);
    enum { M = 20 };
    int counts[M] = {0};
    double sum = 0;
    long n = 0;
    for (uint64_t pixel = 0; pixel < 20000; pixel++) {
        run_batch(&s, pixel, 0, &buf);
        for (int k = 0; k < 20; k++, n++) {
            sum += buf.t[k];
            counts[(int)((buf.t[k] - 2.0) / 1.5 * M)]++;
        }
    }
    CHECK_NEAR(sum / n, 2.75, 5 * 1.5 / sqrt(12.0) / sqrt((double)n));
    double p = 1.0 / M, sd = sqrt(n * p * (1 - p));
    for (int j = 0; j < M; j++)
        CHECK_NEAR(counts[j], n * p, 5 * sd);
}

TEST(uniform_numbers_are_in_unit_interval_with_mean_half)
{
    double sum = 0;
    int ok = 1;
    for (uint64_t i = 0; i < 100000; i++) {
        double u = sampler_uniform(9, i, i * 3, 2);
        ok &= u >= 0 && u < 1;
        sum += u;
    }
    CHECK(ok);
    CHECK_NEAR(sum / 100000, 0.5, 5 * sqrt(1 / 12.0 / 100000));
}

/* Regression: counts in 64 bits (spp 4096 and tspp 10^6 overflowed an int). */
TEST(sampler_check_refuses_counts_past_int)
{
    sampler s = {SAMPLER_THESIS, 1, 64, 1000000, 1, 0}; /* spp 4096, tspp 10^6 */
    CHECK(sampler_count(&s) == 4096000000LL);
    CHECK(sampler_check(&s, NULL) == -1);
    sampler sob = {SAMPLER_SOBOL, 1, 1, 1 << 20, 1, 0};
    CHECK(sampler_check(&sob, NULL) == 0);
}

/* Batches of sobol are independent replicates: each its own scramble of the
 * sequence's first n points. Consecutive blocks of one sequence (as before)
 * would together form a net of 2n points; independent scrambles almost never
 * do, and batch 1 is a net on its own. */
TEST(sobol_batches_are_independent_scrambles_not_blocks_of_one_sequence)
{
    sampler s = make(SAMPLER_SOBOL, 1, 64, 1);
    double x[128], y[128];
    int joint_nets = 0;
    for (uint64_t pixel = 0; pixel < 20; pixel++) {
        run_batch(&s, pixel, 0, &buf);
        run_batch(&s, pixel, 1, &buf2);
        for (int k = 0; k < 64; k++) {
            x[k] = buf.x[k] - 7, y[k] = buf.y[k] - 9;
            x[64 + k] = buf2.x[k] - 7, y[64 + k] = buf2.y[k] - 9;
        }
        CHECK(is_net(x + 64, y + 64, 6));
        joint_nets += is_net(x, y, 7);
    }
    CHECK(joint_nets <= 2);
}

/* Equal strata (one batch, no error bars): every weight is 1. */
TEST(equal_strata_weigh_every_sample_one)
{
    for (int kind = 0; kind < 3; kind++) {
        sampler s = make((sampler_kind)kind, 2, 16, 4);
        run_batch(&s, 5, 3, &buf);
        for (int i = 0; i < 64; i++)
            CHECK(buf.w[i] == 1.0);
    }
}

/* The thesis sampler keeps its own images: weights 1 whatever random_strata. */
TEST(thesis_ignores_random_strata)
{
    sampler s = make(SAMPLER_THESIS, 2, 16, 4), r = s;
    r.random_strata = 1;
    run_batch(&s, 9, 2, &buf);
    run_batch(&r, 9, 2, &buf2);
    CHECK(memcmp(buf.t, buf2.t, 64 * sizeof(double)) == 0);
    for (int i = 0; i < 64; i++)
        CHECK(buf2.w[i] == 1.0);
}

/* Random strata: the times of a spatial cell (jittered3d) or of the batch
 * (sobol, n a power of two) hold one time per stratum of the sampler, so the
 * strata's widths, m w / m, add up to the shutter: the weights sum to m. */
TEST(random_strata_weights_are_positive_and_sum_to_the_count)
{
    for (int kind = 1; kind < 3; kind++) {
        sampler s = make((sampler_kind)kind, 1, 64, 1);
        s.random_strata = 1;
        for (uint64_t pixel = 0; pixel < 50; pixel++) {
            run_batch(&s, pixel, (uint32_t)pixel % 4, &buf);
            double sum = 0;
            int ok = 1;
            for (int i = 0; i < 64; i++) {
                ok &= buf.w[i] > 0 && buf.w[i] < 2 && buf.t[i] >= T0 && buf.t[i] < T1;
                sum += buf.w[i];
            }
            CHECK(ok);
            CHECK_NEAR(sum, 64.0, 1e-9);
        }
    }
}

/* The estimate of a step in time, sum w [t < s] / sum w: unbiased (mean over
 * 4000 batches within 5 standard errors of the step's place) and not on a
 * lattice (two batches of a pixel practically never agree exactly), which is
 * what lets the batches' spread see the step's error. With equal strata the
 * estimate is a count over 64, and batches agree often: that half of the
 * test is the planted bug, and it must find ties. */
static void step_estimates(sampler *s, double step, double *est, int n)
{
    for (int k = 0; k < n; k++) {
        run_batch(s, (uint64_t)k / 2, (uint32_t)k % 2, &buf);
        double hit = 0, sum = 0;
        for (int i = 0; i < 64; i++) {
            hit += buf.w[i] * (buf.t[i] < T0 + step * (T1 - T0));
            sum += buf.w[i];
        }
        est[k] = hit / sum;
    }
}

static int pairs_agreeing(const double *est, int n)
{
    int ties = 0;
    for (int k = 0; k + 1 < n; k += 2)
        ties += est[k] == est[k + 1];
    return ties;
}

TEST(random_strata_estimate_a_step_without_bias_or_lattice)
{
    static double est[4000];
    for (int kind = 1; kind < 3; kind++) {
        sampler s = make((sampler_kind)kind, 1, 64, 1);
        s.random_strata = 1;
        step_estimates(&s, 0.3037, est, 4000);
        double sum = 0, sumsq = 0;
        for (int k = 0; k < 4000; k++)
            sum += est[k], sumsq += est[k] * est[k];
        double mean = sum / 4000, sd = sqrt(fmax(sumsq / 4000 - mean * mean, 0));
        CHECK_NEAR(mean, 0.3037, 5 * sd / sqrt(4000.0));
        CHECK(pairs_agreeing(est, 4000) == 0);
        s.random_strata = 0;
        step_estimates(&s, 0.3037, est, 4000);
        CHECK(pairs_agreeing(est, 4000) > 200);
    }
}

/* sobol's times, without error bars, fall one in each 1/n of the shutter
 * whatever the count: a power of two by the net property, any other count
 * by the rank of its time (sampler.c, rank_stratified_times). The first 400
 * points of the sequence are nets of 256, 128 and 16 points, whose times
 * were even only in sixteenths (a planted return of the sequence's own
 * times fails this for 400, 100, 12 and 9); with error bars each half holds
 * n / 2 of them, so the weights sum to n. */
TEST(sobol_times_fall_one_in_each_nth_of_the_shutter_for_any_count)
{
    static const int grids[] = {2, 1, 2, 1, 2}, tspps[] = {100, 100, 3, 9, 64};
    for (int c = 0; c < 5; c++) {
        sampler s = make(SAMPLER_SOBOL, grids[c], tspps[c], 1);
        int n = (int)sampler_count(&s);
        for (uint64_t pixel = 0; pixel < 8; pixel++) {
            run_batch(&s, pixel, (uint32_t)pixel % 3, &buf);
            int ok = 1;
            for (int k = 0; k < n; k++) /* in time order: the k-th time in the k-th stratum */
                ok &= (int)floor((buf.t[k] - T0) / (T1 - T0) * n) == k;
            CHECK(ok);
        }
        s.random_strata = 1;
        run_batch(&s, 3, 1, &buf);
        double sum = 0;
        for (int k = 0; k < n; k++)
            sum += buf.w[k];
        CHECK_NEAR(sum, (double)n, 1e-9); /* odd n: equal strata, weights 1 */
    }
}

/* Rank-stratified times keep the estimate unbiased where position and time
 * interact: f = x' t' + y' (primes: places in the pixel and the shutter) has
 * mean 1/4 + 1/2; the mean over 2000 batches of 12 and of 400 samples is
 * within 5 standard errors of it (from the batches' spread). */
TEST(sobol_with_any_count_is_unbiased_where_position_and_time_interact)
{
    static const int tspps[] = {3, 100};
    for (int c = 0; c < 2; c++) {
        sampler s = make(SAMPLER_SOBOL, 2, tspps[c], 1);
        int n = (int)sampler_count(&s), batches = 2000;
        double sum = 0, sumsq = 0;
        for (int b = 0; b < batches; b++) {
            run_batch(&s, (uint64_t)b / 2, (uint32_t)b % 2, &buf);
            double est = 0;
            for (int i = 0; i < n; i++)
                est += (buf.x[i] - 7) * (buf.t[i] - T0) / (T1 - T0) + (buf.y[i] - 9);
            est /= n;
            sum += est, sumsq += est * est;
        }
        double mean = sum / batches, sd = sqrt(fmax(sumsq / batches - mean * mean, 0) * batches / (batches - 1));
        CHECK_NEAR(mean, 0.75, 5 * sd / sqrt(batches) + 1e-12);
    }
}
