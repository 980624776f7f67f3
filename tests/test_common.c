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
