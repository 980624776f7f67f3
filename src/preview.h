/* sRGB preview PNG (or any 8-bit format OpenImageIO writes, chosen by the
 * file extension). C interface to a small C++ file using OpenImageIO. */
#ifndef RR_PREVIEW_H
#define RR_PREVIEW_H

#ifdef __cplusplus
extern "C" {
#endif

/* Writes RGB of interleaved float RGBA: each channel clamped to [0, 1]
 * (no exposure change) and encoded with the sRGB transfer function.
 * Atomic like the EXR output (atomicfile.h), and read back before it
 * replaces anything. Returns 0, or -1 with a message in msg. */
int preview_write_srgb(const char *path, int w, int h, const float *rgba, char *msg, int msg_size);

/* 0 if OpenImageIO can write the format of path's extension; checked before
 * a render so that a bad --preview name fails at once, naming the file. */
int preview_check_format(const char *path, char *msg, int msg_size);

#ifdef __cplusplus
}
#endif

#endif
