/* Scene files (XML, libxml2), close to the thesis' Figure 4.11 and
 * documented in README.md. Every error names the file and line. */
#ifndef RR_SCENE_XML_H
#define RR_SCENE_XML_H

#include "scene.h"

int scene_load_file(const char *path, scene *s, rr_error *err);

/* Parses XML text; name is used in messages and relative paths resolve
 * against base_dir. */
int scene_load_memory(const char *xml, size_t len, const char *name, const char *base_dir,
                      scene *s, rr_error *err);

#endif
