#include "io/output.h"

#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "formats/exr.h"
#include "io/preview.h"
#include "render/exact.h"

/* What resuming and merging do with an attribute. */
typedef enum {
    ROLE_IDENTITY, /* must agree for states to be merged or resumed; every state has it */
    ROLE_KEPT,     /* describes the render; read back from a state */
    ROLE_EQUAL,    /* the frame and the camera: equal in every state of a merge, or absent from all */
    ROLE_SUMMED,   /* the work of the states together: rays and seconds add up */
    ROLE_PER_RAY,  /* an integrator's counter per traced ray (render/counters.h): the ray-weighted mean */
    ROLE_WRITTEN   /* describes one run only: not read back */
} attr_role;

/* Every attribute refrender writes, its kind (README, Output: the counts,
 * distances, times and camera matrices as EXR numbers, the rest as
 * strings) and its role, in the order identity checks name a difference
 * and states are read. The frame and the camera are those of every state,
 * so they must agree (a misnumbered pass would otherwise pass as the
 * frame); rays and seconds are the work of all states together. */
static const struct {
    const char *key;
    rr_attr_kind kind;
    attr_role role;
} attr_table[] = {
    /* first: another build's state may differ in anything below, and the
     * build is the cause (a rebuilt shared tree under a running array job) */
    {ATTR_BUILD, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_SCENE_HASH, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_INPUTS_HASH, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_RESOLUTION, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_SAMPLER, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_SPP, RR_ATTR_INT, ROLE_IDENTITY},
    {ATTR_TSPP, RR_ATTR_INT, ROLE_IDENTITY},
    {ATTR_SEED, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_EPSILON, RR_ATTR_DOUBLE, ROLE_IDENTITY},
    {ATTR_KERNEL_SIGMA, RR_ATTR_DOUBLE, ROLE_IDENTITY},
    {ATTR_SHUTTER, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_WEIGHT_FUNCTION, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_TIME_FACTOR, RR_ATTR_INT, ROLE_IDENTITY},
    {ATTR_BATCHES, RR_ATTR_INT, ROLE_IDENTITY},
    {ATTR_TIME_INTEGRATION, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_PARAMETERS, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_PARAMETERS_HASH, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_WEIGHT_HASH, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_PIXEL_FILTER, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_BLUR_SPACE, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_GAUSSIANS, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_GAUSSIANS_HASH, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_ROLLING_SHUTTER, RR_ATTR_TEXT, ROLE_IDENTITY},
    {ATTR_SCENE, RR_ATTR_TEXT, ROLE_KEPT},
    {ATTR_COLOR_SPACE, RR_ATTR_TEXT, ROLE_KEPT}, /* follows from blurSpace and gaussians */
    {ATTR_COMMAND, RR_ATTR_TEXT, ROLE_KEPT},
    {ATTR_SOFTWARE, RR_ATTR_TEXT, ROLE_KEPT},
    {ATTR_BACKGROUND, RR_ATTR_TEXT, ROLE_KEPT},
    {ATTR_ALPHA, RR_ATTR_TEXT, ROLE_KEPT},
    {ATTR_WORLD_TO_CAMERA, RR_ATTR_M44F, ROLE_EQUAL},
    {ATTR_WORLD_TO_NDC, RR_ATTR_M44F, ROLE_EQUAL},
    {ATTR_CAMERA_TIME, RR_ATTR_DOUBLE, ROLE_EQUAL},
    {ATTR_WORLD_TO_CAMERA_OPEN, RR_ATTR_M44F, ROLE_EQUAL},
    {ATTR_CAMERA_TIME_OPEN, RR_ATTR_DOUBLE, ROLE_EQUAL},
    {ATTR_WORLD_TO_CAMERA_CLOSE, RR_ATTR_M44F, ROLE_EQUAL},
    {ATTR_CAMERA_TIME_CLOSE, RR_ATTR_DOUBLE, ROLE_EQUAL},
    {ATTR_SHUTTER_OPEN, RR_ATTR_DOUBLE, ROLE_EQUAL},
    {ATTR_SHUTTER_CLOSE, RR_ATTR_DOUBLE, ROLE_EQUAL},
    {ATTR_FRAME, RR_ATTR_INT, ROLE_EQUAL},
    {ATTR_FRAME_RATE, RR_ATTR_DOUBLE, ROLE_EQUAL},
    {ATTR_RAYS, RR_ATTR_DOUBLE, ROLE_SUMMED},
    {ATTR_RENDER_SECONDS, RR_ATTR_DOUBLE, ROLE_SUMMED},
    {ATTR_CLAMPED, RR_ATTR_DOUBLE, ROLE_SUMMED},
    {EXACT_UNRESOLVED_SHARE_ATTR, RR_ATTR_TEXT, ROLE_PER_RAY},
    {ATTR_LINE_TIMES, RR_ATTR_TEXT, ROLE_WRITTEN},
    {ATTR_STATE, RR_ATTR_TEXT, ROLE_WRITTEN},
    {ATTR_TARGET_ERROR, RR_ATTR_DOUBLE, ROLE_WRITTEN},
    {ATTR_TARGET_REACHED, RR_ATTR_TEXT, ROLE_WRITTEN},
    {ATTR_CROP_WINDOW, RR_ATTR_TEXT, ROLE_WRITTEN},
    {ATTR_BATCHES_MIN, RR_ATTR_INT, ROLE_WRITTEN},
    {ATTR_BATCHES_MAX, RR_ATTR_INT, ROLE_WRITTEN},
    {ATTR_STDERR_MEAN, RR_ATTR_DOUBLE, ROLE_WRITTEN},
    {ATTR_STDERR_P99, RR_ATTR_DOUBLE, ROLE_WRITTEN},
    {ATTR_STDERR_MAX, RR_ATTR_DOUBLE, ROLE_WRITTEN},
    {ATTR_STDERR_REACHED, RR_ATTR_TEXT, ROLE_WRITTEN},
    {ATTR_METHOD, RR_ATTR_TEXT, ROLE_WRITTEN},
    {ATTR_METHOD_PARAMETERS, RR_ATTR_TEXT, ROLE_WRITTEN},
    {ATTR_FRAGMENTS, RR_ATTR_DOUBLE, ROLE_WRITTEN},
};
enum { ATTRS_KNOWN = sizeof attr_table / sizeof attr_table[0] };

