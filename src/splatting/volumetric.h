/* Volumetric kernels (thesis sec. 3.6.3, 4.1.2, 4.2.2, Appendix C; the
 * readings chosen where the text is open are src/SPLAT.md's). Internal to
 * src/splatting/. */
#ifndef RR_SPLAT_VOLUMETRIC_H
#define RR_SPLAT_VOLUMETRIC_H

#include "splatting/frame.h"

/* The N instants of set, each a visibility pass of the 2D splats and an
 * attribute pass of their kernels, into rgba (4 per pixel). -1 when out of
 * memory. */
int splat_volumetric(splat_frame *f, const splat_settings *set, float *rgba, rr_error *err);

#endif
