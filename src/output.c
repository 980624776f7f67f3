#include "output.h"

#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "exr.h"

static const char *const identity_keys[] = {
    "refrender:sceneHash", "refrender:inputsHash", "refrender:resolution", "refrender:sampler", "refrender:spp",
    "refrender:tspp", "refrender:seed", "refrender:epsilon", "refrender:kernelSigma",
    "refrender:shutter", "refrender:weightFunction", "refrender:timeFactor", "refrender:batches",
    "refrender:timeIntegration", "refrender:parameters", "refrender:parametersHash", "refrender:weightHash",
    "refrender:pixelFilter", "refrender:blurSpace", "refrender:gaussians", "refrender:gaussiansHash",
    "refrender:rollingShutter", NULL};

/* Attributes that describe a render without being its identity (README,
 * Output), and what a merge of its states writes for each: the frame and
 * the camera are those of every state, so they must agree (a misnumbered
 * pass would otherwise pass as the frame); rays and seconds are the work
 * of all states together, so they add up. */
static const char *const equal_keys[] = {"worldToCamera", "worldToNDC", "refrender:shutterOpen",
                                         "refrender:shutterClose", "refrender:frame", "refrender:frameRate", NULL};
static const char *const summed_keys[] = {"refrender:rays", "refrender:renderSeconds", NULL};
#define UNRESOLVED_KEY "refrender:exactUnresolvedShare"

