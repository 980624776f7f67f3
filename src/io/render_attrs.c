#include "io/render_attrs.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>

#include "gaussians/gaussian_hit.h"
#include "core/inputfile.h"
#include "render/integrator.h"

#ifndef RR_BUILD_ID /* the Makefile's: the SHA-256 of the code under src/ */
#error "RR_BUILD_ID is not defined: build with the Makefile"
#endif

const char *render_build_id(void) { return RR_BUILD_ID; }

static void describe_weight(FILE *f, const shutter *sh)
{
    if (sh->kind == WEIGHT_LINEAR)
        fprintf(f, "linear center=%.17g", sh->center);
    else if (sh->kind == WEIGHT_EXP)
        fprintf(f, "exp center=%.17g rate=%.17g", sh->center, sh->rate);
    else if (sh->kind == WEIGHT_TABLE) {
        fputs("table", f);
        for (int i = 0; i < sh->table_size; i++)
            fprintf(f, " %.17g %.17g", sh->table_t[i], sh->table_w[i]);
    } else
        fputs("box", f);
}

/* The scene parameters applied, "name=value ..." ("none" without any). */
static void describe_parameters(FILE *f, const scene_params *p)
{
    for (int i = 0; i < p->n; i++)
        fprintf(f, "%s%s=%s", i ? " " : "", p->name[i], p->value[i]);
    if (!p->n)
        fputs("none", f);
}

/* An identity text of any length (a 256-pair weight table, many -D
 * parameters): the text under key, cut visibly where an EXR attribute
 * cannot hold it, and its FNV-1a under hash_key, which is what identity
 * checks compare whole. Cut at 4095 characters, the text alone once let
 * passes rendered with different parameters merge. */
static void set_identity_text(attr_list *a, const char *key, const char *hash_key,
                              void (*describe)(FILE *, const void *), const void *what)
{
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    RR_CHECK(f != NULL); /* out of memory for a few KB: nothing sensible is left to do */
    describe(f, what);
    RR_CHECK(fclose(f) == 0 && text != NULL);
    attrs_set(a, hash_key, "%016" PRIx64, input_hash(INPUT_HASH_INIT, text, len));
    attrs_set(a, key, len < ATTR_TEXT_MAX ? "%s" : "%.4000s ... (cut: the whole text's hash is the identity)", text);
    free(text);
}

/* How each Gaussian-splat object is imaged ("none" without any): its PLY
 * does not say, and the default has changed (3D models were once imaged as
 * 3DGRT's, now by the 3DGS rasterizer's rules), so it is part of a render's
 * identity: states rendered under two defaults must not merge. */
static void describe_gaussians(FILE *f, const scene *s)
{
    int any = 0;
    for (int i = 0; i < s->nobjects; i++) {
        const scene_object *o = &s->objects[i];
        if (!scene_object_row(o)->gaussians)
            continue;
        const char *key[GAUSSIAN_IMAGING_FIELDS], *value[GAUSSIAN_IMAGING_FIELDS];
        gaussian_imaging(&o->gaussians, o->order, key, value);
        fprintf(f, "%s%s:", any++ ? "; " : "", o->name);
        for (int k = 0; k < GAUSSIAN_IMAGING_FIELDS; k++)
            fprintf(f, " %s=%s", key[k], value[k]);
    }
    if (!any)
        fputs("none", f);
}

/* What the pixels hold (issue 55): a Gaussian model's colours are display
 * values, sRGB-encoded (it was fitted to 8-bit sRGB photographs, and the
 * official rasterizers write them to PNG as they are: gaussian-splatting
 * 1152adc render.py:34, torchvision's save_image rounding clamp(255 c + 0.5)), so its image is
 * sRGB-encoded unless --blur-space linear decoded every sample; surfel
 * shading is linear light. Written under OpenImageIO's name, which every
 * OpenImageIO reader of the EXR reports (it says "Linear" when it is absent). */
static const char *color_space(const scene *s, blur_space blur)
{
    int gaussians = 0;
    for (int i = 0; i < s->nobjects; i++)
        gaussians |= scene_object_row(&s->objects[i])->gaussians;
    return gaussians && blur != BLUR_SPACE_LINEAR ? "sRGB" : "Linear";
}

static void weight_text(FILE *f, const void *sh) { describe_weight(f, sh); }
static void gaussians_text(FILE *f, const void *s) { describe_gaussians(f, s); }
static void parameters_text(FILE *f, const void *p) { describe_parameters(f, p); }

/* A rolling shutter's windows, the first and the last line's, for a reader
 * who does not know the presets' rules (with --time the shutter is [T, T]
 * but the lines are not all at T); each preset's window moves linearly with
 * the line, so these two give every line's. */
static void line_times(attr_list *a, const shutter *sh, int width, int height)
{
    if (sh->rolling.kind == ROLLING_OFF)
        return;
    int lines;
    shutter_line(sh, 0, 0, width, height, &lines);
    attrs_set(a, ATTR_LINE_TIMES, "line 0 [%.17g, %.17g], line %d [%.17g, %.17g], linear between",
              shutter_line_time(sh, 0, lines, sh->open), shutter_line_time(sh, 0, lines, sh->close), lines - 1,
              shutter_line_time(sh, lines - 1, lines, sh->open), shutter_line_time(sh, lines - 1, lines, sh->close));
}

/* Writes the column-vector matrix m (p' = m p) as OpenEXR stores it: for
 * Imath's row vectors (p' = p M), i.e. transposed, row after row. */
static void set_matrix(attr_list *a, const char *key, double m[4][4])
{
    char buf[512];
    size_t len = 0;
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            len += (size_t)snprintf(buf + len, sizeof buf - len, "%s%.9g", len ? " " : "", m[c][r]);
    attrs_set(a, key, "%s", buf);
}