static rr_attr_kind attr_kind(const char *key)
{
    for (int k = 0; k < ATTRS_KNOWN; k++)
        if (!strcmp(attr_table[k].key, key))
            return attr_table[k].kind;
    return RR_ATTR_TEXT;
}

static void attrs_vset(attr_list *a, const char *key, const char *fmt, va_list ap)
{
    int i = 0;
    while (i < a->n && strcmp(a->key[i], key))
        i++;
    if (i == ATTR_MAX) { /* the keys are refrender's own: more is a programming error, never dropped silently */
        fprintf(stderr, "refrender: internal error: more than %d EXR attributes (adding '%s')\n", ATTR_MAX, key);
        abort();
    }
    if (i == a->n) {
        a->n++;
        snprintf(a->key[i], sizeof a->key[i], "%s", key);
    }
    a->kind[i] = attr_kind(key);
    int len = vsnprintf(a->value[i], sizeof a->value[i], fmt, ap);
    if (len >= ATTR_TEXT_MAX) /* never cut silently: the value says it was cut (identity texts go by hash) */
        snprintf(a->value[i] + ATTR_TEXT_MAX - 64, 64, " ... (cut: %d characters)", len);
}

void attrs_set(attr_list *a, const char *key, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    attrs_vset(a, key, fmt, ap);
    va_end(ap);
}

const char *attrs_get(const attr_list *a, const char *key)
{
    for (int i = 0; i < a->n; i++)
        if (!strcmp(a->key[i], key))
            return a->value[i];
    return NULL;
}

int attrs_check_identity(const attr_list *a, const char *a_name, const attr_list *b, const char *b_name,
                         rr_error *err)
{
    for (int k = 0; k < ATTRS_KNOWN; k++) {
        if (attr_table[k].role != ROLE_IDENTITY)
            continue;
        const char *key = attr_table[k].key, *va = attrs_get(a, key), *vb = attrs_get(b, key);
        if (va && vb && strcmp(va, vb) && !strcmp(key, ATTR_BUILD))
            return rr_fail(err, "%s and %s were rendered by different builds of refrender (%s '%.80s' vs '%.80s'): "
                                "not the same render", a_name, b_name, key, va, vb);
        if (!va || !vb || strcmp(va, vb))
            return rr_fail(err, "%s and %s differ in %s ('%.160s' vs '%.160s'): not the same render", a_name, b_name,
                           key, va ? va : "missing", vb ? vb : "missing");
    }
    return 0;
}

