/* What a render's noise came to, said where a user reads it: the threshold
 * of --target-error in value units or 8-bit levels, and after a final
 * render the noise reached (render/noise.h) in the header and on stderr. */
#ifndef RR_NOISE_REPORT_H
#define RR_NOISE_REPORT_H

#include "io/output.h"

/* --target-error's argument: X in the EXR's value units, or "Xlv" in 8-bit
 * levels (X / 255), the unit the docs speak in; the result in value units. */
int noise_parse_target(const char *text, double *value, rr_error *err);

/* The noise a final image reached into its header (attrs_for_noise) and,
 * unless quiet, a summary line; with a target error (> 0) also how many
 * pixels reached it and how many stopped at the cap. -1 when out of memory. */
int noise_report(const image *img, double target_error, uint32_t cap, int quiet, attr_list *attrs, rr_error *err);

#endif
