/* sRGB preview PNG (or any 8-bit format OpenImageIO writes, chosen by the
 * file extension). C interface to a small C++ file using OpenImageIO. */
#ifndef RR_PREVIEW_H
#define RR_PREVIEW_H

#include "common.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes RGB of interleaved float RGBA: each channel clamped to [0, 1]
 * (no exposure change) and encoded with the sRGB transfer function.
 * Atomic like the EXR output (atomicfile.h), and read back before it
 * replaces anything. Returns 0, or -1 with the reason in err. */
int preview_write_srgb(const char *path, int w, int h, const float *rgba, rr_error *err);

/* 0 if OpenImageIO can write the format of path's extension; checked before
 * a render so that a bad --preview name fails at once, naming the file. */
int preview_check_format(const char *path, rr_error *err);

#ifdef __cplusplus
}
#endif

#endif
