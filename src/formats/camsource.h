/* Where a <camera> takes a trained model's or a dataset's camera from:
 * a cameras.json (camjson.h), a COLMAP sparse model (colmap.h) or an LLFF
 * poses_bounds.npy (llff.h), told apart by the path: a directory is a
 * COLMAP model, a name ending in .npy LLFF's file, anything else a
 * cameras.json. One of its cameras is selected by image name, by COLMAP's
 * IMAGE_ID or by LLFF's row; each gives a posed pinhole (camjson_camera). */
#ifndef RR_CAMSOURCE_H
#define RR_CAMSOURCE_H

#include "formats/camjson.h"
#include "formats/colmap.h"
#include "formats/llff.h"

typedef enum { CAMSOURCE_JSON, CAMSOURCE_COLMAP, CAMSOURCE_LLFF } camsource_kind;

typedef struct {
    camsource_kind kind;
    camjson_file json;
    colmap_model colmap;
    llff_poses llff;
    char *dir; /* LLFF: the file's directory, where images/ is looked for */
    char *files[2]; /* the files read, for the scene's inputs (COLMAP: two) */
} camsource;

/* One camera of the source: by image name (image non-NULL), else by
 * number (COLMAP's IMAGE_ID, LLFF's row). */
typedef struct {
    const char *image;
    long number;
} camsource_key;

camsource_kind camsource_kind_of(const char *path);
/* Reads the source at path, folding its bytes into *content_hash. */
int camsource_load(const char *path, camsource *s, uint64_t *content_hash, rr_error *err);
/* The key's camera; an LLFF name lists images/ beside the file (once). */
int camsource_find(camsource *s, camsource_key key, camjson_camera *out, uint64_t *content_hash, rr_error *err);
void camsource_free(camsource *s);

#endif
