#include "harness.h"

#include <stdlib.h>
#include <string.h>

/* The list grows: a fixed table once dropped every test past its size
 * without a word. */
static struct test_entry {
    const char *name;
    test_fn fn;
} *tests;
static int ntests, capacity, current_failed;
static const char *current_skip; /* why the running test was skipped; NULL: it ran */

void harness_register(const char *name, test_fn fn)
{
    if (ntests == capacity) {
        capacity = capacity ? 2 * capacity : 256;
        struct test_entry *grown = realloc(tests, (size_t)capacity * sizeof *tests);
        if (!grown) {
            fprintf(stderr, "harness: out of memory registering %s\n", name);
            exit(2);
        }
        tests = grown;
    }
    tests[ntests].name = name;
    tests[ntests].fn = fn;
    ntests++;
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

void harness_skip(const char *why) { current_skip = why; }

/* Is name among the n names? */
static int named(const char *name, int n, char **names)
{
    for (int k = 0; k < n; k++)
        if (!strcmp(name, names[k]))
            return 1;
    return 0;
}

int main(int argc, char **argv)
{
    int passed = 0, failed = 0, skipped = 0;
    if (argc > 1 && !strcmp(argv[1], "--list")) { /* tests/test_harness.py counts them */
        for (int i = 0; i < ntests; i++)
            printf("%s\n", tests[i].name);
        free(tests);
        return 0;
    }
    /* --only NAME...: those tests alone (make test runs each file's as a
     * pytest item, tests/test_unit_tests.py, so pytest's workers share
     * them out); otherwise the tests whose name holds the filter */
    int only = argc > 2 && !strcmp(argv[1], "--only");
    const char *filter = only ? argv[2] : argc > 1 ? argv[1] : "";
    for (int i = 0; i < ntests; i++) {
        if (only ? !named(tests[i].name, argc - 2, argv + 2) : !strstr(tests[i].name, filter))
            continue;
        current_failed = 0, current_skip = NULL;
        tests[i].fn();
        if (current_failed)
            printf("FAIL %s\n", tests[i].name), failed++;
        else if (current_skip)
            printf("SKIP %s: %s\n", tests[i].name, current_skip), skipped++;
        else
            printf("ok   %s\n", tests[i].name), passed++;
    }
    if (skipped)
        printf("%d passed, %d failed, %d skipped\n", passed, failed, skipped);
    else
        printf("%d passed, %d failed\n", passed, failed);
    free(tests);
    /* A filter that names no test ran nothing: that is a failure, not a pass. */
    if (passed + failed + skipped == 0) {
        fprintf(stderr, "harness: no test %s '%s'\n", only ? "is named" : "matches", filter);
        return 1;
    }
    return failed ? 1 : 0;
}
