/* common.h's invariant checks: a failed RR_DCHECK aborts with the file,
 * line, condition and values, and test builds have DCHECKs compiled in
 * (make test builds with RR_DCHECKS; a release build has them as no-ops). */
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/common.h"
#include "harness.h"

/* "Did you mean": distances worked by hand (one deletion, one swap of
 * neighbours, case), the limit a third of the name's length (at least 1,
 * at most 3), ties to the first name. */
/* One rule for every file name's extension (cli.c's -o check and
 * preview.c's format once disagreed on ".png"): the base name's last dot,
 * not a leading one (os.path.splitext's rule). */
TEST(extension_is_the_base_names_last_dot_but_not_a_leading_one)
{
    CHECK(!strcmp(rr_extension("a/b.png"), ".png"));
    CHECK(!strcmp(rr_extension("out.exr.png"), ".png"));
    CHECK(!strcmp(rr_extension(".png"), ""));
    CHECK(!strcmp(rr_extension("dir/.png"), ""));
    CHECK(!strcmp(rr_extension("dir.exr/out"), ""));
    CHECK(!strcmp(rr_extension("x."), "."));
    CHECK(!strcmp(rr_extension(""), ""));
}

TEST(nearest_name_takes_slips_of_the_keyboard_and_nothing_else)
{
    const char *const opts[] = {"crop-window", "spp", "tspp", "sampler", "seed", NULL};
    CHECK(rr_nearest_name("cropwindow", opts) == opts[0]); /* pbrt's name: one deletion */
    CHECK(rr_nearest_name("samlper", opts) == opts[3]);    /* one swap */
    CHECK(rr_nearest_name("SPP", opts) == opts[1]);        /* case */
    CHECK(rr_nearest_name("sppp", opts) == opts[1]);       /* spp 1, tspp 2 */
    CHECK(rr_nearest_name("sed", opts) == opts[4]);        /* seed 1 (limit 1), spp 2 */
    CHECK(rr_nearest_name("output", opts) == NULL);
    CHECK(rr_nearest_name("sp", opts) == opts[1]);         /* spp 1 */
    CHECK(rr_nearest_name("s", opts) == NULL);             /* spp 2 > its limit 1 */
    const char *const sigma[] = {"kernel_sigma", NULL};  /* limit min(3, 12/3) = 3 */
    CHECK(rr_nearest_name("kernelSigma", sigma) == sigma[0]); /* 1 */
    CHECK(rr_nearest_name("krnelsigam", sigma) == sigma[0]);  /* 3: e, _, a<->m */
    CHECK(rr_nearest_name("kernsigm", sigma) == NULL);        /* 4: e, l, _, a */
    const char *const tie[] = {"seed", "send", NULL};
    CHECK(rr_nearest_name("sed", tie) == tie[0]);
    char buf[64];
    CHECK(!strcmp(rr_did_you_mean("objet", (const char *const[]){"object", NULL}, "<", ">", buf, sizeof buf),
                  " (did you mean '<object>'?)"));
    CHECK(!strcmp(rr_did_you_mean("bogus", (const char *const[]){"object", NULL}, "<", ">", buf, sizeof buf), ""));
}

