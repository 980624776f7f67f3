/* OpenEXR output and input through the OpenEXR C API (OpenEXRCore). */
#ifndef RR_EXR_H
#define RR_EXR_H

#include "common.h"

typedef struct {
    const char *key, *value;
} exr_string_attr;

/* Writes interleaved float RGBA (w*h*4) as a 32-bit float, ZIP-compressed
 * scanline EXR with the given string attributes. Atomic: the image goes to a
 * temporary file beside `path` that is renamed over it only when complete,
 * so a failure never leaves a partial file or clobbers a good one. */
int exr_write_rgba(const char *path, int w, int h, const float *rgba, const exr_string_attr *attrs,
                   int nattrs, rr_error *err);

/* Reads R, G, B (and A, 1 if absent) of any scanline EXR as interleaved
 * float RGBA; *rgba is malloc'ed. Channels are decoded planar (one channel
 * per pass), which avoids OpenEXRCore 3.1.5's channel swap when decoding
 * half data interleaved. */
int exr_read_rgba(const char *path, int *w, int *h, float **rgba, rr_error *err);

/* Reads a string attribute of part 0 into buf. */
int exr_read_string_attr(const char *path, const char *key, char *buf, size_t size, rr_error *err);

#endif