/* Both or neither of a and b have key; fails naming the files if not. */
static int check_both_have(const attr_list *a, const char *a_name, const attr_list *b, const char *b_name,
                           const char *key, rr_error *err)
{
    const char *va = attrs_get(a, key), *vb = attrs_get(b, key);
    if (!va != !vb)
        return rr_fail(err, "%s %s %s but %s %s it: states of one render all have it or none does", a_name,
                       va ? "has" : "lacks", key, b_name, vb ? "has" : "lacks");
    return 0;
}

/* A counter's header value (COUNTER_SHARE_PER_RAY, the only scale) as
 * text: a render and a merge write it alike. */
static void set_share_per_ray(attr_list *a, const char *key, double share) { attrs_set(a, key, "%.6g", share); }

double output_counter_value(const counter_set *c, int i, uint64_t rays, double shutter_length)
{
    RR_DCHECK(c->spec[i].scale == COUNTER_SHARE_PER_RAY);
    return rays > 0 ? c->sum[i] / ((double)rays * shutter_length) : 0.0;
}

double output_counter_sum(const counter_spec *spec, double value, uint64_t rays, double shutter_length)
{
    RR_DCHECK(spec->scale == COUNTER_SHARE_PER_RAY);
    (void)spec; /* (read by the check only: the one scale there is) */
    return value * (double)rays * shutter_length;
}

void output_counter_attrs(attr_list *a, const counter_set *c, uint64_t rays, double shutter_length)
{
    for (int i = 0; i < c->n; i++)
        set_share_per_ray(a, c->spec[i].attribute, output_counter_value(c, i, rays, shutter_length));
}

/* A counter per traced ray (ROLE_PER_RAY): the share of states together
 * is their ray-weighted mean; called before the rays are summed. */
static void combine_per_ray(attr_list *merged, const attr_list *b, const char *key)
{
    const char *sa = attrs_get(merged, key), *sb = attrs_get(b, key);
    const char *ra = attrs_get(merged, ATTR_RAYS), *rb = attrs_get(b, ATTR_RAYS);
    if (!sa || !sb || !ra || !rb)
        return;
    double wa = strtod(ra, NULL), wb = strtod(rb, NULL);
    set_share_per_ray(merged, key, wa + wb > 0 ? (strtod(sa, NULL) * wa + strtod(sb, NULL) * wb) / (wa + wb) : 0.0);
}

int attrs_combine(attr_list *merged, const char *merged_name, const attr_list *b, const char *b_name, rr_error *err)
{
    for (int k = 0; k < ATTRS_KNOWN; k++) {
        if (attr_table[k].role != ROLE_EQUAL)
            continue;
        const char *key = attr_table[k].key;
        if (check_both_have(merged, merged_name, b, b_name, key, err))
            return -1;
        const char *va = attrs_get(merged, key), *vb = attrs_get(b, key);
        if (va && strcmp(va, vb))
            return rr_fail(err, "%s and %s differ in %s ('%.160s' vs '%.160s'): not the same frame and camera",
                           merged_name, b_name, key, va, vb);
    }
    for (int k = 0; k < ATTRS_KNOWN; k++)
        if ((attr_table[k].role == ROLE_PER_RAY || attr_table[k].role == ROLE_SUMMED) &&
            check_both_have(merged, merged_name, b, b_name, attr_table[k].key, err))
            return -1;
    for (int k = 0; k < ATTRS_KNOWN; k++)
        if (attr_table[k].role == ROLE_PER_RAY)
            combine_per_ray(merged, b, attr_table[k].key);
    const char *rays = attrs_get(merged, ATTR_RAYS), *secs = attrs_get(merged, ATTR_RENDER_SECONDS);
    const char *clamped = attrs_get(merged, ATTR_CLAMPED);
    if (rays) /* a double holds counts exactly up to 2^53 rays */
        attrs_set(merged, ATTR_RAYS, "%.17g", strtod(rays, NULL) + strtod(attrs_get(b, ATTR_RAYS), NULL));
    if (clamped)
        attrs_set(merged, ATTR_CLAMPED, "%.17g", strtod(clamped, NULL) + strtod(attrs_get(b, ATTR_CLAMPED), NULL));
    if (secs)
        attrs_set(merged, ATTR_RENDER_SECONDS, "%.3f",
                  strtod(secs, NULL) + strtod(attrs_get(b, ATTR_RENDER_SECONDS), NULL));
    return 0;
}

