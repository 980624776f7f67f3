/* 'refrender surfels': scanned meshes (read with Assimp) and xyz point
 * clouds with normals to surfel PLY files. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd/cli.h"
#include "cmd/commands.h"
#include "formats/meshload.h"
#include "cmd/surfel_output.h"
#include "surfels/surfelize.h"

static void surfels_usage(FILE *f)
{
    fputs(
"usage: refrender surfels INPUT -o OUT.ply [options]\n"
"\n"
"Turns a triangle mesh (OBJ, OFF, PLY, ... read with Assimp) or a point cloud\n"
"with normals (.xyz or .pts text: x y z nx ny nz per line) into circular\n"
"surfels written as binary PLY (x y z nx ny nz radius red green blue).\n"
"Mesh: one splat per vertex, area = a third of its adjacent triangles'.\n"
"Point cloud: area from the distance to the 6th nearest neighbour.\n"
"  --overlap F       radius factor over the equal-area disk (default 1.5)\n"
"  --fit R           move the bounding-box center to the origin and scale so\n"
"                    half the box diagonal is R (default: keep coordinates)\n"
"  --color \"r g b\"   color (default 0.8 0.8 0.8)\n"
"  --color2 \"r g b\"  second color of a 3D checkerboard (default 0.2 0.2 0.2)\n"
"  --checker S       checker cube side in output units; 0 = plain (default 0)\n", f);
    fputs(surfel_output_help, f);
}

typedef struct {
    double overlap, fit, checker;
    vec3 color, color2;
    surfel_output output;
} surfels_options;

/* --fit: center the box at the origin, half diagonal R. */
static void fit(surfel *s, size_t n, double r)
{
    aabb b = aabb_empty();
    for (size_t i = 0; i < n; i++)
        aabb_add_point(&b, s[i].center);
    vec3 c = v3_scale(v3_add(b.lo, b.hi), 0.5);
    double half = 0.5 * v3_len(v3_sub(b.hi, b.lo)), k = half > 0 ? r / half : 1.0;
    for (size_t i = 0; i < n; i++) {
        s[i].center = v3_scale(v3_sub(s[i].center, c), k);
        s[i].radius *= k;
    }
}

static int convert(const char *in, const surfels_options *o, rr_error *err)
{
    double *pos = NULL, *nrm = NULL;
    unsigned *tri = NULL;
    size_t nv = 0, nt = 0, n = 0;
    surfel *s = NULL;
    int points = meshload_is_point_cloud(in);
    int rc = points ? meshload_points(in, &pos, &nrm, &nv, err) : meshload_mesh(in, &pos, &nrm, &nv, &tri, &nt, err);
    rr_error sub;
    if (!rc && (points ? surfels_from_points(pos, nrm, nv, o->overlap, &s, &n, &sub)
                       : surfels_from_mesh(pos, nrm, nv, tri, nt, o->overlap, &s, &n, &sub)))
        rc = rr_fail(err, "%s: %s", in, sub.msg); /* the input's fault: name it */
    free(pos), free(nrm), free(tri);
    if (rc)
        return rc;
    if (o->fit > 0)
        fit(s, n, o->fit);
    surfels_color(s, n, o->color, o->color2, o->checker);
    rc = surfel_output_write(&o->output, s, n, err);
    if (!rc)
        fprintf(stderr, "refrender surfels: %s: %zu %s -> %s\n", in, n,
                o->output.gaussians == GAUSSIAN_AUTO ? "splats" : "Gaussians", o->output.out);
    free(s);
    return rc;
}

static int surfels_option(int c, const char *arg, surfels_options *o, rr_error *err)
{
    int rc = surfel_output_option(c, arg, &o->output, err);
    if (rc <= 0)
        return rc;
    switch (c) {
    case 'v': return cli_double("--overlap", arg, 1e-6, &o->overlap, err);
    case 'f': return cli_double("--fit", arg, 1e-30, &o->fit, err);
    case 'k': return cli_double("--checker", arg, 0.0, &o->checker, err);
    case 'c': return cli_vec3("--color", arg, &o->color, err);
    case 'd': return cli_vec3("--color2", arg, &o->color2, err);
    }
    return rr_fail(err, "unknown option");
}

int cmd_surfels(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"overlap", required_argument, 0, 'v'}, {"fit", required_argument, 0, 'f'},
        {"checker", required_argument, 0, 'k'}, {"color", required_argument, 0, 'c'},
        {"color2", required_argument, 0, 'd'}, {"output", required_argument, 0, 'o'},
        {"gaussians", required_argument, 0, 'g'}, {"sh-degree", required_argument, 0, 's'},
        {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    surfels_options o = {1.5, 0, 0, rr_default_color(), rr_default_color2(), {NULL, GAUSSIAN_AUTO, 0, 0}};
    rr_error err;
    int c;
    while ((c = getopt_long(argc, argv, "ho:", longopts, NULL)) != -1) {
        if (c == 'h') { surfels_usage(stdout); return 0; }
        if (c == '?') {
            cli_suggest_option("refrender surfels", argv[optind - 1], longopts);
            fputs("Try 'refrender surfels --help'.\n", stderr);
            return 2;
        }
        if (surfels_option(c, optarg, &o, &err)) {
            fprintf(stderr, "refrender surfels: %s\n", err.msg);
            return 2;
        }
    }
    if (optind != argc - 1 || !o.output.out) {
        fputs("refrender surfels: need exactly one INPUT and -o OUT.ply; try 'refrender surfels --help'\n", stderr);
        return 2;
    }
    if (surfel_output_check(&o.output, &err)) {
        fprintf(stderr, "refrender surfels: %s\n", err.msg);
        return 2;
    }
    if (cli_check_writable("-o", o.output.out, &err) || cli_refuse_overwriting_inputs(o.output.out, argv + optind, 1, &err) ||
        convert(argv[optind], &o, &err)) {
        fprintf(stderr, "refrender surfels: %s\n", err.msg);
        return 1;
    }
    return 0;
}
