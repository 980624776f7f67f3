/* Helpers shared by the dynamic-Gaussian unit tests (test_gaussian_dynamic.c
 * and test_gaussian_fdgs.c): ascii PLY text written from a list of property
 * names and values, parsing it, checking a refusal, and the tests'
 * reproducible random numbers. */
#ifndef RR_GAUSSIAN_TEST_UTIL_H
#define RR_GAUSSIAN_TEST_UTIL_H

#include <stddef.h>
#include <stdint.h>

#include "gaussians/gaussian.h"
#include "formats/gaussian_ply.h"

/* The header of an ascii PLY of n vertices with properties names[0..count),
 * through "end_header\n"; skip names one to leave out (NULL: none), extra
 * one to add after them (NULL: none). Returns the length written. */
size_t ply_ascii_header(char *buf, size_t size, int n, const char *const *names, int count, const char *skip,
                        const char *extra);

/* Appends one vertex's line at buf + len: values[k] with `digits`
 * significant digits for each name the header kept, then 0 for extra.
 * Returns the new length. */
size_t ply_ascii_row(char *buf, size_t size, size_t len, const char *const *names, const double *values, int count,
                     int digits, const char *skip, const char *extra);

/* Parses the text as the file `name` of kind GAUSSIAN_AUTO into m (first
 * initialised); gaussian_parse's result. */
int parse_gaussian_text(const char *name, const char *buf, size_t len, gaussian_model *m, rr_error *e);

/* 1 if the text is refused as the file `name` read as `kind` with a message
 * naming the file and holding needle, and nothing is left allocated;
 * otherwise prints what was said and returns 0. */
int gaussian_text_refused(const char *name, const char *buf, size_t len, gaussian_kind kind, const char *needle);

/* A uniform number in [lo, hi) from a 64-bit LCG (Knuth's MMIX constants)
 * advancing *s: the same sequence on every machine. */
double lcg_uniform(uint64_t *s, double lo, double hi);

#endif
