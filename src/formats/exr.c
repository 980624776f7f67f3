#include "formats/exr.h"

#include <limits.h>
#include <openexr.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/atomicfile.h"

static int exr_fail(rr_error *err, const char *path, const char *what, exr_result_t rc)
{
    return rr_fail(err, "%s: %s: %s", path, what, exr_get_default_error_message(rc));
}

static void silent_handler(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt, (void)code, (void)msg; /* errors are reported through return codes */
}

static exr_pixel_type_t pixel_type(exr_channel_type t) { return t == EXR_CHANNEL_UINT ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT; }

static const exr_channel *find_channel(const exr_channel *chs, int n, const char *name)
{
    for (int i = 0; i < n; i++)
        if (!strcmp(chs[i].name, name))
            return &chs[i];
    return NULL;
}

int exr_attr_numbers(const exr_string_attr *a, double out[16])
{
    const char *p = a->value;
    switch (a->kind) {
    case RR_ATTR_INT: out[0] = (int32_t)strtol(p, NULL, 10); return 1;
    case RR_ATTR_DOUBLE: out[0] = strtod(p, NULL); return 1;
    case RR_ATTR_M44F:
        for (int k = 0; k < 16; k++) { /* a float each, as the file holds it */
            char *end;
            out[k] = strtof(p, &end);
            if (end == p)
                return -1;
            p = end;
        }
        return 16;
    case RR_ATTR_TEXT: break;
    }
    return 0;
}

static exr_result_t set_attr(exr_context_t ctx, int part, const exr_string_attr *a)
{
    double v[16];
    exr_attr_m44f_t m;
    switch (exr_attr_numbers(a, v)) {
    case -1: return EXR_ERR_INVALID_ARGUMENT;
    case 0: return exr_attr_set_string(ctx, part, a->key, a->value);
    case 16:
        for (int k = 0; k < 16; k++)
            m.m[k] = (float)v[k];
        return exr_attr_set_m44f(ctx, part, a->key, &m);
    }
    return a->kind == RR_ATTR_INT ? exr_attr_set_int(ctx, part, a->key, (int32_t)v[0])
                                  : exr_attr_set_double(ctx, part, a->key, v[0]);
}

static exr_result_t write_header(exr_context_t ctx, const exr_window *win, const exr_channel *chs, int nch,
                                 const exr_string_attr *attrs, int nattrs)
{
    int part;
    exr_result_t rc = exr_add_part(ctx, "image", EXR_STORAGE_SCANLINE, &part);
    exr_attr_box2i_t display, data;
    display.min.x = 0, display.min.y = 0, display.max.x = win->full_w - 1, display.max.y = win->full_h - 1;
    data.min.x = win->x0, data.min.y = win->y0;
    data.max.x = win->x0 + win->w - 1, data.max.y = win->y0 + win->h - 1;
    exr_attr_v2f_t center;
    center.x = 0.0f, center.y = 0.0f;
    if (!rc)
        rc = exr_initialize_required_attr(ctx, part, &display, &data, 1.0f, &center, 1.0f, EXR_LINEORDER_INCREASING_Y,
                                          EXR_COMPRESSION_ZIP);
    for (int c = 0; c < nch && !rc; c++)
        rc = exr_add_channel(ctx, part, chs[c].name, pixel_type(chs[c].type), EXR_PERCEPTUALLY_LINEAR, 1, 1);
    for (int i = 0; i < nattrs && !rc; i++)
        rc = set_attr(ctx, part, &attrs[i]);
    if (!rc)
        rc = exr_write_header(ctx);
    return rc;
}

/* OpenEXRCore 3.1.5 (Debian 12) ZIP encoder bug (upstream
 * AcademySoftwareFoundation/openexr issue #2306, fixed by PR #2307): when
 * zlib's output is exactly as long as the packed chunk it keeps the zlib
 * bytes, but every reader takes a chunk whose stored size equals its
 * unpacked size as raw data, so the pixels read back as garbage.
 * The file format's rule (OpenEXR file layout: "either the compressed or the
 * uncompressed data are stored, whichever is smaller") is enforced here after
 * the library's own compressor: a chunk that did not shrink is stored raw. */
typedef struct {
    exr_result_t (*library_compress)(exr_encode_pipeline_t *);
} compress_guard;

static exr_result_t compress_or_store_raw(exr_encode_pipeline_t *enc)
{
    const compress_guard *guard = enc->encoding_user_data;
    exr_result_t rc = guard->library_compress(enc);
    if (rc || enc->compressed_bytes < enc->packed_bytes)
        return rc;
    if (enc->compressed_buffer != enc->packed_buffer)
        memcpy(enc->compressed_buffer, enc->packed_buffer, enc->packed_bytes);
    enc->compressed_bytes = enc->packed_bytes;
    return rc;
}

