/* What the rendering fuzz targets share: a scene read from
 * memory whose inputs were written to a private directory, rendered at
 * 4x4 through the same path as 'refrender' (accel_build, render_image),
 * and the image's invariants checked: a refusal is a clean return, a
 * render is finite with coverage in [0, 1] and no negative colour
 * (Gaussians' SH colours are clamped below at 0, surfaces are shaded
 * non-negative). A failed invariant aborts, which libFuzzer reports. */
#ifndef RR_FUZZ_RENDER_CHECK_H
#define RR_FUZZ_RENDER_CHECK_H

#include <stddef.h>

/* The fuzzer's scratch directory (made once). */
const char *fuzz_dir(void);
/* Writes data to fuzz_dir()/name; 0 or -1. */
int fuzz_write(const char *name, const void *data, size_t size);
/* Loads the XML (relative paths against fuzz_dir()), renders it at 4x4
 * (one time sample and one spatial sample a pixel, the shutter the scene
 * gives, box filter when `box`, else point) and checks the image. */
void fuzz_render_and_check(const char *xml, int box);

#endif
