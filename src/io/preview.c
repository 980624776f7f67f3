/* sRGB preview images: PNG through libpng (preview_png.c), any other
 * format through the preview module (preview.cpp, OpenImageIO), opened on
 * first use from the directory of the running executable. */
#include "io/preview.h"

#include <dlfcn.h>
#include <strings.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/atomicfile.h"
#include "io/preview_png.h"

#define PREVIEW_MODULE "refrender-preview.so"

typedef int (*format_fn)(const char *ext);
typedef int (*encode_fn)(const char *path, int w, int h, const unsigned char *rgb, unsigned char **bytes,
                         size_t *len, char *why, size_t why_size);

static struct {
    void *handle;
    format_fn format;
    encode_fn encode;
} module;

/* The module next to the executable (make builds both into one directory). */
static int load_module(rr_error *err)
{
    if (module.handle)
        return 0;
    char exe[PATH_MAX], path[PATH_MAX + 32];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0)
        return rr_fail(err, "--preview: cannot find the running executable to load %s next to it", PREVIEW_MODULE);
    exe[n] = 0;
    char *slash = strrchr(exe, '/');
    *(slash ? slash : exe) = 0;
    snprintf(path, sizeof path, "%s/%s", slash ? exe : ".", PREVIEW_MODULE);
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h)
        return rr_fail(err, "--preview needs %s (OpenImageIO's writers; `make` builds it next to refrender): %s",
                       PREVIEW_MODULE, dlerror());
    module.format = (format_fn)dlsym(h, "rr_preview_format");
    module.encode = (encode_fn)dlsym(h, "rr_preview_encode");
    if (!module.format || !module.encode) {
        dlclose(h);
        return rr_fail(err, "--preview: %s is not refrender's preview module", path);
    }
    module.handle = h;
    return 0;
}

static int is_png(const char *path) { return !strcasecmp(rr_extension(path), ".png"); }

/* The extension with its dot, or "" (a dot in a directory name is none). */
int preview_check_format(const char *path, rr_error *err)
{
    if (is_png(path))
        return 0;
    if (load_module(err))
        return -1;
    const char *ext = rr_extension(path);
    int rc = module.format(*ext ? ext + 1 : "");
    if (rc == 1)
        return rr_fail(err, "%s: no image format for the extension '%s' (use e.g. .png)", path, ext);
    if (rc == 2)
        return rr_fail(err, "%s: OpenImageIO cannot write '%s' through memory, which refrender needs to check every "
                            "write (use .png)", path, ext);
    if (rc)
        return rr_fail(err, "%s: OpenImageIO's '%s' writer, through memory, writes a file it cannot read back "
                            "(use .png)", path, ext);
    return 0;
}

/* The 8-bit display value of v clamped to [0, 1]: encoded with IEC
 * 61966-2-1's sRGB curve if v is linear light, else v itself, rounded half
 * up as torchvision's save_image (clamp(255 v + 0.5)) and Blender do. */
static unsigned char display8(float v, int encoded)
{
    float c = v < 0.f ? 0.f : (v > 1.f ? 1.f : v);
    float e = encoded ? c : c <= 0.0031308f ? 12.92f * c : 1.055f * powf(c, 1.f / 2.4f) - 0.055f;
    return (unsigned char)lroundf(e * 255.f);
}

static int write_all(const char *name, const unsigned char *bytes, size_t len)
{
    FILE *f = fopen(name, "wb");
    if (!f)
        return -1;
    int ok = fwrite(bytes, 1, len, f) == len;
    ok = fflush(f) == 0 && ok;
    return fclose(f) == 0 && ok ? 0 : -1;
}

int preview_write_srgb(const char *path, int w, int h, const float *rgba, const char *color_space, rr_error *err)
{
    return preview_write_srgb_into(NULL, path, w, h, rgba, color_space, err);
}

int preview_write_srgb_into(atomic_set *set, const char *path, int w, int h, const float *rgba,
                            const char *color_space, rr_error *err)
{
    if (preview_check_format(path, err))
        return -1;
    size_t count = (size_t)w * h, len = 0;
    unsigned char *px = malloc(3 * count + 1), *bytes = NULL;
    if (!px)
        return rr_fail(err, "%s: out of memory for the preview", path);
    int encoded = color_space && !strcmp(color_space, "sRGB");
    for (size_t i = 0; i < count; i++)
        for (int c = 0; c < 3; c++)
            px[3 * i + c] = display8(rgba[4 * i + c], encoded);
    char why[512] = "", name[PATH_MAX + 128];
    _Static_assert(sizeof why >= PREVIEW_PNG_WHY, "why holds libpng's reason");
    int rc = is_png(path) ? preview_png_encode(w, h, px, &bytes, &len, why)
                          : module.encode(path, w, h, px, &bytes, &len, why, sizeof why);
    free(px);
    if (rc)
        return rr_fail(err, "%s: cannot encode preview: %s", path, why);
    rc = atomic_create(path, rr_extension(path), name, sizeof name, err);
    if (!rc && write_all(name, bytes, len)) {
        atomic_discard(name);
        rc = rr_fail(err, "%s: cannot write preview (disk full?)", path);
    }
    free(bytes);
    return rc ? -1 : atomic_finish(set, name, path, err);
}
