/* 'refrender gen': writes procedural surfel models as PLY files. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd/cli.h"
#include "cmd/commands.h"
#include "surfels/shapes.h"
#include "cmd/surfel_output.h"

static void gen_usage(FILE *f)
{
    fputs(
"usage: refrender gen sphere|torus|plane [options] -o FILE.ply\n"
"\n"
"Samples circular surfels on an analytic shape centered at the origin and\n"
"writes them as binary PLY (x y z nx ny nz radius red green blue).\n"
"  --count N         approximate number of splats (default 20000)\n"
"  --radius R        sphere radius, torus major radius, plane half side (default 1)\n"
"  --minor-radius r  torus tube radius (default 0.3)\n"
"  --color \"r g b\"   color in [0,1] (default 0.8 0.8 0.8)\n"
"  --color2 \"r g b\"  second checker color (default 0.2 0.2 0.2)\n"
"  --checker N       checker cells: per side (plane) or per 180 degrees\n"
"                    (sphere, torus); 0 = plain color (default 0)\n"
"  --overlap F       splat radius factor over the hole-free size (default 1.5)\n"
"  --quiet           no summary line (what was written, on stderr)\n"
"", f);
    fputs(surfel_output_help, f);
}

static int gen_option(int c, const char *arg, shape_params *p, surfel_output *o, rr_error *err)
{
    int count, rc = surfel_output_option(c, arg, o, err);
    if (rc <= 0)
        return rc;
    switch (c) {
    case 'n':
        if (cli_int("--count", arg, 1, 100000000, &count, err))
            return -1;
        p->count = (size_t)count;
        return 0;
    case 'r': return cli_double("--radius", arg, 1e-30, &p->radius, err);
    case 'm': return cli_double("--minor-radius", arg, 1e-30, &p->minor_radius, err);
    case 'c': return cli_vec3("--color", arg, &p->color, err);
    case 'd': return cli_vec3("--color2", arg, &p->color2, err);
    case 'k': return cli_int("--checker", arg, 0, 100000, &p->checker, err);
    case 'v': return cli_double("--overlap", arg, 1e-30, &p->overlap, err);
    }
    return rr_fail(err, "unknown option");
}

int cmd_gen(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"count", required_argument, 0, 'n'}, {"radius", required_argument, 0, 'r'},
        {"minor-radius", required_argument, 0, 'm'}, {"color", required_argument, 0, 'c'},
        {"color2", required_argument, 0, 'd'}, {"checker", required_argument, 0, 'k'},
        {"overlap", required_argument, 0, 'v'}, {"output", required_argument, 0, 'o'},
        {"gaussians", required_argument, 0, 'g'}, {"sh-degree", required_argument, 0, 's'},
        {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    shape_params p;
    shape_params_default(&p);
    surfel_output o = {NULL, GAUSSIAN_AUTO, 0, 0};
    rr_error err;
    int c, quiet = 0;
    while ((c = getopt_long(argc, argv, "ho:", longopts, NULL)) != -1) {
        if (c == 'h') { gen_usage(stdout); return 0; }
        if (c == 'q') { quiet = 1; continue; }
        if (c == '?') {
            cli_suggest_option("refrender gen", argv[optind - 1], longopts);
            fputs("Try 'refrender gen --help'.\n", stderr);
            return 2;
        }
        if (gen_option(c, optarg, &p, &o, &err)) {
            fprintf(stderr, "refrender gen: %s\n", err.msg);
            return 2;
        }
    }
    if (optind != argc - 1 || !o.out) {
        fputs("refrender gen: need exactly one SHAPE and -o FILE.ply; try 'refrender gen --help'\n", stderr);
        return 2;
    }
    if (surfel_output_check(&o, &err)) {
        fprintf(stderr, "refrender gen: %s\n", err.msg);
        return 2;
    }
    snprintf(p.kind, sizeof p.kind, "%s", argv[optind]);
    surfel *s;
    size_t n;
    if (shape_generate(&p, &s, &n, &err)) {
        fprintf(stderr, "refrender gen: %s\n", err.msg);
        return 1;
    }
    int rc = surfel_output_write(&o, s, n, &err);
    free(s);
    if (rc)
        fprintf(stderr, "refrender gen: %s\n", err.msg);
    else if (!quiet) /* as 'refrender surfels' says what it wrote */
        fprintf(stderr, "refrender gen: %s: %zu %s -> %s\n", p.kind, n,
                o.gaussians == GAUSSIAN_AUTO ? "splats" : "Gaussians", o.out);
    return rc ? 1 : 0;
}
