#include "exr.h"

#include <openexr.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Channel names sorted as EXR stores them, and their offset within RGBA. */
static const char *const channel_names[4] = {"A", "B", "G", "R"};
static const int channel_offset[4] = {3, 2, 1, 0};

static int rgba_offset(const char *name)
{
    for (int c = 0; c < 4; c++)
        if (!strcmp(name, channel_names[c]))
            return channel_offset[c];
    return 0;
}

static int exr_fail(rr_error *err, const char *path, const char *what, exr_result_t rc)
{
    return rr_fail(err, "%s: %s: %s", path, what, exr_get_default_error_message(rc));
}

static void silent_handler(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt, (void)code, (void)msg; /* errors are reported through return codes */
}

static exr_result_t write_header(exr_context_t ctx, int w, int h, const exr_string_attr *attrs, int nattrs)
{
    int part;
    exr_result_t rc = exr_add_part(ctx, "rgba", EXR_STORAGE_SCANLINE, &part);
    if (!rc)
        rc = exr_initialize_required_attr_simple(ctx, part, w, h, EXR_COMPRESSION_ZIP);
    for (int c = 0; c < 4 && !rc; c++)
        rc = exr_add_channel(ctx, part, channel_names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1);
    for (int i = 0; i < nattrs && !rc; i++)
        rc = exr_attr_set_string(ctx, part, attrs[i].key, attrs[i].value);
    if (!rc)
        rc = exr_write_header(ctx);
    return rc;
}

static exr_result_t write_chunks(exr_context_t ctx, int w, int h, const float *rgba)
{
    int32_t lines_per_chunk;
    exr_result_t rc = exr_get_scanlines_per_chunk(ctx, 0, &lines_per_chunk);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    for (int y = 0; y < h && !rc; y += lines_per_chunk) {
        exr_chunk_info_t cinfo;
        rc = exr_write_scanline_chunk_info(ctx, 0, y, &cinfo);
        if (!rc)
            rc = initialized ? exr_encoding_update(ctx, 0, &cinfo, &enc)
                             : exr_encoding_initialize(ctx, 0, &cinfo, &enc);
        if (rc)
            break;
        for (int c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 16;
            ch->user_line_stride = 16 * w;
            ch->encode_from_ptr = (const uint8_t *)(rgba + (size_t)y * w * 4 + rgba_offset(ch->channel_name));
        }
        if (!initialized)
            rc = exr_encoding_choose_default_routines(ctx, 0, &enc);
        initialized = 1;
        if (!rc)
            rc = exr_encoding_run(ctx, 0, &enc);
    }
    if (initialized)
        exr_encoding_destroy(ctx, &enc);
    return rc;
}

int exr_write_rgba(const char *path, int w, int h, const float *rgba, const exr_string_attr *attrs,
                   int nattrs, rr_error *err)
{
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp-XXXXXX", path);
    int fd = mkstemp(tmp);
    if (fd < 0)
        return rr_fail(err, "%s: cannot create a temporary file beside the output", path);
    /* mkstemp makes the file private; give it the usual umask permissions */
    mode_t mask = umask(0);
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    close(fd);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = silent_handler;
    exr_context_t ctx;
    exr_result_t rc = exr_start_write(&ctx, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rc) {
        unlink(tmp);
        return exr_fail(err, path, "cannot start writing", rc);
    }
    rc = write_header(ctx, w, h, attrs, nattrs);
    if (!rc)
        rc = write_chunks(ctx, w, h, rgba);
    exr_result_t fin = exr_finish(&ctx);
    if (!rc)
        rc = fin;
    if (rc) {
        unlink(tmp);
        return exr_fail(err, path, "writing failed", rc);
    }
    if (rename(tmp, path)) {
        unlink(tmp);
        return rr_fail(err, "%s: cannot move the finished image into place", path);
    }
    return 0;
}

/* ---- reading ------------------------------------------------------------ */

static exr_result_t decode_channel(exr_context_t ctx, const exr_attr_box2i_t *dw, int chan,
                                   float *plane, int *found)
{
    int w = dw->max.x - dw->min.x + 1, h = dw->max.y - dw->min.y + 1;
    int32_t lines;
    exr_result_t rc = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    *found = 0;
    for (int y = dw->min.y; y <= dw->max.y && !rc; y += lines) {
        exr_chunk_info_t cinfo;
        rc = exr_read_scanline_chunk_info(ctx, 0, y, &cinfo);
        if (!rc)
            rc = initialized ? exr_decoding_update(ctx, 0, &cinfo, &dec)
                             : exr_decoding_initialize(ctx, 0, &cinfo, &dec);
        if (rc)
            break;
        int row = cinfo.start_y - dw->min.y;
        for (int c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            int wanted = !strcmp(ch->channel_name, channel_names[chan]);
            *found |= wanted;
            ch->decode_to_ptr = wanted ? (uint8_t *)(plane + (size_t)row * w) : NULL;
            ch->user_pixel_stride = 4;
            ch->user_line_stride = 4 * w;
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
        }
        if (!initialized)
            rc = exr_decoding_choose_default_routines(ctx, 0, &dec);
        initialized = 1;
        if (!rc)
            rc = exr_decoding_run(ctx, 0, &dec);
    }
    (void)h;
    if (initialized)
        exr_decoding_destroy(ctx, &dec);
    return rc;
}

static exr_context_t open_for_read(const char *path, exr_result_t *rc)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = silent_handler;
    exr_context_t ctx = NULL;
    *rc = exr_start_read(&ctx, path, &init);
    return ctx;
}

int exr_read_rgba(const char *path, int *w, int *h, float **rgba, rr_error *err)
{
    exr_result_t rc;
    exr_context_t ctx = open_for_read(path, &rc);
    if (rc)
        return exr_fail(err, path, "cannot read", rc);
    exr_attr_box2i_t dw;
    rc = exr_get_data_window(ctx, 0, &dw);
    int width = dw.max.x - dw.min.x + 1, height = dw.max.y - dw.min.y + 1;
    size_t n = (size_t)width * (size_t)height;
    float *plane = rc ? NULL : malloc(n * sizeof *plane);
    float *out = rc ? NULL : malloc(n * 4 * sizeof *out);
    for (int c = 0; c < 4 && !rc && plane && out; c++) {
        int found;
        rc = decode_channel(ctx, &dw, c, plane, &found);
        for (size_t i = 0; i < n && !rc; i++)
            out[4 * i + channel_offset[c]] = found ? plane[i] : (c == 0 ? 1.0f : 0.0f);
    }
    exr_finish(&ctx);
    free(plane);
    if (rc || !out) {
        free(out);
        return rc ? exr_fail(err, path, "cannot decode", rc) : rr_fail(err, "%s: out of memory", path);
    }
    *w = width;
    *h = height;
    *rgba = out;
    return 0;
}

int exr_read_string_attr(const char *path, const char *key, char *buf, size_t size, rr_error *err)
{
    exr_result_t rc;
    exr_context_t ctx = open_for_read(path, &rc);
    if (rc)
        return exr_fail(err, path, "cannot read", rc);
    int32_t len = 0;
    const char *s = NULL;
    rc = exr_attr_get_string(ctx, 0, key, &len, &s);
    if (!rc)
        snprintf(buf, size, "%.*s", (int)len, s);
    exr_finish(&ctx);
    return rc ? rr_fail(err, "%s: no string attribute '%s'", path, key) : 0;
}
