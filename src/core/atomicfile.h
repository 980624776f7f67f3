/* Outputs written atomically: into a temporary file beside the target that
 * is renamed over it only when complete, so a failed, interrupted or killed
 * write never leaves a partial file and never replaces a good one.
 *
 * Temporary names are "<target>.tmp-<pid>@<host>-XXXXXX[suffix]": a later
 * write of the same target on the same node removes those whose process no
 * longer exists (left by a SIGKILL), and never another live process's nor
 * another node's (pids are per node: on a shared file system a live writer
 * elsewhere may have any pid). */
#ifndef RR_ATOMICFILE_H
#define RR_ATOMICFILE_H

#include <limits.h>
#include <stddef.h>
#include <stdio.h>

#include "core/common.h"

/* Longest host name kept in a temporary's name (HOST_NAME_MAX is 64). */
#define ATOMIC_HOST_MAX 65

#ifdef __cplusplus
extern "C" {
#endif

/* Creates an empty temporary file for `path` (the umask's permissions, as a
 * plain create would give) and writes its name into tmp. suffix (may be "")
 * ends the name, for writers that choose a format by extension. Stale
 * temporaries of the same target are removed first. */
int atomic_create(const char *path, const char *suffix, char *tmp, size_t size, rr_error *err);

/* Renames tmp over path; on failure removes tmp. */
int atomic_commit(const char *tmp, const char *path, rr_error *err);

/* Removes tmp after a failed write. */
void atomic_discard(const char *tmp);

/* Writes path atomically through stdio: write(f, ctx, err) returns -1
 * with err set when its content cannot be made; a stream error (disk
 * full...) is reported as "<path>: write failed". Either way nothing is
 * left at path but what was there. */
int atomic_write_stdio(const char *path, int (*write)(FILE *f, void *ctx, rr_error *err), void *ctx,
                       rr_error *err);

/* atomic_write_stdio without the commit: the complete content is left in
 * the temporary tmp (size bytes, PATH_MAX + 64 will do) for
 * atomic_commit_all; on failure nothing is left. */
int atomic_prepare_stdio(const char *path, int (*write)(FILE *f, void *ctx, rr_error *err), void *ctx, char *tmp,
                         size_t size, rr_error *err);

/* Several outputs of one command, all or nothing: each tmps[i] holds the
 * complete paths[i] (atomic_create, atomic_prepare_stdio). Renames them
 * into place in order; if one rename fails, the files the earlier ones
 * replaced are put back (kept under a second name until the end) and the
 * rest discarded, so that every path holds what it held before. The
 * paths must name distinct files. */
int atomic_commit_all(const char *const *tmps, const char *const *paths, int n, rr_error *err);

/* The outputs of one command put in place together: a writer handed a set
 * leaves its complete temporary there (atomic_finish) instead of renaming
 * it, and atomic_set_commit puts them all in place or none
 * (atomic_commit_all). The paths must outlive the set. */
#define ATOMIC_SET_MAX 4
typedef struct {
    int n;
    char tmp[ATOMIC_SET_MAX][PATH_MAX + 64];
    const char *path[ATOMIC_SET_MAX];
} atomic_set;

/* The last step of a writer: renames tmp over path now (set NULL), or
 * leaves it in set for atomic_set_commit. */
int atomic_finish(atomic_set *set, const char *tmp, const char *path, rr_error *err);
int atomic_set_commit(atomic_set *set, rr_error *err);
/* Removes the set's temporaries (a later output failed). */
void atomic_set_discard(atomic_set *set);

#ifdef __cplusplus
}
#endif

#endif