static exr_result_t choose_routines(exr_context_t ctx, exr_encode_pipeline_t *enc, compress_guard *guard)
{
    exr_result_t rc = exr_encoding_choose_default_routines(ctx, 0, enc);
    if (!rc && enc->compress_fn) {
        guard->library_compress = enc->compress_fn;
        enc->encoding_user_data = guard;
        enc->compress_fn = compress_or_store_raw;
    }
    return rc;
}

static exr_result_t write_chunks(exr_context_t ctx, const exr_window *win, const exr_channel *chs, int nch)
{
    int w = win->w, h = win->h;
    int32_t lines_per_chunk;
    exr_result_t rc = exr_get_scanlines_per_chunk(ctx, 0, &lines_per_chunk);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    compress_guard guard = {NULL};
    int initialized = 0;
    for (int c = 0; c < nch && !rc; c++)
        if ((long long)chs[c].stride * w > INT32_MAX)
            rc = EXR_ERR_INVALID_ARGUMENT; /* OpenEXRCore's line stride is 32-bit */
    for (int y = 0; y < h && !rc; y += lines_per_chunk) {
        exr_chunk_info_t cinfo;
        rc = exr_write_scanline_chunk_info(ctx, 0, win->y0 + y, &cinfo);
        if (!rc)
            rc = initialized ? exr_encoding_update(ctx, 0, &cinfo, &enc)
                             : exr_encoding_initialize(ctx, 0, &cinfo, &enc);
        if (rc)
            break;
        for (int c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *info = &enc.channels[c];
            const exr_channel *src = find_channel(chs, nch, info->channel_name);
            info->user_bytes_per_element = 4;
            info->user_data_type = (uint16_t)pixel_type(src->type);
            info->user_pixel_stride = src->stride;
            info->user_line_stride = src->stride * w;
            info->encode_from_ptr = (const uint8_t *)src->base + (size_t)y * w * src->stride;
        }
        if (!initialized)
            rc = choose_routines(ctx, &enc, &guard);
        initialized = 1;
        if (!rc)
            rc = exr_encoding_run(ctx, 0, &enc);
    }
    if (initialized)
        exr_encoding_destroy(ctx, &enc);
    return rc;
}

int exr_write(const char *path, int w, int h, const exr_channel *channels, int nchannels,
              const exr_string_attr *attrs, int nattrs, rr_error *err)
{
    exr_window whole = {w, h, 0, 0, w, h};
    return exr_write_window(path, &whole, channels, nchannels, attrs, nattrs, err);
}

int exr_write_window(const char *path, const exr_window *win, const exr_channel *channels, int nchannels,
                     const exr_string_attr *attrs, int nattrs, rr_error *err)
{
    return exr_write_window_into(NULL, path, win, channels, nchannels, attrs, nattrs, err);
}

int exr_write_window_into(atomic_set *set, const char *path, const exr_window *win, const exr_channel *channels,
                          int nchannels, const exr_string_attr *attrs, int nattrs, rr_error *err)
{
    char tmp[PATH_MAX + 64];
    if (atomic_create(path, "", tmp, sizeof tmp, err))
        return -1;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = silent_handler;
    exr_context_t ctx;
    exr_result_t rc = exr_start_write(&ctx, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rc) {
        atomic_discard(tmp);
        return exr_fail(err, path, "cannot start writing", rc);
    }
    rc = write_header(ctx, win, channels, nchannels, attrs, nattrs);
    if (!rc)
        rc = write_chunks(ctx, win, channels, nchannels);
    exr_result_t fin = exr_finish(&ctx);
    if (!rc)
        rc = fin;
    if (rc) {
        atomic_discard(tmp);
        return exr_fail(err, path, "writing failed", rc);
    }
    return atomic_finish(set, tmp, path, err);
}

int exr_write_rgba(const char *path, int w, int h, const float *rgba, const exr_string_attr *attrs,
                   int nattrs, rr_error *err)
{
    float *p = (float *)rgba;
    exr_channel chs[4] = {{"R", EXR_CHANNEL_FLOAT, p, 16}, {"G", EXR_CHANNEL_FLOAT, p + 1, 16},
                          {"B", EXR_CHANNEL_FLOAT, p + 2, 16}, {"A", EXR_CHANNEL_FLOAT, p + 3, 16}};
    return exr_write(path, w, h, chs, 4, attrs, nattrs, err);
}

