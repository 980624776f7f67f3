/* COLMAP sparse models as camera sources: a model directory's cameras and
 * images, binary (cameras.bin, images.bin) or text (cameras.txt,
 * images.txt), read as COLMAP 4.1.1 reads them (colmap/colmap tag 4.1.1,
 * a0d785f, src/colmap/scene/reconstruction_io_binary.cc:106-121 and
 * 172-247, reconstruction_io_text.cc:116-150 and 213-307; the same records
 * as scripts/python/read_write_model.py at tag 3.11.1, 106-295). An image
 * holds its camera's pose as COLMAP's cam_from_world: a quaternion QW QX
 * QY QZ (Eigen's Hamilton order, w first) and a translation T, so that a
 * world point X sits at R(q) X + T in the camera's axes x right, y down,
 * z forward; the camera centre is -R(q)^T T and R(q)^T's columns are the
 * camera's axes in world (cameras.json's position and rotation). Pixel
 * coordinates put the upper-left image corner at (0, 0) (models.h:82-85),
 * refrender's raster. Only PINHOLE (fx, fy, cx, cy) and SIMPLE_PINHOLE
 * (f, cx, cy) cameras are rendered; every other model is refused by name
 * when an image of it is selected (undistort first: colmap
 * image_undistorter). */
#ifndef RR_COLMAP_H
#define RR_COLMAP_H

#include <stdint.h>

#include "formats/camjson.h"

#define COLMAP_MAX_PARAMS 16 /* RAD_TAN_THIN_PRISM_FISHEYE's, the most of 4.1.1's models */

typedef struct {
    uint32_t id;
    int model;             /* COLMAP's CameraModelId; -1: a name (text) COLMAP does not know */
    char model_name[32];   /* as the file names it (text) or COLMAP names the id (binary) */
    uint64_t width, height;
    double params[COLMAP_MAX_PARAMS];
    int nparams;
    long record;           /* its line (text) or record number, from 0 (binary), for errors */
} colmap_camera;

typedef struct {
    uint32_t id, camera_id;
    double q[4], t[3]; /* cam_from_world: w x y z, then the translation */
    char *name;
    long record;
} colmap_image;

typedef struct {
    colmap_camera *cameras;
    size_t ncameras;
    colmap_image *images;
    size_t nimages;
    char *cameras_file, *images_file; /* paths, for errors */
    int text;                         /* 1: records are lines; 0: binary record numbers */
} colmap_model;

/* cameras.bin / images.bin (text = 0) or cameras.txt / images.txt (text
 * = 1) from memory into m (start from a zeroed model; the other file's
 * records stay). Errors name the file and the line or record: a truncated
 * record, a count larger than the file can hold, bytes after the last
 * record, an unknown camera model id (binary: its parameters' count is
 * unknown), a parameter count not the model's (text), a width or height
 * outside [1, 65536], a number that is not finite, a quaternion of length 0
 * or off 1 by more than 1e-3 (it is normalised: COLMAP writes unit
 * quaternions to 17 digits, and a hand-written file's rounding to fewer
 * is no pose), a repeated id, a name with a space (text: COLMAP's reader
 * would take its first word), a name without its terminating NUL. */
int colmap_parse_cameras(const char *name, const char *data, size_t len, int text, colmap_model *m, rr_error *err);
int colmap_parse_images(const char *name, const char *data, size_t len, int text, colmap_model *m, rr_error *err);

/* The model in directory dir: binary where cameras.bin and images.bin are
 * both there, else text (COLMAP's Reconstruction::Read, reconstruction.cc
 * 974-987, which also wants points3D, not read here: no pose is in it).
 * The bytes read are folded into *content_hash unless NULL; the files
 * read are named in files[0..1] (malloc'd) unless files is NULL. */
int colmap_load(const char *dir, colmap_model *m, uint64_t *content_hash, char *files[2], rr_error *err);

/* The image named name (image_id < 0) or of IMAGE_ID image_id as a
 * posed pinhole (camjson_camera: centre, camera-to-world rotation, size,
 * focal lengths, principal point). Refused: no such image (the message
 * lists some), a name two images share, its camera missing or of another
 * model than PINHOLE and SIMPLE_PINHOLE (named), intrinsics outside
 * camera_focal_usable / camera_principal_usable, more pixels than
 * RR_MAX_PIXELS, a centre too far out for its view direction. */
int colmap_find(const colmap_model *m, const char *name, long image_id, camjson_camera *out, rr_error *err);
void colmap_free(colmap_model *m);

#endif
