#include "core/atomicfile.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Splits path into its directory ("." if none) and base name. */
static void split_path(const char *path, char *dir, size_t dsize, const char **base)
{
    const char *slash = strrchr(path, '/');
    *base = slash ? slash + 1 : path;
    if (!slash)
        snprintf(dir, dsize, ".");
    else if (slash == path)
        snprintf(dir, dsize, "/");
    else
        snprintf(dir, dsize, "%.*s", (int)(slash - path), path);
}

/* This node's name as temporaries carry it: pids are per node, so on a
 * shared file system a temporary is only judged by the node that made it.
 * Characters a name may not hold ('/', and '-' and '@', which delimit it
 * here) become '_'. */
static void host_tag(char *buf, size_t size)
{
    if (gethostname(buf, size) != 0)
        snprintf(buf, size, "unknown");
    buf[size - 1] = 0;
    for (char *c = buf; *c; c++)
        if (*c == '/' || *c == '-' || *c == '@' || (unsigned char)*c <= ' ')
            *c = '_';
}

/* The pid in "<base>.tmp-<pid>@<host>-..." when host is this node's, else 0
 * (not such a temporary, or another node's, whose pid means nothing here). */
static long temp_owner(const char *name, const char *base, const char *host)
{
    size_t n = strlen(base), h = strlen(host);
    if (strncmp(name, base, n) || strncmp(name + n, ".tmp-", 5))
        return 0;
    char *end;
    long pid = strtol(name + n + 5, &end, 10);
    if (pid <= 0 || *end != '@' || strncmp(end + 1, host, h) || end[1 + h] != '-')
        return 0;
    return pid;
}

static void remove_stale(const char *path, const char *host)
{
    char dir[PATH_MAX];
    const char *base;
    split_path(path, dir, sizeof dir, &base);
    DIR *d = opendir(dir);
    if (!d)
        return;
    for (struct dirent *e; (e = readdir(d));) {
        long pid = temp_owner(e->d_name, base, host);
        if (pid && pid != (long)getpid() && kill((pid_t)pid, 0) && errno == ESRCH) {
            char stale[PATH_MAX + 256];
            snprintf(stale, sizeof stale, "%s/%s", dir, e->d_name);
            unlink(stale);
        }
    }
    closedir(d);
}

int atomic_create(const char *path, const char *suffix, char *tmp, size_t size, rr_error *err)
{
    char host[ATOMIC_HOST_MAX];
    host_tag(host, sizeof host);
    size_t extra = strlen(suffix) + strlen(host) + 32;
    if (strlen(path) + extra > size || strlen(path) + extra >= PATH_MAX)
        return rr_fail(err, "%.200s...: output path is too long (%zu characters)", path, strlen(path));
    remove_stale(path, host);
    snprintf(tmp, size, "%s.tmp-%ld@%s-XXXXXX%s", path, (long)getpid(), host, suffix);
    int fd = mkstemps(tmp, (int)strlen(suffix));
    if (fd < 0)
        return rr_fail(err, "%s: cannot create a temporary file beside it: %s", path, strerror(errno));
    mode_t mask = umask(0); /* mkstemps makes the file private */
    umask(mask);
    int rc = fchmod(fd, 0666 & ~mask);
    if (close(fd) || rc) {
        unlink(tmp);
        return rr_fail(err, "%s: cannot prepare a temporary file beside it: %s", path, strerror(errno));
    }
    return 0;
}

int atomic_commit(const char *tmp, const char *path, rr_error *err)
{
    if (rename(tmp, path)) {
        int e = errno;
        unlink(tmp);
        return rr_fail(err, "%s: cannot move the finished file into place: %s", path, strerror(e));
    }
    return 0;
}

void atomic_discard(const char *tmp) { unlink(tmp); }

int atomic_prepare_stdio(const char *path, int (*write)(FILE *f, void *ctx, rr_error *err), void *ctx, char *tmp,
                         size_t size, rr_error *err)
{
    if (atomic_create(path, "", tmp, size, err))
        return -1;
    FILE *f = fopen(tmp, "wb");
    int rc = f ? write(f, ctx, err) : 0, failed = !f || ferror(f);
    if (f && fclose(f))
        failed = 1;
    if (rc || failed) {
        atomic_discard(tmp);
        return rc ? -1 : rr_fail(err, "%s: write failed (disk full?)", path);
    }
    return 0;
}

int atomic_write_stdio(const char *path, int (*write)(FILE *f, void *ctx, rr_error *err), void *ctx,
                       rr_error *err)
{
    char tmp[PATH_MAX + 64];
    return atomic_prepare_stdio(path, write, ctx, tmp, sizeof tmp, err) ? -1 : atomic_commit(tmp, path, err);
}

