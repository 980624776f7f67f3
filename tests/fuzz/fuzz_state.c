/* libFuzzer target: the render-state reader (output.c, exr.c), through a
 * file as `refrender merge` and --resume read states, then a merge. */
#include <stdint.h>
#include <stdio.h>
#include <unistd.h>

#include "io/output.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char path[64];
    if (!path[0])
        snprintf(path, sizeof path, "/tmp/refrender-fuzz-state-%d.exr", (int)getpid());
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    fwrite(data, 1, size, f);
    fclose(f);
    image img;
    static attr_list attrs;
    uint32_t begin, end;
    rr_error err;
    if (output_read_state(path, &img, &attrs, &begin, &end, &err) == 0) {
        image sum;
        if (image_alloc(&sum, img.width, img.height) == 0) {
            for (size_t i = 0; i < (size_t)img.width * img.height; i++) {
                film_merge(&sum.px[i], &img.px[i]);
                double mean[4], var[4];
                film_resolve(&sum.px[i], mean, var);
            }
            image_free(&sum);
        }
        image_free(&img);
    }
    return 0;
}
