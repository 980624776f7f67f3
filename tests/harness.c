#include "harness.h"

#include <string.h>

#define MAX_TESTS 512

static struct {
    const char *name;
    test_fn fn;
} tests[MAX_TESTS];
static int ntests, current_failed;

void harness_register(const char *name, test_fn fn)
{
    if (ntests < MAX_TESTS) {
        tests[ntests].name = name;
        tests[ntests].fn = fn;
        ntests++;
    }
}

void harness_check(int ok, const char *expr, const char *file, int line)
{
    if (!ok) {
        printf("  FAIL %s:%d: %s\n", file, line, expr);
        current_failed = 1;
    }
}

void harness_check_near(double a, double b, double tol, const char *expr, const char *file, int line)
{
    if (!(fabs(a - b) <= tol)) {
        printf("  FAIL %s:%d: %s: %.17g vs %.17g (difference %.3g, tolerance %.3g)\n", file, line, expr, a, b,
               fabs(a - b), tol);
        current_failed = 1;
    }
}

int harness_failed_now(void) { return current_failed; }

int main(int argc, char **argv)
{
    int passed = 0, failed = 0;
    for (int i = 0; i < ntests; i++) {
        if (argc > 1 && !strstr(tests[i].name, argv[1]))
            continue;
        current_failed = 0;
        tests[i].fn();
        printf("%s %s\n", current_failed ? "FAIL" : "ok  ", tests[i].name);
        if (current_failed)
            failed++;
        else
            passed++;
    }
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