static exr_string_attr *string_attrs(const attr_list *a, exr_string_attr *out)
{
    for (int i = 0; i < a->n; i++)
        out[i] = (exr_string_attr){a->key[i], a->value[i], a->kind[i]};
    return out;
}

/* Moves the window's pixels (elems floats each) to the front, row after row. */
static void compact_window(float *plane, int elems, const exr_window *win)
{
    size_t row = (size_t)win->w * elems;
    for (int y = 0; y < win->h; y++)
        memmove(plane + y * row, plane + ((size_t)(win->y0 + y) * win->full_w + win->x0) * elems, row * sizeof *plane);
}

/* The preview shows what the header says the RGB holds (its oiio:ColorSpace). */
int output_write_preview_into(atomic_set *set, const char *path, const image *img, const attr_list *a,
                              rr_error *err)
{
    image_planes p;
    if (image_planes_resolve(img, 1, &p)) /* its RGBA only: the samples plane's scale does not matter */
        return rr_fail(err, "out of memory");
    int rc = preview_write_srgb_into(set, path, img->width, img->height, p.rgba, attrs_get(a, ATTR_COLOR_SPACE), err);
    image_planes_free(&p);
    return rc;
}

int output_final_channels(const image *img, int samples_per_batch, const exr_window *win, image_planes *p,
                          exr_channel chs[OUTPUT_FINAL_CHANNELS_MAX], int *nch, rr_error *err)
{
    size_t n = (size_t)img->width * img->height;
    if (image_planes_resolve(img, samples_per_batch, p))
        return rr_fail(err, "out of memory");
    uint32_t most = 0;
    for (size_t i = 0; i < n; i++)
        most = img->px[i].batches > most ? img->px[i].batches : most;
    static const char *const names[3][4] = {{"R", "G", "B", "A"},
                                            {"variance.R", "variance.G", "variance.B", "variance.A"},
                                            {"stderr.R", "stderr.G", "stderr.B", "stderr.A"}};
    float *planes[3] = {p->rgba, p->var, p->se};
    *nch = 0;
    for (int k = 0; k < (most >= 2 ? 3 : 1); k++)
        for (int c = 0; c < 4; c++)
            chs[(*nch)++] = (exr_channel){names[k][c], EXR_CHANNEL_FLOAT, planes[k] + c, 16};
    chs[(*nch)++] = (exr_channel){"samples", EXR_CHANNEL_FLOAT, p->samples, 4};
    for (int k = 0; k < 3; k++)
        compact_window(planes[k], 4, win);
    compact_window(p->samples, 1, win);
    return 0;
}

int output_write_final_into(atomic_set *set, const char *path, const image *img, int samples_per_batch,
                            const attr_list *a, const exr_window *win, rr_error *err)
{
    image_planes p;
    exr_channel chs[OUTPUT_FINAL_CHANNELS_MAX];
    int nch;
    if (output_final_channels(img, samples_per_batch, win, &p, chs, &nch, err))
        return -1;
    exr_string_attr sa[ATTR_MAX];
    int rc = exr_write_window_into(set, path, win, chs, nch, string_attrs(a, sa), a->n, err);
    image_planes_free(&p);
    return rc;
}

/* State planes: batches, then per RGBA channel sum (2 words) and sum of
 * squares (4 words), little-endian word order. */
enum { STATE_WORDS = 1 + 4 * 6 };

static void state_channel_name(int k, char *buf, size_t size)
{
    static const char rgba[] = "RGBA";
    if (k == 0)
        snprintf(buf, size, "state.batches");
    else if ((k - 1) % 6 < 2)
        snprintf(buf, size, "state.sum.%c.%d", rgba[(k - 1) / 6], (k - 1) % 6);
    else
        snprintf(buf, size, "state.sq.%c.%d", rgba[(k - 1) / 6], (k - 1) % 6 - 2);
}

