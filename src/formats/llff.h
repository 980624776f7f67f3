/* LLFF's poses_bounds.npy as a camera source, the file Deblur-NeRF,
 * BAD-NeRF and the LLFF-layout deblurring datasets ship. LLFF's
 * imgs2poses writes it (Fyusion/LLFF c6e27b1, llff/poses/pose_utils.py
 * 11-53, 56-88): one float64 row per image, the images in sorted name
 * order (argsort of COLMAP's names, 33 and 78), each row a 3x5 matrix
 * written row-major (ravel, 85) and then the near and far depth bounds
 * (the 0.1 and 99.9 percentiles of the COLMAP points' depths, 82). The
 * matrix's first three columns are the camera-to-world rotation with its
 * axes re-ordered to [down, right, back] from COLMAP's [right, down,
 * forward] (51), the fourth the camera centre, the fifth [height, width,
 * focal] in pixels of the full-size images (COLMAP's camera, 21-23: its
 * first parameter; the principal point is the image centre, as
 * Deblur-NeRF's K puts it: run_nerf.py 268-271).
 * Loaders turn the axes to [right, up, back] (limacv/Deblur-NeRF aa9d6ce,
 * load_llff.py 246: columns 1, -0, 2); refrender turns them to OpenCV's
 * [right, down, forward]: columns 1, 0, -2. Loaders then rescale and
 * recentre the poses (load_llff.py 252-258); the file's poses, read here,
 * are COLMAP's world, the frame 3DGS trains in. Image k is the k-th name
 * in sorted order of images/ beside the file, counting names that end in
 * "JPG", "jpg" or "png" (load_llff.py 83-84). The bounds are read and
 * checked, not used (refrender clips nothing). */
#ifndef RR_LLFF_H
#define RR_LLFF_H

#include <stdint.h>

#include "formats/camjson.h"

typedef struct {
    double *rows; /* n x 17, C order, as doubles */
    size_t n;
    char *name;   /* the file, for errors */
    char **image_names; /* sorted, once listed (llff_list_images) */
    size_t nnames;
} llff_poses;

/* The .npy (NumPy format 1.0-3.0, numpy 1.24.2 numpy/lib/format.py 90-160)
 * of len bytes: a header no longer than numpy reads (10000 bytes, 194),
 * the keys descr, fortran_order and shape and no other, descr '<f8', '>f8',
 * '<f4' or '>f4', either order, shape (N, 17) with N >= 1, exactly N x 17
 * values after it. Refused naming the file and, for a row, its index:
 * another header or dtype or shape, data short or long, a value that is
 * not finite, a rotation that is not one (columns orthonormal within 1e-4,
 * determinant 1), height or width not a whole number in [1, 65536], more
 * than RR_MAX_PIXELS, a focal length with no usable field of view, a centre
 * too far out for its view direction. */
int llff_parse(const char *name, const char *data, size_t len, llff_poses *p, rr_error *err);
int llff_load(const char *path, llff_poses *p, uint64_t *content_hash, rr_error *err);

/* The names in directory dir as the loaders count them (see above), sorted
 * by byte (Python's sorted of the names: code point order, UTF-8's byte
 * order); refused when their count is not the file's rows (the loaders'
 * "Mismatch between imgs and poses") or dir cannot be listed. The names are
 * folded into *content_hash unless NULL. */
int llff_list_images(llff_poses *p, const char *dir, uint64_t *content_hash, rr_error *err);

/* Row index (name NULL) or the row of the listed image named name. */
int llff_find(const llff_poses *p, const char *name, long index, camjson_camera *out, rr_error *err);
void llff_free(llff_poses *p);

#endif
