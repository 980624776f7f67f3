/* Pinhole camera. Raster (0,0) is the top-left image corner; pixel (i,j)
 * covers [i,i+1] x [j,j+1]; rows go downward. fov is the vertical field of
 * view in degrees; the camera looks along lookat - position with up
 * projected to image up. */
#ifndef RR_CAMERA_H
#define RR_CAMERA_H

#include "common.h"

typedef struct {
    vec3 position, lookat, up;
    double fov_degrees;
    int width, height;
    /* derived by camera_prepare */
    vec3 forward, right, image_up;
    double tan_half_fov;
} camera;

/* Computes the orthonormal frame; -1 if lookat == position or up is
 * parallel to the view direction or fov is outside (0, 180). */
int camera_prepare(camera *c, rr_error *err);

/* Unit direction of the ray through raster position (x, y). */
vec3 camera_ray_direction(const camera *c, double x, double y);

#endif
