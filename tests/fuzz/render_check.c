#include "render_check.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render.h"
#include "scenexml/scene_xml.h"

const char *fuzz_dir(void)
{
    static char dir[64];
    if (!dir[0]) {
        snprintf(dir, sizeof dir, "/tmp/refrender-fuzz-XXXXXX");
        if (!mkdtemp(dir))
            abort();
    }
    return dir;
}

int fuzz_write(const char *name, const void *data, size_t size)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s", fuzz_dir(), name);
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    size_t wrote = fwrite(data, 1, size, f);
    return fclose(f) == 0 && wrote == size ? 0 : -1;
}

static void check_image(const image *img)
{
    float rgba[4 * 16], var[4 * 16], se[4 * 16], n[16];
    image_resolve(img, 1, rgba, var, se, n);
    for (int p = 0; p < img->width * img->height; p++) {
        for (int c = 0; c < 4; c++)
            if (!isfinite(rgba[4 * p + c]) || rgba[4 * p + c] < -1e-6f) {
                fprintf(stderr, "pixel %d channel %d is %g\n", p, c, rgba[4 * p + c]);
                abort();
            }
        if (rgba[4 * p + 3] > 1.0f + 1e-6f) {
            fprintf(stderr, "pixel %d coverage %g\n", p, rgba[4 * p + 3]);
            abort();
        }
    }
}

void fuzz_render_and_check(const char *xml, int box)
{
    scene s;
    rr_error err;
    if (scene_load_memory(xml, strlen(xml), "fuzz.xml", fuzz_dir(), &s, &err))
        return;
    s.cam.width = s.cam.height = 4; /* as --res: the view is kept */
    accel *a = NULL;
    accel_settings set = {s.epsilon, s.kernel_sigma, 1};
    if (camera_prepare(&s.cam, &err) == 0 && accel_build(&s, &set, &a, &err) == 0) {
        render_settings rs = render_settings_default();
        rs.filter = box ? PIXEL_FILTER_BOX : PIXEL_FILTER_POINT;
        image img;
        volatile sig_atomic_t never = 0;
        if (image_alloc(&img, 4, 4) == 0) {
            if (render_image(a, &rs, &img, NULL, &never, &err) == 0)
                check_image(&img);
            image_free(&img);
        }
        accel_free(a);
    }
    scene_free(&s);
}
