/* Guan and Mueller 2004's motion hints (Point-based surface rendering with
 * motion blur, SPBG 2004; the readings chosen where the text is open are
 * src/SPLAT.md's): the object sharp at the flash, plus one screen-space
 * trail splat per front-facing point. Internal to src/splatting/. */
#ifndef RR_SPLAT_GUAN_MUELLER_H
#define RR_SPLAT_GUAN_MUELLER_H

#include "splatting/frame.h"

/* The object image at the shutter's close composited over the trail image
 * (set->trails: added or alpha-blended) and the background, into rgba (4 per
 * pixel). -1 when out of memory. */
int splat_guan_mueller(splat_frame *f, const splat_settings *set, float *rgba, rr_error *err);

#endif
