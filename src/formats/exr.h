/* OpenEXR output and input through the OpenEXR C API (OpenEXRCore). */
#ifndef RR_EXR_H
#define RR_EXR_H

#include <stdint.h>

#include "core/atomicfile.h"
#include "core/common.h"

/* How an attribute given as text is stored: as a string, or parsed into a
 * numeric EXR attribute (int, double, or a 4x4 float matrix of 16 numbers,
 * row-major as Imath's M44f, which multiplies row vectors: p' = p M). */
typedef enum { RR_ATTR_TEXT, RR_ATTR_INT, RR_ATTR_DOUBLE, RR_ATTR_M44F } rr_attr_kind;

typedef struct {
    const char *key, *value;
    rr_attr_kind kind;
} exr_string_attr;

/* The numbers an attribute given as text is stored as (the writer's own
 * conversion): 1 for an int or a double, 16 for a matrix (each a float),
 * 0 for a string, -1 for a matrix of fewer than 16 numbers. */
int exr_attr_numbers(const exr_string_attr *a, double out[16]);

typedef enum { EXR_CHANNEL_FLOAT, EXR_CHANNEL_UINT } exr_channel_type;

/* One channel of an image in memory: element (x, y) is at
 * base + (y * width + x) * stride bytes, a float or a uint32_t. */
typedef struct {
    const char *name;
    exr_channel_type type;
    void *base;
    int stride;
} exr_channel;

/* Writes the channels as a ZIP-compressed scanline EXR with string
 * attributes. Atomic: the image goes to a temporary file beside `path` that
 * is renamed over it only when complete, so a failure never leaves a partial
 * file or clobbers a good one. */
int exr_write(const char *path, int w, int h, const exr_channel *channels, int nchannels,
              const exr_string_attr *attrs, int nattrs, rr_error *err);

/* A data window (x0, y0, w, h) inside a display window full_w x full_h. */
typedef struct {
    int full_w, full_h, x0, y0, w, h;
} exr_window;

/* The same for an image covering only the data window (the channels hold
 * its w x h pixels); readers see the full display window. */
int exr_write_window(const char *path, const exr_window *win, const exr_channel *channels, int nchannels,
                     const exr_string_attr *attrs, int nattrs, rr_error *err);
/* The same, its file left in set for atomic_set_commit (set NULL: put in
 * place now). */
int exr_write_window_into(atomic_set *set, const char *path, const exr_window *win, const exr_channel *channels,
                          int nchannels, const exr_string_attr *attrs, int nattrs, rr_error *err);

/* Interleaved float RGBA (w*h*4) as channels R, G, B, A. */
int exr_write_rgba(const char *path, int w, int h, const float *rgba, const exr_string_attr *attrs,
                   int nattrs, rr_error *err);

/* Size of part 0's data window. */
int exr_read_size(const char *path, int *w, int *h, rr_error *err);

/* Reads the named channels into the given buffers (sized by exr_read_size),
 * converting to each channel's type. A channel missing from the file is an
 * error unless `optional` is set, in which case its buffer is untouched and
 * *found (if given) is cleared. Channels are decoded one at a time (planar),
 * which avoids OpenEXRCore 3.1.5's channel swap when decoding half data
 * interleaved. */
int exr_read_channel(const char *path, const exr_channel *ch, int optional, int *found, rr_error *err);

/* Reads R, G, B (and A, 1 if absent) as interleaved float RGBA; *rgba is
 * malloc'ed. */
int exr_read_rgba(const char *path, int *w, int *h, float **rgba, rr_error *err);

/* Reads an attribute of part 0 into buf as text: strings as they are, int
 * attributes with %d, double with %.17g, float with %.9g and m44f as 16
 * numbers with %.9g (the same text they were written from; buf must hold
 * 16 numbers, 256 characters). Returns 0, 1 if there is no such attribute, -1
 * if the file cannot be read or the string does not fit in buf (never
 * cut). */
int exr_read_string_attr(const char *path, const char *key, char *buf, size_t size, rr_error *err);

#endif
