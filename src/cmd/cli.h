/* Command-line parsing helpers shared by the refrender subcommands. */
#ifndef RR_CLI_H
#define RR_CLI_H

#include <getopt.h>
#include <stdint.h>

#include "core/common.h"

/* Each returns 0, or -1 with "OPTION: expected ..., got 'TEXT'" in err. */
int cli_int(const char *opt, const char *text, long lo, long hi, int *out, rr_error *err);
int cli_u64(const char *opt, const char *text, uint64_t *out, rr_error *err);
int cli_double(const char *opt, const char *text, double lo, double *out, rr_error *err);
int cli_resolution(const char *opt, const char *text, int *w, int *h, rr_error *err);
int cli_vec3(const char *opt, const char *text, vec3 *out, rr_error *err);

/* Fails early, before a long render, if the output path (given with
 * option, which the message names) is empty or too long, names a directory
 * or another file that is not a regular one, or no file can be created in
 * its directory. */
int cli_check_writable(const char *option, const char *path, rr_error *err);

/* -1 ("OPT PATH: refrender writes OpenEXR only, not .EXT ...") if the
 * base name has an extension other than .exr: the file would be an EXR
 * whatever it is called, and a viewer trusting the name fails on it.
 * has_preview: the command has --preview, which the message suggests. */
int cli_check_exr_name(const char *opt, const char *path, int has_preview, rr_error *err);

/* Whether two paths name the same file: the same inode when both exist,
 * else the same absolute name (their directories resolved). */
int cli_same_file(const char *a, const char *b);

/* --shutter OPEN,CLOSE (the render's and export's): finite, OPEN < CLOSE. */
int cli_shutter(const char *arg, double *open, double *close, rr_error *err);

/* -1 (naming both) if the output is one of the n inputs (cli_same_file):
 * the output is written before the inputs are all read, or over them. */
int cli_refuse_overwriting_inputs(const char *output, char *const *inputs, int n, rr_error *err);

/* After getopt_long refused arg (argv[optind - 1]), prints "PROG: did you
 * mean '--NAME'?" to stderr when arg is a long option near one of longopts
 * (rr_nearest_name): pbrt's --cropwindow, a misspelt --sampler. Silent for
 * a known option missing its value and for an ambiguous abbreviation
 * (getopt_long has said what was wrong then). */
void cli_suggest_option(const char *prog, const char *arg, const struct option *longopts);

/* Output names for frame sequences: a pattern holds exactly one field "%d",
 * "%4d" or "%04d". cli_frame_path formats it (a name without a field is
 * copied unchanged). */
int cli_frame_pattern_ok(const char *pattern);
void cli_frame_path(const char *pattern, int frame, char *out, size_t size);

/* rel (e.g. "scenes/default.xml") beside the running executable's tree
 * (build/../rel) when readable there, else in the source tree the binary
 * was built from (RR_SOURCE_DIR), there or not: the caller's open names
 * the path it tried. The bundled scene and scripts/dataset.py are found so. */
const char *cli_tree_file(const char *rel, char *buf, size_t size);


#endif
