/* What a splatting method is asked to do (splatting.h's splat_render,
 * and each method's file: frame.c, volumetric.c, guan_mueller.c), in a
 * header of its own so that the methods and their dispatcher
 * (splatting.c) both read the settings and neither reaches the other's
 * file. */
#ifndef RR_SPLAT_SETTINGS_H
#define RR_SPLAT_SETTINGS_H

#include <stdint.h>

#include "motion/shutter.h"

typedef enum { SPLAT_INSTANT, SPLAT_ACCUM, SPLAT_BUCKET, SPLAT_VOLUMETRIC, SPLAT_GUAN_MUELLER } splat_method;
/* none: the reconstruction kernel only; botsch: the EWA approximation of
 * thesis sec. 4.2.3, eq. 4.13 (screen-space radius sqrt 2, attribute pass
 * only); ewa: Ren, Pfister, Zwicker 2002's object-space EWA resampling
 * filter (their eq. 7) with per-pixel normalisation. */
typedef enum { SPLAT_FILTER_NONE, SPLAT_FILTER_BOTSCH, SPLAT_FILTER_EWA } splat_filter;
/* Where the N instants lie in the shutter (the thesis does not say):
 * midpoint (k + 1/2) / N as scripts/nframe_average.py, stratified
 * (k + u_k) / N, random u_k (sorted). */
typedef enum { SPLAT_TIMES_MIDPOINT, SPLAT_TIMES_STRATIFIED, SPLAT_TIMES_RANDOM } splat_times;

/* Volumetric kernels' alpha (src/SPLAT.md): thesis: the weighted sum of
 * every instant's fragments, clamped to [0, 1] (sec. 4.1.2, Fig. 4.6);
 * normalized: each instant's a weighted average, then summed with a(t)
 * (the remedy sec. 6.2 proposes). */
typedef enum { SPLAT_ALPHA_THESIS, SPLAT_ALPHA_NORMALIZED } splat_alpha;

/* Guan and Mueller's trail image (their sec. 4: "either adding or
 * alpha-blending can be used to render the motion splats"): blend (the
 * default) composites the trails front to back; add sums them (alpha the
 * clamped sum). src/SPLAT.md says why blend is the default. */
typedef enum { SPLAT_TRAILS_BLEND, SPLAT_TRAILS_ADD } splat_trails;

/* Default standard deviation of a volumetric kernel's 1D Gaussian along
 * its velocity, in units of the slice |v| dt it stands for: that of a
 * uniform density over the slice, 1 / sqrt 12. */
#define SPLAT_SIGMA_T_DEFAULT 0.28867513459481287

typedef struct {
    splat_method method;
    splat_filter filter;
    splat_times times;
    int samples;       /* N instants (accum, bucket) */
    int buckets;       /* B (bucket): consecutive groups of instants */
    uint64_t seed;     /* stratified and random times */
    double instant;    /* instant: the time splatted */
    splat_alpha alpha; /* volumetric */
    double sigma_t;    /* volumetric: see SPLAT_SIGMA_T_DEFAULT */
    splat_trails trails; /* guan-mueller */
} splat_settings;

/* The name of each choice, as the command line and the EXR header spell them. */
const char *splat_method_name(splat_method m);
const char *splat_filter_name(splat_filter f);
const char *splat_times_name(splat_times t);
const char *splat_alpha_name(splat_alpha a);
const char *splat_trails_name(splat_trails t);

/* The N instants of accum, bucket and volumetric within the shutter
 * (the scene's, splat_render's s->shut), ascending. */
void splat_instants(const splat_settings *set, const shutter *shut, double *times);

#endif
