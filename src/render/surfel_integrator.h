/* The surfel integrator (thesis sec. 4.5 step c): one sample's colour from
 * the splats and spheres it meets. Its parts:
 *  - the epsilon window: the hits within epsilon of the closest, kept in a
 *    k-buffer (surfels/kbuffer.h; during traversal, accel's callbacks insert
 *    into it);
 *  - blending and deferred Phong of the window's hits (scene/shade.h);
 *  - static reuse: the samples of a still camera at one raster position
 *    share one world ray, whose static objects are traversed and shaded
 *    once (accel_ray_begin) for all of its times.
 * surfel_hits_rgba runs the window, blending and Phong on a given list of
 * hits, without a traversal (nor Embree). */
#ifndef RR_SURFEL_INTEGRATOR_H
#define RR_SURFEL_INTEGRATOR_H

#include "render/integrator.h"

/* The colour (rgb) and coverage (a) of a sample whose window is kb: its
 * hits blended and shaded (shade_hits) seen from org along the unit dir,
 * coverage 1; an empty window is the background, coverage 0. */
void surfel_kbuffer_rgba(const scene *s, const kbuffer *kb, vec3 org, vec3 dir, double rgba[4]);

/* The same for n hits in any order: the epsilon window (kbuffer_insert,
 * with the blending distance epsilon) keeps those within epsilon of the
 * closest, as a traversal offering them would. Returns whether more than
 * KBUFFER_MAX lay within it (kbuffer_overflowed). */
int surfel_hits_rgba(const scene *s, const surface_hit *hits, int n, float epsilon, vec3 org, vec3 dir,
                     double rgba[4]);

/* What a sample's surfaces leave for whatever is composited over them:
 * its world ray and the distance to its nearest surface (INFINITY: none). */
typedef struct {
    vec3 org, dir;
    double closest;
} surfel_sample;

/* A thread's state: the static objects' hits and colour of the raster
 * position last traced (static reuse). */
typedef struct surfel_thread surfel_thread;
surfel_thread *surfel_thread_new(void);
void surfel_thread_free(surfel_thread *st);
/* A new batch: nothing cached from the last one is reused. */
void surfel_thread_begin_batch(surfel_thread *st);

/* Estimates the samples of ps from `first` to the end of their group: those
 * sharing its raster position with a still camera (the thesis sampler lists
 * a position's times together), at most ACCEL_PACKET; one sample with a
 * moving camera (thesis eq. 3.6: each has its own world ray). Fills
 * rgba[k] and, unless surf is NULL, surf[k]; returns the index after the
 * group. */
int surfel_group(surfel_thread *st, const integrator_context *ctx, const pixel_samples *ps, int first,
                 double (*rgba)[4], surfel_sample *surf, integrator_counts *c);

#endif
