/* What the Gaussian PLY readers share (gaussian_ply.c, gaussian_stg_ply.c,
 * gaussian_fdgs_ply.c): each reads its own layout through ply.h, and all
 * check and store values the same way, so that a value refused by one is
 * refused by the others with the same message. The io layer's own helper:
 * not for the rest of refrender. */
#ifndef RR_GAUSSIAN_PLY_COMMON_H
#define RR_GAUSSIAN_PLY_COMMON_H

#include <stdint.h>

#include "gaussians/gaussian.h"
#include "gaussians/gaussian_dynamic.h"
#include "formats/ply.h"

/* The part of a reader's sink that ply.h's callbacks need in every layout. */
typedef struct {
    gaussian_model *m;
    gaussian_kind forced;
    size_t declared, next;
} gaussian_ply_sink;

/* name is prefix followed by decimal digits only: their value, else -1. */
long gaussian_ply_numbered(const char *name, const char *prefix);

/* Writes fmt with name and value into why; returns -1. */
int gaussian_ply_bad(char *why, size_t size, const char *fmt, const char *name, double value);

/* v as the float the model holds: a value finite as a double but not as a
 * float (a double property of 1e300, ascii 1e39) would be stored as inf,
 * so it is refused naming the property (name) and its value. */
int gaussian_ply_store(float *dst, double v, const char *name, char *why, size_t why_size);

/* Every present slot of v finite, else the first that is not is named. */
int gaussian_ply_check_finite(const double *v, const int *present, const char *const *names, int slots, char *why,
                              size_t why_size);

/* Appends " 'name'" to missing (size bytes) for each slot in [first, end)
 * that present lacks: a begin callback's list of what a model lacks. */
void gaussian_ply_list_missing(char *missing, size_t size, const int *present, const char *const *names, int first,
                               int end);

/* The begin callback's end for the dynamic layouts, which are 3D: refuses
 * kind 2D naming the layout, else sets m 3D and the sink to count. */
int gaussian_ply_begin_3d(gaussian_ply_sink *s, const char *path, const char *layout, size_t count, rr_error *err);

/* Storage for every declared Gaussian, on the first one (after the reader
 * has checked that the file can hold them all), and the motion's when
 * dynamic_alloc is not NULL. */
int gaussian_ply_allocate(gaussian_model *m, size_t declared, gaussian_dynamic *(*dynamic_alloc)(size_t), char *why,
                          size_t why_size);

/* Gaussian i's mean (slots x..x+2 of v) within RR_MAX_REACH and its
 * first `scales` scales (slots scale..), after exp, within
 * RR_MAX_REACH (core/common.h: Embree's range); the others 0. */
int gaussian_ply_store_mean_scale(gaussian_model *m, size_t i, const double *v, const char *const *names, int x,
                                  int scale, int scales, char *why, size_t why_size);

/* The unit quaternion of rot[0..3]: divided by its largest component
 * before squaring, so that components of 1e200 do not overflow q.q and a
 * lone 1e-170 does not underflow it; only zero is refused. */
int gaussian_ply_unit_quaternion(const double *rot, float *q, char *why, size_t why_size);

/* A parse's end: on failure, or with no Gaussian, the model is left empty. */
int gaussian_ply_finish(gaussian_model *m, int rc, const char *name, rr_error *err);

/* Empties m, then parses len bytes at data with schema and v, or the
 * opened file src when it is not NULL (released as it is read:
 * ply_stream_vertices), and ends as gaussian_ply_finish. */
int gaussian_ply_load_layout(const char *name, const char *data, size_t len, input_file *src,
                             const ply_schema *schema, const ply_visitor *v, gaussian_model *m, rr_error *err);

#endif