TEST(dchecks_are_on_in_test_builds_and_abort_with_the_values)
{
#ifndef RR_DCHECKS
    CHECK(!"RR_DCHECKS is not defined: make test builds in build-check/ with it");
#endif
    int fds[2];
    CHECK(pipe(fds) == 0);
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0) {
        dup2(fds[1], 2);
        long depth = 65, limit = 64;
        RR_DCHECK_LE(depth, limit);
        _exit(0); /* not reached when the check fires */
    }
    close(fds[1]);
    char msg[512] = "";
    ssize_t n = read(fds[0], msg, sizeof msg - 1);
    msg[n > 0 ? n : 0] = 0;
    close(fds[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    CHECK(WIFSIGNALED(status) && WTERMSIG(status) == SIGABRT);
    CHECK(strstr(msg, "test_common.c:") && strstr(msg, "check failed: depth <= limit (65 vs 64)"));
}

/* rr_fmax and rr_fmin replace libm's in the hot Gaussian code: the same
 * value as glibc's (called through a pointer, so the compiler cannot
 * inline or reorder it) for every pair of special and ordinary values,
 * NaN included; ties of +0 and -0 may give either zero. */
TEST(inline_fmax_and_fmin_give_libms_values)
{
    const double v[] = {0.0, -0.0, 1.0, -1.0, 0.5, 1e-310, -1e-310, 1e308, INFINITY, -INFINITY, NAN, -NAN, 3.0};
    enum { N = sizeof v / sizeof v[0] };
    int differ = 0;
    for (int a = 0; a < N; a++)
        for (int b = 0; b < N; b++) {
            double (*volatile libm_max)(double, double) = fmax, (*volatile libm_min)(double, double) = fmin;
            double x = v[a], y = v[b], got[2] = {rr_fmax(x, y), rr_fmin(x, y)}, want[2] = {libm_max(x, y), libm_min(x, y)};
            for (int k = 0; k < 2; k++)
                differ += !(got[k] == want[k] || (isnan(got[k]) && isnan(want[k])));
        }
    CHECK(differ == 0);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* rr_sort_u64 gives qsort's order for lengths 0-300, random words and
 * words with an ascending prefix of every length (kept and merged) or
 * nearly sorted ones; and rr_float_order_bits orders floats as < does,
 * signed zeros and infinities included. */
/* rr_lazy_sort finishes, prefix by prefix, exactly rr_sort_u64's order
 * (qsort's, the words being distinct or equal as wholes): random words,
 * upper halves clustered, all equal, two values, one outlier far above
 * the rest (every other word in the first bucket), sizes 0 to 300, the
 * prefixes asked for in random steps (and zero steps), each checked as it
 * is finished and nothing after it required. */
TEST(lazy_sort_finishes_the_prefixes_of_the_full_sort)
{
    uint64_t a[300], b[300], *scratch = malloc(600 * sizeof *scratch); /* (no declared type: it holds 32-bit words too) */
    CHECK(scratch != NULL);
    unsigned st = 5;
    int wrong = 0, trials = 0;
    for (int trial = 0; trial < 4000; trial++) {
        size_t n = (size_t)(rand_r(&st) % 301);
        int kind = trial % 5;
        for (size_t k = 0; k < n; k++) {
            uint32_t hi = kind == 0   ? (uint32_t)rand_r(&st) * 2654435761u
                          : kind == 1 ? 0x40000000u + (uint32_t)(rand_r(&st) % 50)
                          : kind == 2 ? 7u
                          : kind == 3 ? (uint32_t)(rand_r(&st) % 2) * 0x80000000u
                                      : (k == n / 2 ? 0xffffffffu : (uint32_t)(rand_r(&st) % 1000));
            a[k] = (uint64_t)hi << 32 | (uint64_t)(rand_r(&st) % 64);
        }
        memcpy(b, a, n * sizeof *a);
        qsort(b, n, sizeof *b, cmp_u64);
        rr_lazy_sort s;
        rr_lazy_sort_begin(&s, a, scratch, n);
        for (size_t k = 0; k <= n; k += (size_t)(rand_r(&st) % 20)) {
            rr_lazy_sort_through(&s, k);
            wrong += memcmp(a, b, k * sizeof *a) != 0;
        }
        rr_lazy_sort_through(&s, n);
        wrong += memcmp(a, b, n * sizeof *a) != 0;
        trials++;
    }
    free(scratch);
    printf("    %d arrays, %d prefixes differing from qsort's\n", trials, wrong);
    CHECK(wrong == 0);
}

TEST(u64_sort_agrees_with_qsort_and_float_bits_sort_as_floats)
{
    uint64_t a[300], b[300], tmp[300];
    unsigned st = 3;
    int wrong = 0;
    for (int trial = 0; trial < 3000; trial++) {
        size_t n = (size_t)(rand_r(&st) % 301), prefix = n ? (size_t)rand_r(&st) % (n + 1) : 0;
        for (size_t k = 0; k < n; k++)
            a[k] = (uint64_t)rand_r(&st) << 20 ^ (uint64_t)(rand_r(&st) % 64);
        if (trial % 3 == 0)
            qsort(a, prefix, sizeof *a, cmp_u64);
        else if (trial % 3 == 1)
            for (size_t k = 0; k < n; k++)
                a[k] = (uint64_t)k * 1000 + (uint64_t)(rand_r(&st) % 3000);
        memcpy(b, a, n * sizeof *a);
        rr_sort_u64(a, tmp, n);
        qsort(b, n, sizeof *b, cmp_u64);
        wrong += memcmp(a, b, n * sizeof *a) != 0;
    }
    CHECK(wrong == 0);
    const float f[] = {-INFINITY, -3.5f, -1e-30f, -0.0f, 1e-40f, 2.0f, 3e38f, INFINITY};
    for (size_t k = 1; k < sizeof f / sizeof *f; k++)
        CHECK(rr_float_order_bits(f[k - 1]) < rr_float_order_bits(f[k]));
    CHECK(rr_float_order_bits(0.0f) == rr_float_order_bits(-0.0f) + 1); /* -0 just before +0 */
}

/* rr_grow: the contents survive a doubling, the capacity covers the need,
 * and a size past SIZE_MAX is refused without touching the array. */
TEST(grow_keeps_contents_and_refuses_overflow)
{
    int *a = NULL;
    size_t cap = 0;
    for (int i = 0; i < 1000; i++) {
        CHECK(rr_grow((void **)&a, &cap, (size_t)i + 1, sizeof *a) == 0 && cap >= (size_t)i + 1);
        a[i] = i;
    }
    int intact = 1;
    for (int i = 0; i < 1000; i++)
        intact &= a[i] == i;
    CHECK(intact);
    int *before = a;
    size_t cap_before = cap;
    CHECK(rr_grow((void **)&a, &cap, SIZE_MAX / 2, sizeof *a) == -1 && a == before && cap == cap_before);
    CHECK(rr_grow((void **)&a, &cap, SIZE_MAX, 1) == -1 && a == before && cap == cap_before);
    free(a);
}

/* Rounded outward: strictly outside x whether x is a float (1) or lies
 * between two (0.1), so a float box so made holds the double box. */
TEST(outward_rounding_lies_strictly_outside)
{
    const double xs[] = {1.0, 0.1, -0.1, 1e-30, -3e7 + 0.3};
    for (int i = 0; i < 5; i++)
        CHECK((double)rr_float_below(xs[i]) < xs[i] && (double)rr_float_above(xs[i]) > xs[i]);
    aabb b = {v3(0.1, -0.2, 1.0), v3(0.3, 0.7, 1.0)};
    float lo[3], hi[3];
    aabb_round_out(b, lo, hi);
    CHECK(lo[0] < 0.1 && lo[1] < -0.2 && lo[2] < 1.0 && hi[0] > 0.3 && hi[1] > 0.7 && hi[2] > 1.0);
}
