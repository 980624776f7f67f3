#include "atomicfile.h"

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

/* The pid in "<base>.tmp-<pid>-..." or 0 if name is not such a temporary. */
static long temp_owner(const char *name, const char *base)
{
    size_t n = strlen(base);
    if (strncmp(name, base, n) || strncmp(name + n, ".tmp-", 5))
        return 0;
    char *end;
    long pid = strtol(name + n + 5, &end, 10);
    return pid > 0 && *end == '-' ? pid : 0;
}

static void remove_stale(const char *path)
{
    char dir[PATH_MAX];
    const char *base;
    split_path(path, dir, sizeof dir, &base);
    DIR *d = opendir(dir);
    if (!d)
        return;
    for (struct dirent *e; (e = readdir(d));) {
        long pid = temp_owner(e->d_name, base);
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
    if (strlen(path) + strlen(suffix) + 32 > size || strlen(path) >= PATH_MAX - 32)
        return rr_fail(err, "%.200s...: output path is too long (%zu characters)", path, strlen(path));
    remove_stale(path);
    snprintf(tmp, size, "%s.tmp-%ld-XXXXXX%s", path, (long)getpid(), suffix);
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

int atomic_write_stdio(const char *path, int (*write)(FILE *f, void *ctx, rr_error *err), void *ctx,
                       rr_error *err)
{
    char tmp[PATH_MAX + 64];
    if (atomic_create(path, "", tmp, sizeof tmp, err))
        return -1;
    FILE *f = fopen(tmp, "wb");
    int rc = f ? write(f, ctx, err) : 0, failed = !f || ferror(f);
    if (f && fclose(f))
        failed = 1;
    if (rc || failed) {
        atomic_discard(tmp);
        return rc ? -1 : rr_fail(err, "%s: write failed (disk full?)", path);
    }
    return atomic_commit(tmp, path, err);
}