/* The attributes stored as EXR numbers (README, Output). */
static rr_attr_kind attr_kind(const char *key)
{
    static const char *const ints[] = {"refrender:spp", "refrender:tspp", "refrender:timeFactor",
                                       "refrender:batches", "refrender:frame", NULL};
    static const char *const doubles[] = {"refrender:epsilon", "refrender:kernelSigma", "refrender:targetError",
                                          "refrender:renderSeconds", "refrender:rays", "refrender:frameRate",
                                          "refrender:shutterOpen", "refrender:shutterClose", NULL};
    for (const char *const *k = ints; *k; k++)
        if (!strcmp(*k, key))
            return RR_ATTR_INT;
    for (const char *const *k = doubles; *k; k++)
        if (!strcmp(*k, key))
            return RR_ATTR_DOUBLE;
    return !strcmp(key, "worldToCamera") || !strcmp(key, "worldToNDC") ? RR_ATTR_M44F : RR_ATTR_TEXT;
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
    for (const char *const *k = identity_keys; *k; k++) {
        const char *va = attrs_get(a, *k), *vb = attrs_get(b, *k);
        if (!va || !vb || strcmp(va, vb))
            return rr_fail(err, "%s and %s differ in %s ('%.160s' vs '%.160s'): not the same render", a_name, b_name,
                           *k, va ? va : "missing", vb ? vb : "missing");
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

/* Exact time's unresolved share is per traced ray (main.c), so the share
 * of states together is their ray-weighted mean; called before the rays
 * are summed. */
static void combine_unresolved(attr_list *merged, const attr_list *b)
{
    const char *sa = attrs_get(merged, UNRESOLVED_KEY), *sb = attrs_get(b, UNRESOLVED_KEY);
    const char *ra = attrs_get(merged, "refrender:rays"), *rb = attrs_get(b, "refrender:rays");
    if (!sa || !sb || !ra || !rb)
        return;
    double wa = strtod(ra, NULL), wb = strtod(rb, NULL);
    double share = wa + wb > 0 ? (strtod(sa, NULL) * wa + strtod(sb, NULL) * wb) / (wa + wb) : 0.0;
    attrs_set(merged, UNRESOLVED_KEY, "%.6g", share);
}

int attrs_combine(attr_list *merged, const char *merged_name, const attr_list *b, const char *b_name, rr_error *err)
{
    for (const char *const *k = equal_keys; *k; k++) {
        if (check_both_have(merged, merged_name, b, b_name, *k, err))
            return -1;
        const char *va = attrs_get(merged, *k), *vb = attrs_get(b, *k);
        if (va && strcmp(va, vb))
            return rr_fail(err, "%s and %s differ in %s ('%.160s' vs '%.160s'): not the same frame and camera",
                           merged_name, b_name, *k, va, vb);
    }
    if (check_both_have(merged, merged_name, b, b_name, UNRESOLVED_KEY, err))
        return -1;
    for (const char *const *k = summed_keys; *k; k++)
        if (check_both_have(merged, merged_name, b, b_name, *k, err))
            return -1;
    combine_unresolved(merged, b);
    const char *rays = attrs_get(merged, "refrender:rays"), *secs = attrs_get(merged, "refrender:renderSeconds");
    if (rays) /* a double holds counts exactly up to 2^53 rays */
        attrs_set(merged, "refrender:rays", "%.17g", strtod(rays, NULL) + strtod(attrs_get(b, "refrender:rays"), NULL));
    if (secs)
        attrs_set(merged, "refrender:renderSeconds", "%.3f",
                  strtod(secs, NULL) + strtod(attrs_get(b, "refrender:renderSeconds"), NULL));
    return 0;
}

static exr_string_attr *string_attrs(const attr_list *a, exr_string_attr *out)
{
    for (int i = 0; i < a->n; i++)
        out[i] = (exr_string_attr){a->key[i], a->value[i], a->kind[i]};
    return out;
}

int output_write_final(const char *path, const image *img, int samples_per_batch, const attr_list *a,
                       rr_error *err)
{
    exr_window whole = {img->width, img->height, 0, 0, img->width, img->height};
    return output_write_final_window(path, img, samples_per_batch, a, &whole, err);
}

/* Moves the window's pixels (elems floats each) to the front, row after row. */
static void compact_window(float *plane, int elems, const exr_window *win)
{
    size_t row = (size_t)win->w * elems;
    for (int y = 0; y < win->h; y++)
        memmove(plane + y * row, plane + ((size_t)(win->y0 + y) * win->full_w + win->x0) * elems, row * sizeof *plane);
}

int output_write_final_window(const char *path, const image *img, int samples_per_batch, const attr_list *a,
                              const exr_window *win, rr_error *err)
{
    return output_write_final_into(NULL, path, img, samples_per_batch, a, win, err);
}

int output_write_final_into(atomic_set *set, const char *path, const image *img, int samples_per_batch,
                            const attr_list *a, const exr_window *win, rr_error *err)
{
    size_t n = (size_t)img->width * img->height;
    float *rgba = malloc(n * 4 * sizeof *rgba), *var = malloc(n * 4 * sizeof *var);
    float *se = malloc(n * 4 * sizeof *se), *samples = malloc(n * sizeof *samples);
    int rc = -1;
    if (rgba && var && se && samples) {
        image_resolve(img, samples_per_batch, rgba, var, se, samples);
        uint32_t most = 0;
        for (size_t i = 0; i < n; i++)
            most = img->px[i].batches > most ? img->px[i].batches : most;
        static const char *const names[3][4] = {{"R", "G", "B", "A"},
                                                {"variance.R", "variance.G", "variance.B", "variance.A"},
                                                {"stderr.R", "stderr.G", "stderr.B", "stderr.A"}};
        float *planes[3] = {rgba, var, se};
        exr_channel chs[13];
        int nch = 0;
        for (int k = 0; k < (most >= 2 ? 3 : 1); k++)
            for (int c = 0; c < 4; c++)
                chs[nch++] = (exr_channel){names[k][c], EXR_CHANNEL_FLOAT, planes[k] + c, 16};
        chs[nch++] = (exr_channel){"samples", EXR_CHANNEL_FLOAT, samples, 4};
        for (int k = 0; k < 3; k++)
            compact_window(planes[k], 4, win);
        compact_window(samples, 1, win);
        exr_string_attr sa[ATTR_MAX];
        rc = exr_write_window_into(set, path, win, chs, nch, string_attrs(a, sa), a->n, err);
    } else {
        rr_fail(err, "out of memory");
    }
    free(rgba), free(var), free(se), free(samples);
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
    attrs_set(a, "refrender:state", "batches %u-%u", begin, end);
    exr_string_attr sa[ATTR_MAX];
    exr_window whole = {img->width, img->height, 0, 0, img->width, img->height};
    int rc = exr_write_window_into(set, path, &whole, chs, 4 + STATE_WORDS, string_attrs(a, sa), a->n, err);
    free(words), free(rgba);
    return rc;
}

static int read_attrs(const char *path, attr_list *a, rr_error *err)
{
    static const char *const keys[] = {"refrender:scene", "refrender:command", "software", "refrender:background",
                                       "refrender:alpha", UNRESOLVED_KEY, NULL};
    const char *const *optional[] = {keys, equal_keys, summed_keys};
    a->n = 0;
    char buf[ATTR_TEXT_MAX];
    for (const char *const *k = identity_keys; *k; k++) {
        int rc = exr_read_string_attr(path, *k, buf, sizeof buf, err);
        if (rc)
            return rc > 0 ? rr_fail(err, "%s: not a refrender render state (no %s)", path, *k) : -1;
        attrs_set(a, *k, "%s", buf);
    }
    for (int list = 0; list < 3; list++)
        for (const char *const *k = optional[list]; *k; k++) {
            int rc = exr_read_string_attr(path, *k, buf, sizeof buf, err);
            if (rc < 0) /* longer than refrender writes: refused, not cut */
                return -1;
            if (!rc)
                attrs_set(a, *k, "%s", buf);
        }
    return 0;
}

/* The data window must be the resolution the identity attributes state:
 * states are merged pixel by pixel. */
static int check_state_size(const char *path, const attr_list *a, int w, int h, rr_error *err)
{
    int rw, rh;
    char extra;
    const char *res = attrs_get(a, "refrender:resolution");
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
    if (exr_read_string_attr(path, "refrender:state", range, sizeof range, NULL) ||
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
