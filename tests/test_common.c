/* common.h's invariant checks: a failed RR_DCHECK aborts with the file,
 * line, condition and values, and test builds have DCHECKs compiled in
 * (make test builds with RR_DCHECKS; a release build has them as no-ops). */
#include <signal.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "../src/common.h"
#include "harness.h"

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
