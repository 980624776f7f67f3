/* The thesis sampler (sec. 4.5): stratification, range, determinism and
 * unbiasedness of the time distribution. */
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "sampler.h"

static sampler make(int grid, int tspp, int factor)
{
    sampler s = {12345, grid, tspp, factor, 2.0, 3.5};
    return s;
}

TEST(spp_rounds_to_nearest_square_grid)
{
    CHECK(sampler_grid_for_spp(1) == 1);
    CHECK(sampler_grid_for_spp(4) == 2);
    CHECK(sampler_grid_for_spp(5) == 2);
    CHECK(sampler_grid_for_spp(7) == 3);
    CHECK(sampler_grid_for_spp(16) == 4);
    CHECK(sampler_grid_for_spp(0) == 1);
}

TEST(spatial_samples_hit_every_stratum_exactly_once)
{
    sampler s = make(5, 4, 4);
    for (uint64_t pixel = 0; pixel < 50; pixel++) {
        int seen[25] = {0};
        for (int i = 0; i < 25; i++) {
            double x, y;
            sampler_position(&s, pixel, 7, 9, i, &x, &y);
            CHECK(x >= 7 && x < 8 && y >= 9 && y < 10);
            int cx = (int)((x - 7) * 5), cy = (int)((y - 9) * 5);
            seen[cy * 5 + cx]++;
        }
        for (int c = 0; c < 25; c++)
            CHECK(seen[c] == 1);
    }
}

TEST(time_samples_are_distinct_fine_strata_inside_shutter)
{
    sampler s = make(2, 10, 4);
    int m = 40;
    double jitter[40], times[10];
    int perm[40];
    sampler_time_jitter(&s, 3, jitter);
    for (int i = 0; i < 4; i++) {
        sampler_times(&s, 3, i, jitter, perm, times);
        int used[40] = {0};
        for (int k = 0; k < 10; k++) {
            CHECK(times[k] >= 2.0 && times[k] < 3.5);
            int stratum = (int)((times[k] - 2.0) / 1.5 * m);
            CHECK(used[stratum] == 0);
            used[stratum] = 1;
            /* the time sits at its stratum's per-pixel jitter */
            CHECK_NEAR(times[k], 2.0 + 1.5 * (stratum + jitter[stratum]) / m, 1e-12);
        }
    }
}

TEST(sampler_is_deterministic_and_pixels_differ)
{
    sampler s = make(2, 8, 4);
    double j1[32], j2[32], t1[8], t2[8];
    int perm[32];
    sampler_time_jitter(&s, 77, j1);
    sampler_time_jitter(&s, 77, j2);
    CHECK(memcmp(j1, j2, sizeof j1) == 0);
    sampler_times(&s, 77, 1, j1, perm, t1);
    sampler_times(&s, 77, 1, j2, perm, t2);
    CHECK(memcmp(t1, t2, sizeof t1) == 0);
    sampler_time_jitter(&s, 78, j2);
    CHECK(memcmp(j1, j2, sizeof j1) != 0);
    s.seed++;
    sampler_time_jitter(&s, 77, j2);
    CHECK(memcmp(j1, j2, sizeof j1) != 0);
}

TEST(time_samples_are_uniform_on_the_shutter)
{
    /* Each time is uniform on [t0, t1]: the mean of N times is within 5
       standard errors (sd of U[2,3.5] = 1.5/sqrt 12) of 2.75, and every fine
       stratum is picked about equally often (each count within 5 sd of its
       binomial mean). */
    sampler s = make(2, 5, 4);
    enum { M = 20 };
    double jitter[M], times[5];
    int perm[M], counts[M] = {0};
    double sum = 0;
    long n = 0;
    for (uint64_t pixel = 0; pixel < 20000; pixel++) {
        sampler_time_jitter(&s, pixel, jitter);
        for (int i = 0; i < 4; i++) {
            sampler_times(&s, pixel, i, jitter, perm, times);
            for (int k = 0; k < 5; k++, n++) {
                sum += times[k];
                counts[(int)((times[k] - 2.0) / 1.5 * M)]++;
            }
        }
    }
    double se = 1.5 / sqrt(12.0) / sqrt((double)n);
    CHECK_NEAR(sum / n, 2.75, 5 * se);
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
