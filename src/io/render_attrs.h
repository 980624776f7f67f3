/* The identity and provenance attributes of a render, written into its
 * EXR header (output.h checks the identity ones when states are merged or
 * resumed). */
#ifndef RR_RENDER_ATTRS_H
#define RR_RENDER_ATTRS_H

#include "io/output.h"
#include "render/noise.h"
#include "render/render.h"

/* The build's identity: the SHA-256 of the code under src/, computed by the
 * Makefile (-DRR_BUILD_ID); equal sources give an equal id. */
const char *render_build_id(void);

/* s: the scene as the frame renders it (scene_for_shutter), whose shutter
 * (s->shut) the header records; rs: the render's settings. */
void attrs_for_render(attr_list *a, const scene *s, const render_settings *rs, uint32_t total_batches,
                      const char *command);

/* A final image's noise (render/noise.h): the batch range its pixels hold
 * and, with standard errors, their mean, 99th percentile and max in value
 * units, and as text in 8-bit levels too. A render and a merge of its
 * passes write the same. */
void attrs_for_noise(attr_list *a, const noise_stats *n);

#endif
