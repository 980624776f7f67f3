/* Gaussian-splat models' PLY files, as the official code saves them
 * (graphdeco-inria/gaussian-splatting scene/gaussian_model.py save_ply;
 * hbb1/2d-gaussian-splatting the same with two scales).
 *
 * PLY vertex properties, found by name (ply.h): x y z, [nx ny nz: written as
 * zeros, ignored], f_dc_0..2, f_rest_0..(3((d+1)^2 - 1) - 1), opacity,
 * scale_0 scale_1 [scale_2], rot_0..3. The SH degree d (0 to 3) follows from
 * the number of f_rest properties; they are channel-major: all R
 * coefficients of bases 1..K-1, then all G, then all B. */
#ifndef RR_GAUSSIAN_PLY_H
#define RR_GAUSSIAN_PLY_H

#include <stdint.h>

#include "gaussians/gaussian.h"

/* Reads a trained model. kind GAUSSIAN_AUTO detects it (scale_2 present:
 * 3D, else 2D); forcing 2D reads a 3D file's first two scales; forcing 3D
 * on a file without scale_2 is an error. Errors name the file and the
 * property (missing or duplicated properties, an f_rest count that is no
 * SH degree, non-finite values or ones beyond float range, a mean
 * coordinate beyond RR_MAX_REACH, zero quaternions (others are
 * normalised whatever their size), counts the file cannot hold). The bytes
 * are folded into *content_hash unless NULL. A non-zero *cancel (NULL:
 * never) stops the read, as ply_read's. */
int gaussian_read(const char *path, gaussian_kind kind, gaussian_model *m, uint64_t *content_hash,
                  volatile sig_atomic_t *cancel, rr_error *err);
int gaussian_parse(const char *name, const char *data, size_t len, gaussian_kind kind, gaussian_model *m,
                   rr_error *err);

/* Writes m in the official layout (binary little endian; the activations
 * undone: logit of the opacity, log of the scales; normals zero), so the
 * official loaders and gaussian_read read it back. Atomic, as every
 * refrender output. */
int gaussian_write_ply(const char *path, const gaussian_model *m, rr_error *err);

#endif
