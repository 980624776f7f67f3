/* What 'refrender gen' and 'refrender surfels' write: surfels as a surfel
 * PLY, or (--gaussians) as a trained Gaussian-splat model's PLY, so the
 * suite has 2DGS/3DGS scenes from procedural shapes and scanned models. */
#ifndef RR_SURFEL_OUTPUT_H
#define RR_SURFEL_OUTPUT_H

#include "gaussians/gaussian.h"
#include "formats/ply.h"

typedef struct {
    const char *out;
    gaussian_kind gaussians; /* GAUSSIAN_AUTO: surfels */
    int sh_degree;
    int sh_degree_given; /* --sh-degree was given: it needs --gaussians */
} surfel_output;

/* The options' lines for --help. */
extern const char surfel_output_help[];

/* --gaussians K (getopt code 'g') and --sh-degree D ('s'), and -o ('o'):
 * 0 parsed, -1 a bad value (err), 1 not one of these. */
int surfel_output_option(int c, const char *arg, surfel_output *o, rr_error *err);

/* After the options: --sh-degree without --gaussians would be
 * ignored (surfels have no SH), so it is a usage error. */
int surfel_output_check(const surfel_output *o, rr_error *err);

int surfel_output_write(const surfel_output *o, const surfel *s, size_t n, rr_error *err);

#endif