enum { KEEP_NAME = PATH_MAX + 64 };

/* Copies the file at path into the existing file keep: for file systems
 * without hard links. */
static int copy_file(const char *path, const char *keep)
{
    FILE *in = fopen(path, "rb"), *out = in ? fopen(keep, "wb") : NULL;
    char buf[65536];
    size_t n;
    int failed = !out;
    while (out && !failed && (n = fread(buf, 1, sizeof buf, in)) > 0)
        failed = fwrite(buf, 1, n, out) != n;
    failed |= in && ferror(in);
    if (out && fclose(out))
        failed = 1;
    if (in)
        fclose(in);
    return failed ? -1 : 0;
}

/* A second name for the file now at path (a hard link, else a copy: path
 * itself stays in place), so that it can be put back; "" in keep when
 * there is no file at path. The name is a temporary's: should the process
 * die before removing it, a later write of path removes it. */
static int keep_previous(const char *path, char *keep, size_t size, rr_error *err)
{
    struct stat st;
    keep[0] = 0;
    if (lstat(path, &st))
        return errno == ENOENT ? 0 : rr_fail(err, "%s: %s", path, strerror(errno));
    if (atomic_create(path, ".previous", keep, size, err))
        return -1;
    unlink(keep); /* link() makes the name itself */
    if (link(path, keep) && copy_file(path, keep)) {
        atomic_discard(keep);
        keep[0] = 0;
        return rr_fail(err, "%s: cannot keep the previous file while the new one is put in place", path);
    }
    return 0;
}

/* Puts the previous file (keep, or none if "") back at path. Clears keep
 * when no second name is left to remove. */
static void restore_previous(const char *path, char *keep)
{
    if (!keep[0]) {
        unlink(path);
        return;
    }
    if (!rename(keep, path)) {
        keep[0] = 0;
        return;
    }
    unlink(path); /* without rename: the name is away for a moment, the content is not */
    if (link(keep, path))
        keep[0] = 0; /* keep is now the previous content's only name: not removed */
}

/* Phase two of atomic_commit_all: renames each temporary over its path;
 * when one fails, puts back what the earlier ones replaced and discards
 * the later temporaries. */
static int commit_in_order(const char *const *tmps, const char *const *paths, char (*keep)[KEEP_NAME], int n,
                           rr_error *err)
{
    for (int i = 0; i < n; i++) {
        if (!atomic_commit(tmps[i], paths[i], err)) /* on failure tmps[i] is gone, paths[i] untouched */
            continue;
        for (int k = 0; k < i; k++)
            restore_previous(paths[k], keep[k]);
        for (int k = i + 1; k < n; k++)
            atomic_discard(tmps[k]);
        return -1;
    }
    return 0;
}

int atomic_commit_all(const char *const *tmps, const char *const *paths, int n, rr_error *err)
{
    char(*keep)[KEEP_NAME] = calloc((size_t)n + 1, sizeof *keep);
    int rc = keep ? 0 : rr_fail(err, "out of memory");
    for (int i = 0; !rc && i < n - 1; i++) /* the last is never put back: its rename is the last step */
        rc = keep_previous(paths[i], keep[i], sizeof keep[i], err);
    if (!rc)
        rc = commit_in_order(tmps, paths, keep, n, err);
    else
        for (int i = 0; i < n; i++)
            atomic_discard(tmps[i]);
    for (int i = 0; keep && i < n; i++)
        if (keep[i][0])
            unlink(keep[i]);
    free(keep);
    return rc;
}

int atomic_finish(atomic_set *set, const char *tmp, const char *path, rr_error *err)
{
    if (!set)
        return atomic_commit(tmp, path, err);
    RR_CHECK(set->n < ATOMIC_SET_MAX);
    snprintf(set->tmp[set->n], sizeof set->tmp[set->n], "%s", tmp);
    set->path[set->n++] = path;
    return 0;
}

int atomic_set_commit(atomic_set *set, rr_error *err)
{
    const char *tmps[ATOMIC_SET_MAX];
    for (int i = 0; i < set->n; i++)
        tmps[i] = set->tmp[i];
    int rc = set->n ? atomic_commit_all(tmps, set->path, set->n, err) : 0;
    set->n = 0;
    return rc;
}

void atomic_set_discard(atomic_set *set)
{
    for (int i = 0; i < set->n; i++)
        atomic_discard(set->tmp[i]);
    set->n = 0;
}
