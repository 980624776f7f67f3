/* libFuzzer target: the Gaussian-splat PLY reader (gaussian.c), through
 * the generic PLY layer it shares with the surfel reader. */
#include <stdint.h>

#include "formats/gaussian_ply.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    gaussian_model m;
    rr_error err;
    gaussian_model_init(&m);
    gaussian_parse("fuzz.ply", (const char *)data, size, GAUSSIAN_AUTO, &m, &err);
    gaussian_model_free(&m);
    return 0;
}
