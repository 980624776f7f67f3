/* Scene files (XML, libxml2), close to the thesis' Figure 4.11 and
 * documented in scenes/README.md. Every error names the file and line. */
#ifndef RR_SCENE_XML_H
#define RR_SCENE_XML_H

#include <signal.h>

#include "scene/scene.h"

/* Largest scene file (bytes); inline splats make big scenes possible. */
#define SCENE_MAX_BYTES ((size_t)256 << 20)

/* What a load is handed besides the file (scene_load_file_params; NULL:
 * none of either). */
typedef struct {
    const scene_params *params; /* -D name=value: $name in attribute values (NULL: none) */
    /* the command's interrupt flag (NULL: never): a model's read stops
     * soon after it is set (ply_read, gaussian_read), so that a signal
     * need not wait for gigabytes to be parsed */
    volatile sig_atomic_t *cancel;
} scene_load_options;

/* Loads a scene file and everything it names. s->scene_hash is the FNV-1a
 * hash of the scene file's bytes, s->inputs_hash that of the scene file, then
 * every model and .anim file in the order they are read. */
int scene_load_file(const char *path, scene *s, rr_error *err);
/* The same with options (may be NULL). */
int scene_load_file_params(const char *path, const scene_load_options *opt, scene *s, rr_error *err);

/* Adds "name=value" (a -D argument) to p; a later value for a name wins. */
int scene_params_add(scene_params *p, const char *assignment, rr_error *err);

/* Parses XML text; name is used in messages and relative paths resolve
 * against base_dir. */
int scene_load_memory(const char *xml, size_t len, const char *name, const char *base_dir,
                      scene *s, rr_error *err);
int scene_load_memory_params(const char *xml, size_t len, const char *name, const char *base_dir,
                             const scene_load_options *opt, scene *s, rr_error *err);

#endif
