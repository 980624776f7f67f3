/* Reader for Maya's .anim text format (animImportExport; thesis Figure 4.11
 * names such files in <animation>). Reads the curves of translateX/Y/Z,
 * rotateX/Y/Z and scaleX/Y/Z into keyframes (animation.h), converting
 * units: key times from the file's timeUnit frames to seconds (film 24,
 * ntsc 30, pal 25, game 15, show 48, palf 50, ntscf 60 fps; sec, millisec,
 * min, hour), translate values from linearUnit to meters, rotate values and
 * tangent angles from angularUnit to radians. Unknown attributes are
 * skipped with a warning (returned in *warnings, which may be NULL).
 * Weighted curves are evaluated as Bezier segments with their tangent
 * weights (curve.h). Words longer than 255 characters are refused; nodes
 * are not limited in number. */
#ifndef RR_ANIMFILE_H
#define RR_ANIMFILE_H

#include "motion/animation.h"

#include <stdint.h>

/* Longest word (number, node or attribute name) read; longer ones are
 * refused naming file, line and length. Scenes name nodes up to this long
 * (<animation node="...">). */
#define ANIMFILE_MAX_WORD 255

/* Largest .anim file read (bytes); real exports of whole rigs are a few MB. */
#define ANIMFILE_MAX_BYTES ((size_t)256 << 20)

/* Reads the curves of node `node` of path into *out (allocated; free with
 * animation_free's keyframes handling). A file animating several nodes
 * (Maya exports a whole hierarchy) needs a node name; NULL takes the only
 * one, and a wrong or missing name is an error listing the nodes present.
 * Parent transforms are not composed. The file's bytes are folded into
 * *content_hash unless it is NULL (inputfile.h). Only regular files are
 * read. Errors name the file and line. */
int animfile_load(const char *path, const char *node, keyframes **out, uint64_t *content_hash, rr_warnings *warnings,
                  rr_error *err);

/* The same from text in memory; name is used in messages. */
int animfile_parse(const char *text, const char *name, const char *node, keyframes **out, rr_warnings *warnings,
                   rr_error *err);

#endif
