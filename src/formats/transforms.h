/* nerfstudio's transforms.json as a camera trajectory: the
 * frames' camera-to-world `transform_matrix` (OpenGL axes: x right, y up,
 * z backward) are the knots, in file order at times 0, 1, 2, ... or at
 * each frame's `time` where every frame has one; the pinhole intrinsics
 * `fl_x`, `fl_y`, `cx`, `cy`, `w`, `h` (top level, or the same in every
 * frame) the camera's, within cameras.json's range (camera_focal_usable,
 * camera_principal_usable). Distortion coefficients other than the number
 * 0 and camera models other than PINHOLE and OPENCV are refused, at the top
 * level or in a frame, naming the entry and the value; so are unknown keys
 * (a misspelt one would otherwise be ignored). */
#ifndef RR_TRANSFORMS_H
#define RR_TRANSFORMS_H

#include <stdint.h>
#include <stdio.h>

#include "motion/trajectory.h" /* the file is read into a trajectory's knots */

typedef struct {
    double fx, fy, cx, cy; /* pixels; (cx, cy) from the top-left image corner */
    int width, height;
    double exposure_time, rolling_shutter_time; /* 3dgs-deblur's keys; NAN when absent */
} transforms_camera;

/* Parses the text (len bytes; errors name the file, the frame's index and
 * the field) into the trajectory's knots (opengl_axes set, interp left)
 * and the camera. */
int transforms_parse(const char *name, const char *text, size_t len, trajectory *tr, transforms_camera *cam,
                     rr_error *err);
/* Reads the file at path, folding its bytes into *content_hash. */
int transforms_load(const char *path, trajectory *tr, transforms_camera *cam, uint64_t *content_hash, rr_error *err);

/* Writes a transforms.json: the camera, and one frame (file_path
 * "frame_%05d", time, transform_matrix) per pose: OpenCV-axes poses
 * (p[i], q[i]) at times t[i], written in its OpenGL axes. */
void transforms_write(FILE *f, const transforms_camera *cam, const double *t, const vec3 *p, const double (*q)[4],
                      int n);

#endif