/* ---- reading ------------------------------------------------------------ */

/* The data window's size, computed in 64 bits (a crafted header can hold
 * INT_MIN..INT_MAX) and bounded by RR_MAX_PIXELS before anything is
 * allocated for it. */
static int window_size(const char *path, const exr_attr_box2i_t *dw, int *w, int *h, rr_error *err)
{
    long long ww = (long long)dw->max.x - dw->min.x + 1, hh = (long long)dw->max.y - dw->min.y + 1;
    if (ww < 1 || hh < 1 || ww > RR_MAX_PIXELS || hh > RR_MAX_PIXELS || ww * hh > RR_MAX_PIXELS)
        return rr_fail(err, "%s: data window %lldx%lld is empty or larger than the %lld pixels refrender reads",
                       path, ww, hh, RR_MAX_PIXELS);
    *w = (int)ww, *h = (int)hh;
    return 0;
}

static const char *pixel_type_name(exr_pixel_type_t t)
{
    return t == EXR_PIXEL_UINT ? "uint" : t == EXR_PIXEL_HALF ? "half" : t == EXR_PIXEL_FLOAT ? "float" : "unknown";
}

/* An exact integer channel must be stored as uint: a half or float one
 * would be converted, not read. Float channels may be stored as half. */
static int check_channel_type(exr_context_t ctx, const char *path, const exr_channel *ch, rr_error *err)
{
    const exr_attr_chlist_t *chl = NULL;
    if (exr_get_channels(ctx, 0, &chl) || !chl)
        return rr_fail(err, "%s: cannot read the channel list", path);
    for (int i = 0; i < chl->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[i];
        if (strcmp(e->name.str, ch->name))
            continue;
        if (e->x_sampling != 1 || e->y_sampling != 1)
            return rr_fail(err, "%s: channel %s is subsampled; refrender reads full-resolution channels", path,
                           ch->name);
        if (ch->type == EXR_CHANNEL_UINT && e->pixel_type != EXR_PIXEL_UINT)
            return rr_fail(err, "%s: channel %s is %s, expected uint", path, ch->name,
                           pixel_type_name(e->pixel_type));
        if (ch->type == EXR_CHANNEL_FLOAT && e->pixel_type == EXR_PIXEL_UINT)
            return rr_fail(err, "%s: channel %s is uint, expected float or half", path, ch->name);
    }
    return 0;
}

static exr_context_t open_for_read(const char *path, exr_result_t *rc)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = silent_handler;
    exr_context_t ctx = NULL;
    *rc = exr_start_read(&ctx, path, &init);
    return ctx;
}

/* Decodes one channel of every chunk into ch; *found tells whether the file has it. */
static exr_result_t decode_channel(exr_context_t ctx, const exr_attr_box2i_t *dw, int w, const exr_channel *ch,
                                   int *found)
{
    int32_t lines;
    exr_result_t rc = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0, routines = 0;
    *found = 0;
    for (int y = dw->min.y; y <= dw->max.y && !rc; y += lines) {
        exr_chunk_info_t cinfo;
        rc = exr_read_scanline_chunk_info(ctx, 0, y, &cinfo);
        if (!rc)
            rc = initialized ? exr_decoding_update(ctx, 0, &cinfo, &dec)
                             : exr_decoding_initialize(ctx, 0, &cinfo, &dec);
        if (rc)
            break;
        initialized = 1;
        long long row = (long long)cinfo.start_y - dw->min.y;
        if (row < 0 || row >= (long long)dw->max.y - dw->min.y + 1) {
            rc = EXR_ERR_BAD_CHUNK_LEADER;
            break;
        }
        for (int c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *info = &dec.channels[c];
            int wanted = !strcmp(info->channel_name, ch->name);
            *found |= wanted;
            info->decode_to_ptr = wanted ? (uint8_t *)ch->base + (size_t)row * w * ch->stride : NULL;
            info->user_pixel_stride = ch->stride;
            info->user_line_stride = ch->stride * w; /* fits: check_readable */
            info->user_bytes_per_element = 4;
            info->user_data_type = (uint16_t)pixel_type(ch->type);
        }
        if (!*found)
            break;
        if (!routines)
            rc = exr_decoding_choose_default_routines(ctx, 0, &dec);
        routines = 1;
        if (!rc)
            rc = exr_decoding_run(ctx, 0, &dec);
    }
    if (initialized)
        exr_decoding_destroy(ctx, &dec);
    return rc;
}

