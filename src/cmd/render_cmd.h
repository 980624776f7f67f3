/* The render command's options (refrender [options] SCENE.xml), parsed in
 * render_cmd.c, and the frames rendered with them (render_frames.c): the
 * part a caller with a loaded scene and its own options can use alone. */
#ifndef RR_RENDER_CMD_H
#define RR_RENDER_CMD_H

#include <signal.h>

#include "render/render.h"
#include "scenexml/scene_xml.h"

typedef struct {
    int spp, tspp, time_factor, threads, quiet, width, height, batches, max_batches;
    int pass, passes; /* passes > 0: --pass pass/passes */
    int no_static_reuse;
    int exact_time, tspp_given, batches_given; /* --time-integration exact; --target-error's B */
    int shutter_set;                            /* --shutter OPEN,CLOSE */
    int instant_set;                            /* --time T */
    double instant;
    pixel_filter filter;                        /* --pixel-filter */
    blur_space blur;                            /* --blur-space */
    scene_params params;                        /* -D name=value */
    int crop_set;                               /* --crop-window X0,X1,Y0,Y1 (fractions) */
    double crop[4];
    double shutter_open, shutter_close;
    int frames, first_frame, last_frame; /* frames: 0 none, 1 --frame, 2 --frames */
    sampler_kind sampler;
    double eps, sigma, target_error, checkpoint_every; /* eps, sigma < 0: from the scene */
    double progress_every;                      /* --progress-every S; 0: a bar on a terminal only */
    uint64_t seed;
    const char *scene, *output, *preview, *checkpoint, *resume;
} render_options;

/* The crop window's pixels, pbrt's rounding: indices in [ceil(f0 N),
 * ceil(f1 N)); px = x0, x1, y0, y1. */
void render_options_crop_pixels(const render_options *o, int width, int height, int px[4]);

/* Renders s (loaded, the options' overrides applied) as o asks: one frame
 * or a sequence, sharing the loaded models and their BVHs, each frame's
 * image and preview written atomically; every frame's outputs and shutter
 * are checked before the first is rendered. cmdline goes into the header.
 * -1 with err on failure, or when *cancel became non-zero (cancel: the
 * flag render_image watches). */
int render_frames(const scene *s, const render_options *o, const char *cmdline, volatile sig_atomic_t *cancel,
                  rr_error *err);

#endif
