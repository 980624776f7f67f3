/* Pinhole camera. Raster (0,0) is the top-left image corner; pixel (i,j)
 * covers [i,i+1] x [j,j+1]; rows go downward. fov is the vertical field of
 * view in degrees; the camera looks along lookat - position with up
 * projected to image up. */
#ifndef RR_CAMERA_H
#define RR_CAMERA_H

#include "core/common.h"

typedef struct {
    vec3 position, lookat, up;
    double fov_degrees;
    int width, height;
    /* > 0: the horizontal field of view in degrees, so pixels need not be
     * square (a trained model's cameras.json, whose fx and fy differ); 0:
     * square pixels. Angles, so that --res keeps the view. */
    double fov_x_degrees;
    /* The principal point's offset from the image centre, as fractions of
     * the width and height (0 0: centred; a nerfstudio transforms.json's
     * cx / w - 1/2, cy / h - 1/2). Fractions, so that --res keeps it. */
    double principal_dx, principal_dy;
    /* derived by camera_prepare */
    vec3 forward, right, image_up;
    double tan_half_fov;   /* vertical */
    double tan_half_fov_x; /* horizontal */
} camera;

/* The camera at one instant as the Gaussian-splatting rasterizers see it
 * (OpenCV/COLMAP axes: camera x right, y down, z forward): a point at
 * camera coordinates (x, y, z) lies at raster (fx x / z + cx, fy y / z +
 * cy), raster as above; (cx, cy) the principal point. */
typedef struct {
    vec3 position;
    vec3 axis[3]; /* world directions of the camera's x, y and z */
    double fx, fy, cx, cy;
    int width, height; /* the image's, pixels (the rasterizers' tiles) */
} camera_view;

/* A field of view in degrees from a focal length in pixels over size
 * pixels, and a principal point's offset (camera.principal_dx or _dy) from
 * its position in pixels: each the value whose camera_view_rest gives back
 * reads back as itself (rr_round_trip_representative), so that a camera
 * read from a file, written and read again is the same bit for bit. */
double camera_fov_of_focal(double size, double focal);
double camera_principal_offset(double size, double centre);

/* The one rule for a pinhole's intrinsics read from a file (cameras.json,
 * transforms.json). A focal length (pixels) over size pixels is usable when
 * its field of view 2 atan(size / (2 focal)) lies inside (0, 180) degrees and
 * gives back its tangent within 1e-6 (focal = 1e-14 is a view of 180
 * degrees, all background), and the EXR's float32 worldToNDC holds its scale
 * focal / size (1e300 was written as infinity). A principal point `centre`
 * pixels from the image's first edge is usable with it when the centred view
 * reaching the farther image edge, 2 max(|centre|, |size - centre|) pixels
 * wide, is (both image edges inside 90 degrees of the optical axis, their
 * tangents kept), and worldToNDC holds centre / size. */
int camera_focal_usable(double focal, double size);
int camera_principal_usable(double focal, double centre, double size);

/* Whether every entry of m fits the EXR header's float32 with room to spare
 * (the rule camera_prepare applies to the rest pose's worldToCamera and
 * worldToNDC); 0 with *beyond the first entry that does not. */
int camera_matrix_fits_header(double m[4][4], double *beyond);

/* The prepared camera at rest. */
void camera_view_rest(const camera *c, camera_view *v);

/* Computes the orthonormal frame; -1 if position, lookat or up is not
 * finite, lookat - position overflows or is 0, up is parallel to the view
 * direction, or fov is outside (0, 180). Any finite frame whose difference
 * does not overflow is accepted here (how far rays reach is accel's limit). */
int camera_prepare(camera *c, rr_error *err);

/* The camera's matrices (4x4, row-major, for column vectors p' = M p).
 * Camera space: x right, y up, z forward along the view direction
 * (left-handed, as pbrt's). camera_world_to_camera: world to camera space
 * at rest. camera_projection: camera space to [X, Y, Z, W] with
 * (X / W, Y / W) = (raster x / width * sx, raster y / height * sy), (0, 0)
 * the top-left image corner, and Z / W = 1 / depth: sx = sy = 1 gives
 * normalised device coordinates, sx = width and sy = height raster ones. */
void camera_world_to_camera(const camera *c, double m[4][4]);
void camera_projection(const camera *c, double sx, double sy, double m[4][4]);

/* Unit direction of the ray through raster position (x, y). */
vec3 camera_ray_direction(const camera *c, double x, double y);

#endif
