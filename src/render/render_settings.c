#include "render/render_settings.h"

const char *pixel_filter_name(pixel_filter f) { return f == PIXEL_FILTER_POINT ? "point" : "box"; }
const char *blur_space_name(blur_space b)
{
    return b == BLUR_SPACE_LINEAR ? "linear" : b == BLUR_SPACE_CLAMPED ? "clamped" : "model";
}

render_settings render_settings_default(void)
{
    render_settings rs = {
        .smp = {.kind = SAMPLER_DEFAULT, .seed = 1, .grid = 1, .tspp = 1, .time_factor = 1},
        .threads = 1,
        .batch_begin = 0,
        .batches = 1,
        .max_batches = 1,
        .filter = PIXEL_FILTER_BOX,
        .blur = BLUR_SPACE_MODEL,
    };
    return rs;
}
