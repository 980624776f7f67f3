#include "cmd/surfel_output.h"

#include <string.h>

#include "cmd/cli.h"
#include "formats/gaussian_ply.h"

const char surfel_output_help[] =
"  --gaussians K     write Gaussian splats instead, in the official layout of\n"
"                    K = 2dgs or 3dgs (scale = half the surfel radius, opacity\n"
"                    0.95, the color as SH DC): a trained model's PLY for tests\n"
"  --sh-degree D     with --gaussians: SH degree 0 to 3, with small fixed\n"
"                    view-dependent coefficients (default 0)\n"
"  -o, --output F    output PLY file (required)\n";

int surfel_output_option(int c, const char *arg, surfel_output *o, rr_error *err)
{
    switch (c) {
    case 'g':
        if (strcmp(arg, "2dgs") && strcmp(arg, "3dgs"))
            return rr_fail(err, "--gaussians: expected 2dgs or 3dgs, got '%s'", arg);
        o->gaussians = arg[0] == '2' ? GAUSSIAN_2D : GAUSSIAN_3D;
        return 0;
    case 's':
        o->sh_degree_given = 1;
        return cli_int("--sh-degree", arg, 0, GAUSSIAN_MAX_SH_DEGREE, &o->sh_degree, err);
    case 'o': o->out = arg; return 0;
    }
    return 1;
}

int surfel_output_check(const surfel_output *o, rr_error *err)
{
    if (o->sh_degree_given && o->gaussians == GAUSSIAN_AUTO)
        return rr_fail(err, "--sh-degree needs --gaussians 2dgs or 3dgs (surfels have no SH coefficients)");
    return 0;
}

int surfel_output_write(const surfel_output *o, const surfel *s, size_t n, rr_error *err)
{
    if (o->gaussians == GAUSSIAN_AUTO)
        return ply_write_surfels(o->out, s, n, err);
    gaussian_model m;
    gaussian_model_init(&m);
    int rc = gaussian_from_surfels(s, n, o->gaussians, o->sh_degree, &m, err) ||
             gaussian_write_ply(o->out, &m, err);
    gaussian_model_free(&m);
    return rc ? -1 : 0;
}
