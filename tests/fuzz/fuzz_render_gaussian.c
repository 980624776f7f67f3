/* libFuzzer target that renders: the input is a byte choosing
 * the semantics, order and tile rule, then a Gaussian-splat PLY; the model
 * is rendered at 4x4 under a moving camera and the image checked
 * (render_check.h). A target that only parses cannot reach values that
 * load but render wrong (far means, float overflow, quaternions). */
#include <stdint.h>
#include <stdio.h>

#include "render_check.h"

static const char *const looks[] = {
    "kind=\"3dgs\"",
    "kind=\"3dgs\" semantics=\"3dgs-antialiased\" tileRule=\"on\"",
    "kind=\"3dgs\" semantics=\"gsplat\"",
    "kind=\"3dgs\" semantics=\"gsplat-antialiased\"",
    "kind=\"3dgs\" semantics=\"3dgrt\"",
    "kind=\"2dgs\"",
    "kind=\"2dgs\" semantics=\"2dgs-unit-circle\" order=\"hit-depth\"",
    "kind=\"2dgs\" tileRule=\"on\"",
    "kind=\"2dgs\" semantics=\"2dgs-center-near\"",
};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || fuzz_write("m.ply", data + 1, size - 1))
        return 0;
    char xml[1024];
    snprintf(xml, sizeof xml,
             "<scene><camera position=\"0 0 3\" lookat=\"0 0 0\" up=\"0 1 0\" fov=\"40\" width=\"4\" height=\"4\">"
             "<animation><linear velocity=\"0.2 0.1 0\"/></animation></camera><shutter open=\"0\" close=\"1\"/>"
             "<background color=\"0.1 0.2 0.3\"/><object name=\"g\"><gaussianModel file=\"m.ply\" %s/></object>"
             "</scene>",
             looks[data[0] % (sizeof looks / sizeof looks[0])]);
    fuzz_render_and_check(xml, data[0] & 0x80);
    return 0;
}