int exr_read_size(const char *path, int *w, int *h, rr_error *err)
{
    exr_result_t rc;
    exr_context_t ctx = open_for_read(path, &rc);
    if (rc)
        return exr_fail(err, path, "cannot read", rc);
    exr_attr_box2i_t dw;
    rc = exr_get_data_window(ctx, 0, &dw);
    exr_finish(&ctx);
    if (rc)
        return exr_fail(err, path, "cannot read the data window", rc);
    return window_size(path, &dw, w, h, err);
}

/* Everything checked before a channel is decoded into the caller's buffer. */
static int check_readable(exr_context_t ctx, const char *path, const exr_channel *ch, exr_attr_box2i_t *dw, int *w,
                          rr_error *err)
{
    int h;
    exr_result_t rc = exr_get_data_window(ctx, 0, dw);
    if (rc)
        return exr_fail(err, path, "cannot read the data window", rc);
    if (window_size(path, dw, w, &h, err))
        return -1;
    if ((long long)ch->stride * *w > INT32_MAX)
        return rr_fail(err, "%s: rows of %d pixels are too wide for OpenEXRCore's 32-bit line stride", path, *w);
    return check_channel_type(ctx, path, ch, err);
}

int exr_read_channel(const char *path, const exr_channel *ch, int optional, int *found, rr_error *err)
{
    exr_result_t rc;
    exr_context_t ctx = open_for_read(path, &rc);
    if (rc)
        return exr_fail(err, path, "cannot read", rc);
    exr_attr_box2i_t dw;
    int have = 0, w;
    if (check_readable(ctx, path, ch, &dw, &w, err)) {
        exr_finish(&ctx);
        return -1;
    }
    rc = decode_channel(ctx, &dw, w, ch, &have);
    exr_finish(&ctx);
    if (rc)
        return exr_fail(err, path, "cannot decode", rc);
    if (found)
        *found = have;
    if (!have && !optional)
        return rr_fail(err, "%s: no channel '%s'", path, ch->name);
    return 0;
}

int exr_read_rgba(const char *path, int *w, int *h, float **rgba, rr_error *err)
{
    if (exr_read_size(path, w, h, err))
        return -1;
    size_t n = (size_t)*w * (size_t)*h;
    float *out = malloc(n * 4 * sizeof *out);
    if (!out)
        return rr_fail(err, "%s: out of memory", path);
    for (size_t i = 0; i < n; i++)
        out[4 * i + 3] = 1.0f; /* alpha defaults to opaque */
    static const char *const names[4] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; c++) {
        exr_channel ch = {names[c], EXR_CHANNEL_FLOAT, out + c, 16};
        if (exr_read_channel(path, &ch, c == 3, NULL, err)) {
            free(out);
            return -1;
        }
    }
    *rgba = out;
    return 0;
}

/* 16 numbers as exr_attr_numbers reads them; %.9g gives each float back exactly. */
static void format_matrix(const float m[16], char *buf, size_t size)
{
    size_t len = 0;
    for (int k = 0; k < 16 && len < size; k++)
        len += (size_t)snprintf(buf + len, size - len, "%s%.9g", k ? " " : "", (double)m[k]);
}

int exr_read_string_attr(const char *path, const char *key, char *buf, size_t size, rr_error *err)
{
    exr_result_t rc;
    exr_context_t ctx = open_for_read(path, &rc);
    if (rc)
        return exr_fail(err, path, "cannot read", rc);
    const exr_attribute_t *a = NULL;
    rc = exr_get_attribute_by_name(ctx, 0, key, &a);
    int ok = !rc && a;
    if (ok && a->type == EXR_ATTR_STRING && (size_t)a->string->length >= size) { /* never cut: refuse */
        int length = a->string->length;
        exr_finish(&ctx);
        return rr_fail(err, "%s: attribute '%s' is %d characters long: at most %zu are read", path, key, length,
                       size - 1);
    }
    if (ok && a->type == EXR_ATTR_STRING)
        snprintf(buf, size, "%.*s", (int)a->string->length, a->string->str);
    else if (ok && a->type == EXR_ATTR_INT)
        snprintf(buf, size, "%d", (int)a->i);
    else if (ok && a->type == EXR_ATTR_DOUBLE)
        snprintf(buf, size, "%.17g", a->d);
    else if (ok && a->type == EXR_ATTR_FLOAT)
        snprintf(buf, size, "%.9g", (double)a->f);
    else if (ok && a->type == EXR_ATTR_M44F)
        format_matrix(a->m44f->m, buf, size);
    else
        ok = 0;
    exr_finish(&ctx);
    return ok ? 0 : (rr_fail(err, "%s: no string or number attribute '%s'", path, key), 1);
}
