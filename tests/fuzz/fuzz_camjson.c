/* libFuzzer target: the cameras.json reader (camjson.c, through json-c). */
#include <stdint.h>

#include "formats/camjson.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    camjson_camera c;
    rr_error err;
    camjson_parse("fuzz.json", (const char *)data, size, "A", &c, &err);
    return 0;
}
