/* libFuzzer target: the surfel PLY reader (ply.c). */
#include <stdint.h>

#include "formats/ply.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    pointmodel m;
    rr_error err;
    pointmodel_init(&m);
    ply_parse("fuzz.ply", (const char *)data, size, v3(0.5, 0.5, 0.5), &m, &err);
    pointmodel_free(&m);
    return 0;
}
