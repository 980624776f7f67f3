/* sRGB preview PNG through libpng (preview_png.c), or any other 8-bit
 * format OpenImageIO writes, chosen by the file extension, through
 * OpenImageIO in a module (preview.cpp built as refrender-preview.so next
 * to the executable) opened on first use, so that only such a preview
 * loads OpenImageIO. */
#ifndef RR_PREVIEW_H
#define RR_PREVIEW_H

#include "core/atomicfile.h"
#include "core/common.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes RGB of interleaved float RGBA as 8-bit display values, each
 * channel clamped to [0, 1] (no exposure change): linear light is encoded
 * with the sRGB transfer function; values already sRGB-encoded
 * (color_space "sRGB", the EXR's oiio:ColorSpace: a Gaussian model's
 * colours) are copied, rounded as the rasterizers write them. Atomic like
 * the EXR output (atomicfile.h), and read back before it replaces
 * anything. Returns 0, or -1 with the reason in err. */
int preview_write_srgb(const char *path, int w, int h, const float *rgba, const char *color_space, rr_error *err);
/* The same, its file left in set for atomic_set_commit (set NULL: now). */
int preview_write_srgb_into(atomic_set *set, const char *path, int w, int h, const float *rgba,
                            const char *color_space, rr_error *err);

/* 0 if the format of path's extension can be written (PNG; else
 * OpenImageIO's writer, through memory, read back); checked before
 * a render so that a bad --preview name (or a missing module) fails at
 * once, naming the file. */
int preview_check_format(const char *path, rr_error *err);

#ifdef __cplusplus
}
#endif

#endif