static void pack_state(const pixel_state *p, uint32_t w[STATE_WORDS])
{
    w[0] = p->batches;
    for (int c = 0; c < 4; c++) {
        uint64_t s = (uint64_t)p->sum[c];
        unsigned __int128 q = (unsigned __int128)p->sumsq[c];
        w[1 + 6 * c] = (uint32_t)s, w[2 + 6 * c] = (uint32_t)(s >> 32);
        for (int k = 0; k < 4; k++)
            w[3 + 6 * c + k] = (uint32_t)(q >> (32 * k));
    }
}

static void unpack_state(const uint32_t w[STATE_WORDS], pixel_state *p)
{
    p->batches = w[0];
    for (int c = 0; c < 4; c++) {
        p->sum[c] = (int64_t)((uint64_t)w[1 + 6 * c] | (uint64_t)w[2 + 6 * c] << 32);
        unsigned __int128 q = 0;
        for (int k = 3; k >= 0; k--)
            q = (q << 32) | w[3 + 6 * c + k];
        p->sumsq[c] = (__int128)q;
    }
}

int output_write_state(const char *path, const image *img, uint32_t begin, uint32_t end, attr_list *a,
                       rr_error *err)
{
    return output_write_state_into(NULL, path, img, begin, end, a, err);
}

int output_write_state_into(atomic_set *set, const char *path, const image *img, uint32_t begin, uint32_t end,
                            attr_list *a, rr_error *err)
{
    size_t n = (size_t)img->width * img->height;
    uint32_t *words = malloc(n * STATE_WORDS * sizeof *words);
    float *rgba = malloc(n * 4 * sizeof *rgba);
    if (!words || !rgba) {
        free(words), free(rgba);
        return rr_fail(err, "out of memory");
    }
    for (size_t i = 0; i < n; i++) {
        double mean[4], var[4];
        pack_state(&img->px[i], words + i * STATE_WORDS);
        film_resolve(&img->px[i], mean, var);
        for (int c = 0; c < 4; c++)
            rgba[4 * i + c] = (float)mean[c];
    }
    char names[STATE_WORDS][32];
    exr_channel chs[4 + STATE_WORDS] = {{"R", EXR_CHANNEL_FLOAT, rgba, 16}, {"G", EXR_CHANNEL_FLOAT, rgba + 1, 16},
                                        {"B", EXR_CHANNEL_FLOAT, rgba + 2, 16}, {"A", EXR_CHANNEL_FLOAT, rgba + 3, 16}};
    for (int k = 0; k < STATE_WORDS; k++) {
        state_channel_name(k, names[k], sizeof names[k]);
        chs[4 + k] = (exr_channel){names[k], EXR_CHANNEL_UINT, words + k, 4 * STATE_WORDS};
    }
    attrs_set(a, ATTR_STATE, "batches %u-%u", begin, end);
    exr_string_attr sa[ATTR_MAX];
    exr_window whole = {img->width, img->height, 0, 0, img->width, img->height};
    int rc = exr_write_window_into(set, path, &whole, chs, 4 + STATE_WORDS, string_attrs(a, sa), a->n, err);
    free(words), free(rgba);
    return rc;
}

/* A file without the identity attribute `key`: a state an older build
 * wrote (it has refrender:state, but identities grew since: the build id,
 * camera matrices, ...), or no refrender state at all. */
static int missing_identity(const char *path, const char *key, rr_error *err)
{
    char range[128], build[ATTR_TEXT_MAX];
    if (exr_read_string_attr(path, ATTR_STATE, range, sizeof range, NULL))
        return rr_fail(err, "%s: not a refrender render state (no %s)", path, key);
    if (exr_read_string_attr(path, ATTR_BUILD, build, sizeof build, NULL))
        snprintf(build, sizeof build, "older than build ids");
    return rr_fail(err, "%s: a render state from an older build of refrender (%s '%.80s'; it has no %s): merge or "
                        "resume it with the build that wrote it, or render it again with this one",
                   path, ATTR_BUILD, build, key);
}

