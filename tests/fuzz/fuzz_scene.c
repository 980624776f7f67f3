/* libFuzzer target: the scene XML reader (scene_xml.c). Relative model and
 * .anim paths resolve against a directory that does not exist. */
#include <stdint.h>

#include "scenexml/scene_xml.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    scene s;
    rr_error err;
    if (scene_load_memory((const char *)data, size, "fuzz.xml", "/nonexistent-fuzz-dir", &s, &err) == 0)
        scene_free(&s);
    return 0;
}
