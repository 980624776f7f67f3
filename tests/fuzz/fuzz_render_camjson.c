/* libFuzzer target that renders: the input is a cameras.json;
 * a fixed 3DGS model of three Gaussians is rendered at 4x4 from its camera
 * "A" (an input of odd length: moving from pose "A" to pose "B"), and the
 * image checked (render_check.h). */
#include <stdint.h>
#include <stdio.h>

#include "formats/gaussian_ply.h"
#include "render_check.h"

static void write_model(void)
{
    static int done;
    if (done)
        return;
    gaussian_model m;
    rr_error err;
    gaussian_model_init(&m);
    m.kind = GAUSSIAN_3D, m.sh_degree = 0, m.sh_coeffs = 1;
    if (gaussian_model_alloc(&m, 3))
        __builtin_trap();
    m.count = 3;
    for (int i = 0; i < 3; i++) {
        float mean[3] = {0.3f * (float)(i - 1), 0.1f * (float)i, 0.5f * (float)i};
        for (int k = 0; k < 3; k++)
            m.mean[3 * i + k] = mean[k], m.scale[3 * i + k] = 0.2f, m.sh[3 * i + k] = 0.5f;
        m.rotation[4 * i] = 1, m.rotation[4 * i + 1] = m.rotation[4 * i + 2] = m.rotation[4 * i + 3] = 0;
        m.opacity[i] = 0.8f;
    }
    char path[256];
    snprintf(path, sizeof path, "%s/g.ply", fuzz_dir());
    if (gaussian_write_ply(path, &m, &err))
        __builtin_trap();
    gaussian_model_free(&m);
    done = 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    write_model();
    if (fuzz_write("cameras.json", data, size))
        return 0;
    const char *motion = size % 2 ? "<animation><pose time=\"0\" image=\"A\"/><pose time=\"1\" image=\"B\"/></animation>"
                                  : "";
    char xml[1024];
    snprintf(xml, sizeof xml,
             "<scene><camera cameras=\"cameras.json\" image=\"A\">%s</camera><shutter open=\"0\" close=\"1\"/>"
             "<object name=\"g\"><gaussianModel file=\"g.ply\"/></object></scene>",
             motion);
    fuzz_render_and_check(xml, 1);
    return 0;
}
