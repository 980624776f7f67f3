/* Reader for Maya's .anim text format (animImportExport; thesis Figure 4.11
 * names such files in <animation>). Reads the curves of translateX/Y/Z,
 * rotateX/Y/Z and scaleX/Y/Z into keyframes (animation.h), converting
 * units: key times from the file's timeUnit frames to seconds (film 24,
 * ntsc 30, pal 25, game 15, show 48, palf 50, ntscf 60 fps; sec, millisec,
 * min, hour), translate values from linearUnit to meters, rotate values and
 * tangent angles from angularUnit to radians. Unknown attributes are
 * skipped with a warning on stderr; tangent weights are read and ignored
 * (curves are evaluated unweighted), with a warning for weighted curves. */
#ifndef RR_ANIMFILE_H
#define RR_ANIMFILE_H

#include "animation.h"

/* Reads path into *out (allocated; free with animation_free's keyframes
 * handling). Errors name the file and line. */
int animfile_load(const char *path, keyframes **out, rr_error *err);

/* The same from text in memory; name is used in messages. */
int animfile_parse(const char *text, const char *name, keyframes **out, rr_error *err);

#endif
