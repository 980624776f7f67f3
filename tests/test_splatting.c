/* splatting/splatting.c: the instants of accumulation and time buckets (thesis
 * sec. 3.6.1 leaves them open): midpoint (k + 1/2) / N as
 * scripts/nframe_average.py, stratified one per stratum, random sorted in
 * the shutter; the seed decides them. */
#include <math.h>

#include "harness.h"
#include "splatting/splatting.h"

static splat_settings settings(splat_times kind, int n, uint64_t seed)
{
    splat_settings s = {.method = SPLAT_ACCUM, .times = kind, .samples = n, .seed = seed};
    return s;
}

/* The shutter [2, 4] (the scene's, which splat_render passes). */
static shutter two_to_four(void)
{
    shutter sh;
    shutter_default(&sh);
    sh.open = 2.0, sh.close = 4.0;
    return sh;
}

TEST(splat_instants_midpoint_are_the_midpoint_rule)
{
    splat_settings s = settings(SPLAT_TIMES_MIDPOINT, 4, 1);
    shutter sh = two_to_four();
    double t[4];
    splat_instants(&s, &sh, t);
    /* open + (k + 1/2) / 4 * 2 */
    CHECK(t[0] == 2.25 && t[1] == 2.75 && t[2] == 3.25 && t[3] == 3.75);
}

TEST(splat_instants_stratified_one_per_stratum_random_sorted)
{
    enum { N = 64 };
    double a[N], b[N], c[N];
    splat_settings s = settings(SPLAT_TIMES_STRATIFIED, N, 7);
    shutter sh = two_to_four();
    splat_instants(&s, &sh, a);
    splat_instants(&s, &sh, b);
    int in_strata = 1, same = 1;
    for (int k = 0; k < N; k++) {
        in_strata &= a[k] >= 2.0 + 2.0 * k / N && a[k] < 2.0 + 2.0 * (k + 1) / N;
        same &= a[k] == b[k];
    }
    CHECK(in_strata);
    CHECK(same);
    s = settings(SPLAT_TIMES_RANDOM, N, 7);
    splat_instants(&s, &sh, c);
    int sorted = 1, inside = 1, differs = 0;
    double mean = 0;
    for (int k = 0; k < N; k++) {
        sorted &= k == 0 || c[k - 1] <= c[k];
        inside &= c[k] >= 2.0 && c[k] < 4.0;
        differs |= c[k] != a[k];
        mean += c[k] / N;
    }
    CHECK(sorted && inside && differs);
    /* uniform on [2, 4]: mean 3, standard error sqrt(1/3 / 64) = 0.072; 5 of them */
    CHECK(fabs(mean - 3.0) < 5 * 0.072);
}
