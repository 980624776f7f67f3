/* PNG previews through libpng directly. The preview module (preview.cpp,
 * OpenImageIO) loads some 300 shared libraries: 0.75 s of every render
 * with a .png preview (strace: 316 .so opens; 0.13 s without, 0.90 s with,
 * on the 12x8 scene of tests/test_faults.py). PNG is the format nearly
 * every preview uses, so it skips the module; other extensions still go
 * through OpenImageIO. The chunks say what OpenImageIO 2.4's PNG writer
 * says of an sRGB image (read from its output: gAMA, sRGB with intent 3,
 * cHRM, and an oiio:ColorSpace text), so readers see the same encoding
 * either way; its zero oFFs is left out. */
#include "io/preview_png.h"

#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    unsigned char *bytes;
    size_t len, cap;
    int out_of_memory;
} memory_sink;

static void sink_write(png_structp png, png_bytep data, png_size_t n)
{
    memory_sink *sink = png_get_io_ptr(png);
    if (sink->out_of_memory)
        return;
    if (sink->len + n > sink->cap) {
        size_t cap = 2 * (sink->len + n) + 4096;
        unsigned char *grown = realloc(sink->bytes, cap);
        if (!grown) {
            sink->out_of_memory = 1;
            return;
        }
        sink->bytes = grown, sink->cap = cap;
    }
    memcpy(sink->bytes + sink->len, data, n);
    sink->len += n;
}

static void sink_flush(png_structp png) { (void)png; }

/* libpng reports errors by longjmp; the message is kept for the caller. */
static void on_png_error(png_structp png, png_const_charp msg)
{
    char *why = png_get_error_ptr(png);
    snprintf(why, PREVIEW_PNG_WHY, "libpng: %s", msg);
    png_longjmp(png, 1);
}

static void on_png_warning(png_structp png, png_const_charp msg) { (void)png, (void)msg; }

static void describe_srgb(png_structp png, png_infop info, int w, int h)
{
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_ABSOLUTE);
    static char key[] = "oiio:ColorSpace", value[] = "sRGB";
    png_text text = {.compression = PNG_TEXT_COMPRESSION_NONE, .key = key, .text = value};
    png_set_text(png, info, &text, 1);
}

/* Row pointers are built before setjmp: nothing setjmp's caller changes
 * after it is read after a longjmp (C11 7.13.2.1). */
static int encode_rows(png_structp png, png_infop info, int w, int h, png_bytep *rows)
{
    if (setjmp(png_jmpbuf(png)))
        return -1;
    describe_srgb(png, info, w, h);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, info);
    return 0;
}

int preview_png_encode(int w, int h, const unsigned char *rgb, unsigned char **bytes, size_t *len,
                       char why[PREVIEW_PNG_WHY])
{
    *bytes = NULL, *len = 0, why[0] = 0;
    memory_sink sink = {0};
    png_bytep *rows = malloc((size_t)(h > 0 ? h : 1) * sizeof *rows);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, why, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    int rc = -1;
    if (!rows || !png || !info)
        snprintf(why, PREVIEW_PNG_WHY, "out of memory");
    else {
        for (int y = 0; y < h; y++)
            rows[y] = (png_bytep)rgb + (size_t)3 * w * y;
        png_set_write_fn(png, &sink, sink_write, sink_flush);
        rc = encode_rows(png, info, w, h, rows);
        if (!rc && sink.out_of_memory)
            rc = -1, snprintf(why, PREVIEW_PNG_WHY, "out of memory");
    }
    png_destroy_write_struct(png ? &png : NULL, info ? &info : NULL);
    free(rows);
    if (rc) {
        free(sink.bytes);
        return -1;
    }
    *bytes = sink.bytes, *len = sink.len;
    return 0;
}
