/* refrender's EXR files: final images and render states.
 *
 * A final image has float channels R G B A, samples, and (when pixels have
 * two or more batches) variance.* and stderr.* for R G B A: the variance of
 * the pixel value and its standard error (film.h).
 * A render state (a --pass output or a checkpoint) has R G B A of the
 * batches it holds plus exact uint channels state.* with each pixel's batch
 * count and fixed-point sums, so states merge bit-exactly.
 * Both carry string attributes; the identity attributes (the build, scene hash, hash
 * of every input file's content, resolution, sampler, counts, seed, epsilon, sigma, shutter, weight, time
 * factor, batches) must agree for states to be merged or resumed. */
#ifndef RR_OUTPUT_H
#define RR_OUTPUT_H

#include "core/common.h"
#include "formats/exr.h"
#include "render/film.h"

#define ATTR_MAX 80

/* The name of every attribute refrender writes (README, Output). Their
 * kinds and what resuming and merging do with each are output.c's table,
 * the one list of them; writers name them by these macros. */
#define ATTR_BUILD "refrender:build"
#define ATTR_SCENE_HASH "refrender:sceneHash"
#define ATTR_INPUTS_HASH "refrender:inputsHash"
#define ATTR_RESOLUTION "refrender:resolution"
#define ATTR_SAMPLER "refrender:sampler"
#define ATTR_SPP "refrender:spp"
#define ATTR_TSPP "refrender:tspp"
#define ATTR_SEED "refrender:seed"
#define ATTR_EPSILON "refrender:epsilon"
#define ATTR_KERNEL_SIGMA "refrender:kernelSigma"
#define ATTR_SHUTTER "refrender:shutter"
#define ATTR_WEIGHT_FUNCTION "refrender:weightFunction"
#define ATTR_TIME_FACTOR "refrender:timeFactor"
#define ATTR_BATCHES "refrender:batches"
#define ATTR_TIME_INTEGRATION "refrender:timeIntegration"
#define ATTR_PARAMETERS "refrender:parameters"
#define ATTR_PARAMETERS_HASH "refrender:parametersHash"
#define ATTR_WEIGHT_HASH "refrender:weightHash"
#define ATTR_PIXEL_FILTER "refrender:pixelFilter"
#define ATTR_BLUR_SPACE "refrender:blurSpace"
/* what the RGB holds: "sRGB" (a Gaussian model's display-encoded colours) or "Linear" (linear light),
 * under the name OpenImageIO reads from an EXR header and reports to every reader */
#define ATTR_COLOR_SPACE "oiio:ColorSpace"
#define ATTR_GAUSSIANS "refrender:gaussians"
#define ATTR_GAUSSIANS_HASH "refrender:gaussiansHash"
#define ATTR_ROLLING_SHUTTER "refrender:rollingShutter"
#define ATTR_SCENE "refrender:scene"
#define ATTR_COMMAND "refrender:command"
#define ATTR_SOFTWARE "software"
#define ATTR_BACKGROUND "refrender:background"
#define ATTR_ALPHA "refrender:alpha"
#define ATTR_WORLD_TO_CAMERA "worldToCamera"
#define ATTR_WORLD_TO_NDC "worldToNDC"
#define ATTR_CAMERA_TIME "refrender:cameraTime"
#define ATTR_WORLD_TO_CAMERA_OPEN "refrender:worldToCameraOpen"
#define ATTR_CAMERA_TIME_OPEN "refrender:cameraTimeOpen"
#define ATTR_WORLD_TO_CAMERA_CLOSE "refrender:worldToCameraClose"
#define ATTR_CAMERA_TIME_CLOSE "refrender:cameraTimeClose"
#define ATTR_SHUTTER_OPEN "refrender:shutterOpen"
#define ATTR_SHUTTER_CLOSE "refrender:shutterClose"
#define ATTR_FRAME "refrender:frame"
#define ATTR_FRAME_RATE "refrender:frameRate"
#define ATTR_RAYS "refrender:rays"
#define ATTR_CLAMPED "refrender:clampedEstimates"
#define ATTR_RENDER_SECONDS "refrender:renderSeconds"
#define ATTR_LINE_TIMES "refrender:lineTimes"
#define ATTR_STATE "refrender:state"
#define ATTR_TARGET_ERROR "refrender:targetError"
#define ATTR_TARGET_REACHED "refrender:targetReached"
#define ATTR_CROP_WINDOW "refrender:cropWindow"
/* the noise a final image reached (render/noise.h): batches held per pixel,
 * and each pixel's largest RGB standard error over the image */
