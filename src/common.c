#include "common.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

int rr_fail(rr_error *err, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
    }
    return -1;
}

void rr_warn(rr_warnings *w, const char *fmt, ...)
{
    if (!w)
        return;
    if (w->count < RR_WARNINGS_KEPT) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(w->msg[w->count], sizeof w->msg[w->count], fmt, ap);
        va_end(ap);
    }
    w->count++;
}

int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* A total order on the values' bits: by value, -0 before +0. */
static int lex_less(const double *a, const double *b, int n)
{
    for (int i = 0; i < n; i++) {
        if (a[i] != b[i])
            return a[i] < b[i];
        if (signbit(a[i]) != signbit(b[i]))
            return signbit(a[i]) != 0;
    }
    return 0;
}

int rr_round_trip_representative(double *v, int n, void (*f)(const double *in, double *out, void *ctx), void *ctx)
{
    enum { STEPS = 512 };
    double orbit[STEPS + 1][4];
    memcpy(orbit[0], v, (size_t)n * sizeof *v);
    for (int k = 0; k < STEPS; k++) {
        f(orbit[k], orbit[k + 1], ctx);
        for (int j = 0; j <= k; j++) /* bitwise: a signed zero is a different file */
            if (!memcmp(orbit[j], orbit[k + 1], (size_t)n * sizeof *v)) {
                int best = j;
                for (int c = j + 1; c <= k; c++)
                    if (lex_less(orbit[c], orbit[best], n))
                        best = c;
                memcpy(v, orbit[best], (size_t)n * sizeof *v);
                return 0;
            }
    }
    return -1;
}

double rr_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void mat4_mul(double a[4][4], double b[4][4], double out[4][4])
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            out[r][c] = a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c] + a[r][3] * b[3][c];
}

void rr_check_failed(const char *file, int line, const char *cond)
{
    fprintf(stderr, "%s:%d: check failed: %s\n", file, line, cond);
    abort();
}

void rr_check_failed_values(const char *file, int line, const char *cond, long long a, long long b)
{
    fprintf(stderr, "%s:%d: check failed: %s (%lld vs %lld)\n", file, line, cond, a, b);
    abort();
}

static volatile sig_atomic_t *interrupt_flag;

void rr_interrupt_watch(volatile sig_atomic_t *flag) { interrupt_flag = flag; }

int rr_interrupted(void) { return interrupt_flag && *interrupt_flag; }
