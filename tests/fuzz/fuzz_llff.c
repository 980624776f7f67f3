/* libFuzzer target: the LLFF poses_bounds.npy reader (llff.c): the .npy
 * header's dict, the dtype, the shape against the data, each row's pose.
 * Every row of a file that parses must give a usable pinhole at a finite
 * pose whose rotation is orthonormal within the reader's 1e-4. */
#include <stdint.h>
#include <stdlib.h>

#include "core/camera.h"
#include "formats/llff.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    llff_poses p;
    rr_error err;
    if (llff_parse("fuzz.npy", (const char *)data, size, &p, &err))
        return 0;
    for (size_t i = 0; i < p.n && i < 64; i++) {
        camjson_camera c;
        if (llff_find(&p, NULL, (long)i, &c, &err))
            abort(); /* every row was checked */
        double off = 0;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                off = fmax(off, fabs(c.c2w[0][a] * c.c2w[0][b] + c.c2w[1][a] * c.c2w[1][b] +
                                     c.c2w[2][a] * c.c2w[2][b] - (a == b)));
        if (!(off <= 1e-4) || !v3_finite(c.position) || !camera_focal_usable(c.fx, c.width) ||
            !camera_focal_usable(c.fy, c.height) || c.width < 1 || c.height < 1)
            abort();
    }
    llff_free(&p);
    return 0;
}