/* The frame's camera as pbrt-v4 and OpenEXR's standard attributes name it,
 * at the middle of the frame's exposure, and refrender's at its first and
 * last instant (scene_frame_camera_of: the pose export writes). Camera
 * space: x right, y up, z forward (the view direction; left-handed, as
 * pbrt's). NDC: x = raster x / width, y = raster y / height (0, 0 the
 * top-left image corner, as refrender's raster), z = 1 / depth, after
 * dividing by w = depth. s: the scene as the frame renders it (its
 * shutter the frame's). */
static void camera_matrices(attr_list *a, const scene *s)
{
    scene_frame_camera fc;
    scene_frame_camera_of(s, &fc);
    set_matrix(a, ATTR_WORLD_TO_CAMERA, fc.world_to_camera[1]);
    set_matrix(a, ATTR_WORLD_TO_NDC, fc.world_to_ndc);
    attrs_set(a, ATTR_CAMERA_TIME, "%.17g", fc.time[1]);
    set_matrix(a, ATTR_WORLD_TO_CAMERA_OPEN, fc.world_to_camera[0]);
    attrs_set(a, ATTR_CAMERA_TIME_OPEN, "%.17g", fc.time[0]);
    set_matrix(a, ATTR_WORLD_TO_CAMERA_CLOSE, fc.world_to_camera[2]);
    attrs_set(a, ATTR_CAMERA_TIME_CLOSE, "%.17g", fc.time[2]);
}

void attrs_for_render(attr_list *a, const scene *s, const render_settings *rs, uint32_t total_batches,
                      const char *command)
{
    const sampler *smp = &rs->smp;
    /* the code that drew the pixels: a state of another build may draw a
     * model differently under the same settings */
    attrs_set(a, ATTR_BUILD, "%s", RR_BUILD_ID);
    attrs_set(a, ATTR_SCENE, "%s", s->path);
    attrs_set(a, ATTR_SCENE_HASH, "%016" PRIx64, s->scene_hash);
    attrs_set(a, ATTR_INPUTS_HASH, "%016" PRIx64, s->inputs_hash);
    /* the parameters change the scene: part of the render's identity */
    set_identity_text(a, ATTR_PARAMETERS, ATTR_PARAMETERS_HASH, parameters_text, &s->params);
    attrs_set(a, ATTR_RESOLUTION, "%dx%d", s->cam.width, s->cam.height);
    attrs_set(a, ATTR_SAMPLER, "%s", sampler_name(smp->kind));
    attrs_set(a, ATTR_SPP, "%d", smp->grid * smp->grid);
    attrs_set(a, ATTR_TSPP, "%d", smp->tspp);
    attrs_set(a, ATTR_SEED, "%" PRIu64, smp->seed);
    attrs_set(a, ATTR_EPSILON, "%.17g", s->epsilon);
    attrs_set(a, ATTR_KERNEL_SIGMA, "%.17g", s->kernel_sigma);
    attrs_set(a, ATTR_SHUTTER, "%.17g %.17g", s->shut.open, s->shut.close);
    attrs_set(a, ATTR_SHUTTER_OPEN, "%.17g", s->shut.open);
    attrs_set(a, ATTR_SHUTTER_CLOSE, "%.17g", s->shut.close);
    camera_matrices(a, s);
    set_identity_text(a, ATTR_WEIGHT_FUNCTION, ATTR_WEIGHT_HASH, weight_text, &s->shut);
    char rolling[256];
    shutter_rolling_text(&s->shut, rolling, sizeof rolling);
    attrs_set(a, ATTR_ROLLING_SHUTTER, "%s", rolling);
    line_times(a, &s->shut, s->cam.width, s->cam.height);
    attrs_set(a, ATTR_TIME_FACTOR, "%d", smp->time_factor);
    attrs_set(a, ATTR_TIME_INTEGRATION, "%s", rs->integrator ? rs->integrator->id : "sampled");
    attrs_set(a, ATTR_PIXEL_FILTER, "%s", pixel_filter_name(rs->filter));
    attrs_set(a, ATTR_BLUR_SPACE, "%s", blur_space_name(rs->blur));
    attrs_set(a, ATTR_COLOR_SPACE, "%s", color_space(s, rs->blur));
    set_identity_text(a, ATTR_GAUSSIANS, ATTR_GAUSSIANS_HASH, gaussians_text, s);
    /* the convention compare.py --alpha composite relies on (README, Output) */
    attrs_set(a, ATTR_BACKGROUND, "%.9g %.9g %.9g", s->background.x, s->background.y, s->background.z);
    attrs_set(a, ATTR_ALPHA, "coverage; RGB already holds refrender:background where coverage < 1");
    attrs_set(a, ATTR_BATCHES, "%u", total_batches);
    attrs_set(a, ATTR_COMMAND, "%s", command);
    attrs_set(a, ATTR_SOFTWARE, "refrender %s", RR_VERSION);
}


void attrs_for_noise(attr_list *a, const noise_stats *n)
{
    if (!noise_has_stderr(n)) /* one batch: no standard errors, nothing to say */
        return;
    char text[160];
    noise_text(n, text, sizeof text);
    attrs_set(a, ATTR_BATCHES_MIN, "%u", n->batches_min);
    attrs_set(a, ATTR_BATCHES_MAX, "%u", n->batches_max);
    attrs_set(a, ATTR_STDERR_MEAN, "%.9g", n->mean);
    attrs_set(a, ATTR_STDERR_P99, "%.9g", n->p99);
    attrs_set(a, ATTR_STDERR_MAX, "%.9g", n->max);
    attrs_set(a, ATTR_STDERR_REACHED, "%s, each pixel's largest RGB standard error; %u to %u batches a pixel", text,
              n->batches_min, n->batches_max);
}
