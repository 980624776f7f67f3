/* The TUM trajectory format (TUM RGB-D's `t tx ty tz qx qy qz qw` text, as
 * BAD-Gaussians and DeblurGS exchange camera paths): reading one into a
 * trajectory's knots, and writing a pose as one line. The interpolation is
 * trajectory.h's. */
#ifndef RR_TUM_H
#define RR_TUM_H

#include <stdint.h>
#include <stdio.h>

#include "motion/trajectory.h"

/* Parses a TUM file's text (len bytes): one knot a line,
 * `t tx ty tz qx qy qz qw`, blank lines and lines starting with '#'
 * skipped, and a UTF-8 byte order mark before the first line (editors
 * write one; it is no part of the text). Refuses, naming name, the line
 * and the field (bytes outside printable ASCII as \xHH): a missing or
 * extra field, one that is not a finite number, a position coordinate
 * beyond RR_MAX_REACH, a zero quaternion or one
 * whose length is not 1 within 1e-3 (it is normalised), times that do not
 * increase. out->interp and out->opengl_axes are left as they are. */
int tum_parse(const char *text, size_t len, const char *name, trajectory *out, rr_error *err);

/* Reads the TUM file at path (at most TUM_MAX_BYTES, a regular
 * file: inputfile.h) and folds its bytes into *content_hash. */
#define TUM_MAX_BYTES ((size_t)1 << 30)
int tum_load(const char *path, trajectory *out, uint64_t *content_hash, rr_error *err);

/* One TUM line for the OpenCV-axes pose (p, q) at time t, written in the
 * given axes with every digit a double needs (read back bit for bit). */
void tum_write_line(FILE *f, double t, vec3 p, const double q[4], int opengl_axes);

#endif
