/* An 8-bit sRGB RGB image encoded as PNG in memory with libpng (why
 * preview.c does not load OpenImageIO for .png: preview_png.c). */
#ifndef RR_PREVIEW_PNG_H
#define RR_PREVIEW_PNG_H

#include <stddef.h>

#define PREVIEW_PNG_WHY 256

/* rgb: w*h*3 bytes, rows top to bottom. *bytes is malloc'd; 0, or -1 with
 * the reason in why. */
int preview_png_encode(int w, int h, const unsigned char *rgb, unsigned char **bytes, size_t *len,
                       char why[PREVIEW_PNG_WHY]);

#endif
