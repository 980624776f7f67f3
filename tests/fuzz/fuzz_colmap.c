/* libFuzzer target: the COLMAP sparse model reader (colmap.c). Byte 0
 * chooses text (odd) or binary, bytes 1-2 the length of the cameras file
 * (big-endian), the rest is the images file. Every image of a model that
 * parses is looked up by id and by name; a camera found must be a usable
 * pinhole at a finite pose with an orthonormal rotation. */
#include <stdint.h>
#include <stdlib.h>

#include "core/camera.h"
#include "formats/colmap.h"

static void check(const camjson_camera *c)
{
    double off = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            off = fmax(off, fabs(c->c2w[0][a] * c->c2w[0][b] + c->c2w[1][a] * c->c2w[1][b] +
                                 c->c2w[2][a] * c->c2w[2][b] - (a == b)));
    if (!(off < 1e-9) || !v3_finite(c->position) || c->width < 1 || c->width > 65536 || c->height < 1 ||
        c->height > 65536 || !camera_focal_usable(c->fx, c->width) || !camera_focal_usable(c->fy, c->height) ||
        !camera_principal_usable(c->fx, c->cx, c->width) || !camera_principal_usable(c->fy, c->cy, c->height))
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 3)
        return 0;
    int text = data[0] & 1;
    size_t ncam = (size_t)data[1] << 8 | data[2];
    if (ncam > size - 3)
        ncam = size - 3;
    colmap_model m = {0};
    rr_error err;
    if (!colmap_parse_cameras("cameras", (const char *)data + 3, ncam, text, &m, &err) &&
        !colmap_parse_images("images", (const char *)data + 3 + ncam, size - 3 - ncam, text, &m, &err))
        for (size_t i = 0; i < m.nimages && i < 64; i++) {
            camjson_camera c;
            if (!colmap_find(&m, NULL, m.images[i].id, &c, &err))
                check(&c);
            if (!colmap_find(&m, m.images[i].name, -1, &c, &err))
                check(&c);
        }
    colmap_free(&m);
    return 0;
}