#define ATTR_BATCHES_MIN "refrender:batchesMin"
#define ATTR_BATCHES_MAX "refrender:batchesMax"
#define ATTR_STDERR_MEAN "refrender:stderrMean"
#define ATTR_STDERR_P99 "refrender:stderrP99"
#define ATTR_STDERR_MAX "refrender:stderrMax"
#define ATTR_STDERR_REACHED "refrender:stderrReached"
/* refrender splat (src/SPLAT.md): the method, its parameters and its cost */
#define ATTR_METHOD "refrender:method"
#define ATTR_METHOD_PARAMETERS "refrender:methodParameters"
#define ATTR_FRAGMENTS "refrender:fragments"

/* A render's EXR attributes, each held as text (identity checks compare
 * text) and written as its kind (exr.h): the counts, distances, times and
 * camera matrices as EXR numbers, the rest as strings (attrs_set knows
 * which is which). */
/* Longest attribute text kept (longer is cut visibly; identity texts of
 * any length are compared by their hash, render_attrs.c). */
#define ATTR_TEXT_MAX 4200

typedef struct {
    int n;
    char key[ATTR_MAX][64];
    char value[ATTR_MAX][ATTR_TEXT_MAX];
    rr_attr_kind kind[ATTR_MAX];
} attr_list;

/* Sets an attribute from printf-style text; a numeric attribute's text
 * must parse as its number ("%d" for ints, "%.17g" for doubles, 16
 * numbers for matrices). */
void attrs_set(attr_list *a, const char *key, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
const char *attrs_get(const attr_list *a, const char *key);

/* The final image of the pixels x0 <= x < x0 + w, y0 <= y < y0 + h of win
 * (the whole image, or a crop window written as the EXR's data window),
 * its file left in set for outputs put in place together
 * (atomic_set_commit; set NULL: now). */
int output_write_final_into(atomic_set *set, const char *path, const image *img, int samples_per_batch,
                            const attr_list *a, const exr_window *win, rr_error *err);
/* The channels output_write_final_into writes, as they are in memory: R G
 * B A, with two or more batches in some pixel variance.* and stderr.* too,
 * then samples; each of element stride 16 or 4 bytes in p's planes (held
 * until image_planes_free(p)), win's pixels row after row. For a caller
 * that keeps the image in memory (src/api/): the very values the file gets. */
#define OUTPUT_FINAL_CHANNELS_MAX 13
int output_final_channels(const image *img, int samples_per_batch, const exr_window *win, image_planes *p,
                          exr_channel chs[OUTPUT_FINAL_CHANNELS_MAX], int *nch, rr_error *err);
/* A render state, batch range [begin, end) recorded in the attributes;
 * the _into form as above. */
int output_write_state(const char *path, const image *img, uint32_t begin, uint32_t end, attr_list *a,
                       rr_error *err);
int output_write_state_into(atomic_set *set, const char *path, const image *img, uint32_t begin, uint32_t end,
                            attr_list *a, rr_error *err);
/* img's 8-bit sRGB preview (io/preview.h), its RGB as a's oiio:ColorSpace
 * says: a render's --preview and a merge's, left in set as above. */
int output_write_preview_into(atomic_set *set, const char *path, const image *img, const attr_list *a,
                              rr_error *err);

/* Reads a state file into img (allocated here) and its attributes. */
int output_read_state(const char *path, image *img, attr_list *a, uint32_t *begin, uint32_t *end,
                      rr_error *err);

/* Fails naming the first identity attribute on which a and b differ. */
int attrs_check_identity(const attr_list *a, const char *a_name, const attr_list *b, const char *b_name,
                         rr_error *err);

/* Folds state b's descriptive attributes into merged (a merge's first
 * state): the frame, frame rate, shutter and camera matrices must be equal
 * in both, or absent from both; rays and render seconds are summed; an
 * integrator's counter per ray (exact time's unresolved share) becomes the
 * ray-weighted mean. Fails naming the attribute and both files. */
int attrs_combine(attr_list *merged, const char *merged_name, const attr_list *b, const char *b_name, rr_error *err);

/* Counter i's header value (render/counters.h: its scale), for a render
 * of `rays` rays over a shutter of that length. */
double output_counter_value(const counter_set *c, int i, uint64_t rays, double shutter_length);
/* The sum a counter's header value stands for (output_counter_value's
 * inverse, up to the value's 6 digits): a resumed state's. */
double output_counter_sum(const counter_spec *spec, double value, uint64_t rays, double shutter_length);
/* Each of the counters as its header attribute. */
void output_counter_attrs(attr_list *a, const counter_set *c, uint64_t rays, double shutter_length);

#endif
