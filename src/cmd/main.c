/* refrender: the dispatcher to the subcommands (the *_cmd.c files beside it) and the
 * program's usage. */
#include <stdio.h>
#include <string.h>

#include "cmd/commands.h"

void refrender_usage(FILE *f)
{
    fputs(
"usage: refrender [options] [SCENE.xml]\n"
"       refrender merge STATE.exr [STATE.exr ...] -o OUT.exr   (see 'refrender merge --help')\n"
"       refrender gen SHAPE [options] -o FILE.ply              (see 'refrender gen --help')\n"
"       refrender surfels MESH|CLOUD [options] -o FILE.ply     (see 'refrender surfels --help')\n"
"       refrender export SCENE.xml [options] -o SCENE.json     (see 'refrender export --help')\n"
"       refrender splat METHOD SCENE.xml [options] -o OUT.exr  (the thesis's splatting; 'refrender splat --help')\n"
"       refrender dataset SCENE.xml --layout llff|nerfstudio --frames A-B -o DIR  (a deblurring benchmark)\n"
"\n"
"Renders a ground-truth motion-blurred image of a point-based scene by Monte\n"
"Carlo ray tracing (Wolf 2008, sec. 4.5) into a 32-bit float EXR. Without SCENE\n"
"the bundled scenes/default.xml is rendered. Details of every option: README.md.\n"
"\n"
"Sampling:\n"
"  --spp N            spatial samples per pixel, a KxK grid (default 4)\n"
"  --pixel-filter F   box (default): samples over the pixel; point: at its centre\n"
"  --tspp N           temporal samples per spatial sample (default 100)\n"
"  --sampler S        sobol (default), jittered3d or thesis (Wolf 2008 sec. 4.5)\n"
"  --seed N           random seed: same seed, same image, any threads (default 1)\n"
"  --batches B        independent batches; B >= 2 adds standard errors (default 1)\n"
"  --target-error X   more batches where a pixel's RGB standard error exceeds X, in value\n"
"                     units (0.002) or 8-bit levels (0.5lv); B 4 unless given\n"
"  --max-batches N    batch cap for --target-error (default 8*B)\n"
"Time:\n"
"  --time-integration M  sampled (default) or exact (src/EXACT.md)\n"
"  --time-factor F    thesis sampler: tspp*F time strata (default: scene, else 4)\n"
"  --shutter O,C      shutter interval (frame 0's with <frames>)\n"
"  --frame N          render frame N of a scene with <frames rate>\n"
"  --frames A-B       render frames A to B into -o out.%04d.exr\n"
"  --time T           a sharp image at the instant T (default --tspp 1); a rolling\n"
"                     shutter's lines at T plus their readout offsets\n"
"  --blur-space S     model (default): average colours as given; linear: decode sRGB first;\n"
"                     clamped: clamp each instant to [0, 1] (as SpacetimeGaussians scores)\n"
"Output:\n"
"  -o, --output F     output EXR (default render.exr), written atomically\n"
"  --preview F        also an 8-bit sRGB preview (PNG, by extension)\n"
"  --crop-window X0,X1,Y0,Y1  only this fraction of the image (pbrt's rounding)\n"
"Distributed and long renders:\n"
"  --pass K/N         render batches [K*B/N, (K+1)*B/N) as a state for 'merge'\n"
"  --checkpoint F     write the render state to F periodically and on SIGINT/SIGTERM\n"
"  --checkpoint-every S  seconds between checkpoints (default 60; 0: only when interrupted)\n"
"  --resume F         continue the render state F (same scene and settings)\n"
"Scene overrides:\n"
"  --res WxH          image size\n"
"  --eps X            epsilon-blending distance, world units (default: scene, else 0.01)\n"
"  --sigma X          kernel sigma in splat radii (default: scene, else 0.5)\n"
"  -D name=value      scene parameter: replaces $name in attribute values (repeatable)\n"
"Running:\n"
"  --threads N        render threads (default: all cores)\n"
"  --quiet            no progress bar and no summary line (warnings still)\n"
"  --progress-every S  a progress line every S seconds, also into a log (no terminal)\n"
"  --no-static-reuse  trace every time sample on its own (same image; for benchmarks)\n"
"  --version, -h, --help\n"
"\n"
"Exit status: 0 success, 1 bad input or render error, 2 usage error, 130\n"
"interrupted (no output is written; a checkpoint is, if asked).\n", f);
}

int main(int argc, char **argv)
{
    if (argc > 1 && !strcmp(argv[1], "export"))
        return cmd_export(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "gen"))
        return cmd_gen(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "merge"))
        return cmd_merge(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "splat"))
        return cmd_splat(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "dataset"))
        return cmd_dataset(argc - 1, argv + 1);
    if (argc > 1 && !strcmp(argv[1], "surfels"))
        return cmd_surfels(argc - 1, argv + 1);
    return cmd_render(argc, argv);
}
