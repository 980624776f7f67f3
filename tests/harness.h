/* Minimal C test harness: each test_*.c file registers its tests with
 * TEST(name); main in harness.c runs them all and ends with the line
 * "N passed, N failed" (", N skipped" after it when some are). A test
 * fails when any CHECK fails. */
#ifndef RR_HARNESS_H
#define RR_HARNESS_H

#include <math.h>
#include <stdio.h>

typedef void (*test_fn)(void);
void harness_register(const char *name, test_fn fn);
void harness_check(int ok, const char *expr, const char *file, int line);
/* Harness self-check: the number of checks failed so far in this test. */
int harness_failed_now(void);
/* Marks the running test skipped, saying why (it cannot run on this
 * machine): it reports "SKIP name: why", not "ok", so that it never passes
 * by comparing a thing with itself; a failed check still fails it. */
void harness_skip(const char *why);
#define SKIP_UNLESS(cond, why)                                             \
    do {                                                                   \
        if (!(cond)) {                                                     \
            harness_skip(why);                                             \
            return;                                                        \
        }                                                                  \
    } while (0)

#define TEST(name)                                                         \
    static void name(void);                                                \
    __attribute__((constructor)) static void register_##name(void)         \
    {                                                                      \
        harness_register(#name, name);                                     \
    }                                                                      \
    static void name(void)

#define CHECK(expr) harness_check(!!(expr), #expr, __FILE__, __LINE__)
#define CHECK_NEAR(a, b, tol)                                              \
    harness_check_near((double)(a), (double)(b), (double)(tol), #a " ~= " #b, \
                       __FILE__, __LINE__)
/* Fails, printing both values and the tolerance, unless |a - b| <= tol. */
void harness_check_near(double a, double b, double tol, const char *expr, const char *file, int line);

#endif