static int read_attrs(const char *path, attr_list *a, rr_error *err)
{
    a->n = 0;
    char buf[ATTR_TEXT_MAX];
    for (int k = 0; k < ATTRS_KNOWN; k++) {
        if (attr_table[k].role != ROLE_IDENTITY)
            continue;
        const char *key = attr_table[k].key;
        int rc = exr_read_string_attr(path, key, buf, sizeof buf, err);
        if (rc)
            return rc > 0 ? missing_identity(path, key, err) : -1;
        attrs_set(a, key, "%s", buf);
    }
    for (int k = 0; k < ATTRS_KNOWN; k++) { /* the optional ones */
        if (attr_table[k].role == ROLE_IDENTITY || attr_table[k].role == ROLE_WRITTEN)
            continue;
        int rc = exr_read_string_attr(path, attr_table[k].key, buf, sizeof buf, err);
        if (rc < 0) /* longer than refrender writes: refused, not cut */
            return -1;
        if (!rc)
            attrs_set(a, attr_table[k].key, "%s", buf);
    }
    return 0;
}

/* The data window must be the resolution the identity attributes state:
 * states are merged pixel by pixel. */
static int check_state_size(const char *path, const attr_list *a, int w, int h, rr_error *err)
{
    int rw, rh;
    char extra;
    const char *res = attrs_get(a, ATTR_RESOLUTION);
    if (!res || sscanf(res, "%dx%d%c", &rw, &rh, &extra) != 2 || rw != w || rh != h)
        return rr_fail(err, "%s: data window %dx%d differs from refrender:resolution '%s'", path, w, h,
                       res ? res : "missing");
    return 0;
}

/* zlib (EXR's ZIP) compresses at most about 1032:1 (deflate's longest
 * match, 258 bytes, coded in two bits): a file can hold no more raw state
 * than this many times its size. */
#define ZLIB_MAX_RATIO 1032

/* A state's header declares its size: checked against the file's own size
 * before allocating for it (a 6.5 KB file once made merge ask for 9 GB). */
static int check_state_fits_file(const char *path, int w, int h, rr_error *err)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return rr_fail(err, "%s: %s", path, strerror(errno));
    double raw = (double)w * h * STATE_WORDS * 4;
    if (raw > (double)st.st_size * ZLIB_MAX_RATIO)
        return rr_fail(err, "%s: the header declares a %dx%d state (%.0f bytes of sums) but the file has only %lld "
                            "bytes, too few even at zlib's best ratio: a damaged or crafted state",
                       path, w, h, raw, (long long)st.st_size);
    return 0;
}

/* Every pixel's sums must be ones a render can make (film_check). */
static int check_state_pixels(const char *path, const image *img, rr_error *err)
{
    size_t n = (size_t)img->width * img->height;
    for (size_t i = 0; i < n; i++)
        if (film_check(&img->px[i]))
            return rr_fail(err, "%s: pixel (%zu, %zu) holds sums that no render can produce (%u batches): "
                                "a damaged or crafted state", path, i % (size_t)img->width,
                           i / (size_t)img->width, img->px[i].batches);
    return 0;
}

int output_read_state(const char *path, image *img, attr_list *a, uint32_t *begin, uint32_t *end,
                      rr_error *err)
{
    char range[128], extra;
    int w, h;
    if (exr_read_size(path, &w, &h, err) || read_attrs(path, a, err))
        return -1;
    if (exr_read_string_attr(path, ATTR_STATE, range, sizeof range, NULL) ||
        sscanf(range, "batches %u-%u%c", begin, end, &extra) != 2 || *end < *begin)
        return rr_fail(err, "%s: a final image, not a render state (write states with --pass or --checkpoint)", path);
    if (check_state_size(path, a, w, h, err) || check_state_fits_file(path, w, h, err))
        return -1;
    size_t n = (size_t)w * h;
    uint32_t *words = malloc(n * STATE_WORDS * sizeof *words);
    if (!words || image_alloc(img, w, h)) {
        free(words);
        return rr_fail(err, "%s: out of memory for a %dx%d state", path, w, h);
    }
    int rc = 0;
    for (int k = 0; k < STATE_WORDS && !rc; k++) {
        char name[32];
        state_channel_name(k, name, sizeof name);
        exr_channel ch = {name, EXR_CHANNEL_UINT, words + k, 4 * STATE_WORDS};
        rc = exr_read_channel(path, &ch, 0, NULL, err);
    }
    for (size_t i = 0; i < n && !rc; i++)
        unpack_state(words + i * STATE_WORDS, &img->px[i]);
    free(words);
    if (!rc)
        rc = check_state_pixels(path, img, err);
    if (rc)
        image_free(img);
    return rc;
}
