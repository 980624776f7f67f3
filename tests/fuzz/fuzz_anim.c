/* libFuzzer target: the Maya .anim reader (animfile.c), on a NUL-terminated
 * copy as animfile_load passes it. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "formats/animfile.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *text = malloc(size + 1);
    if (!text)
        return 0;
    memcpy(text, data, size);
    text[size] = 0;
    keyframes *k = NULL;
    rr_error err;
    if (animfile_parse(text, "fuzz.anim", NULL, &k, NULL, &err) == 0) {
        animation a;
        animation_init_static(&a);
        a.keys = k;
        animation_swept_bounds(&a, (aabb){v3(-1, -1, -1), v3(1, 1, 1)}, 0.0, 1.0);
        animation_free(&a);
    }
    free(text);
    return 0;
}
