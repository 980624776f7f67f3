/* LD_PRELOAD shim for the write-fault tests (tests/test_faults.py): the Nth
 * write to a regular file, and with RR_FAULT_STICKY every one after it, fails
 * with ENOSPC as on a full disk; or the Nth rename fails. Writes to pipes and
 * terminals (stderr) are never touched.
 *   RR_FAULT_AT=N       which call fails (1-based; unset: none)
 *   RR_FAULT_OP=write   write, pwrite, fwrite, fflush, fclose (default)
 *   RR_FAULT_OP=rename  rename
 *   RR_FAULT_STICKY=1   every later write fails too (a disk that stays full)
 *   RR_FAULT_LOG=FILE   a line is appended to FILE for each injected fault,
 *                       and "calls W R" (writes, renames seen) at exit
 *   RR_FAULT_OP=memory-in-threads  every realloc outside the main thread,
 *                       and every malloc of ARENA_CHUNK_MIN bytes or more in
 *                       a thread refrender itself started, returns NULL, as
 *                       when memory runs out while the render's workers grow
 *                       their scratch (rr_grow's reallocs, the chunks of
 *                       their arenas: core/arena.c, whose chunks malloc'd
 *                       are 64 KiB and up)
 *   RR_FAULT_OP=pthread_create  the Nth thread refrender itself starts (its
 *                       start routine in the executable, not in a library
 *                       such as Embree's TBB) fails with EAGAIN
 * The "calls" line also counts the threads refrender itself started. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

static long calls[3]; /* writes, renames, threads started */

/* A regular file open for writing (closing a file read is no write). */
static int is_regular(int fd)
{
    struct stat st;
    int flags = fd >= 0 ? fcntl(fd, F_GETFL) : -1;
    return flags >= 0 && (flags & O_ACCMODE) != O_RDONLY && fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
}

static void log_line(const char *what)
{
    const char *path = getenv("RR_FAULT_LOG");
    if (!path)
        return;
    int fd = open(path, O_WRONLY | O_APPEND | O_CREAT, 0644);
    if (fd >= 0) {
        char line[128];
        int n = snprintf(line, sizeof line, "%s %ld %ld %ld\n", what, calls[0], calls[1], calls[2]);
        ssize_t ignored = syscall(1 /* SYS_write */, fd, line, (size_t)n);
        (void)ignored;
        close(fd);
    }
}

/* Whether this call (kind 0 write, 1 rename, 2 thread start) is to fail. */
static int should_fail(int kind, int fd)
{
    const char *at = getenv("RR_FAULT_AT"), *op = getenv("RR_FAULT_OP");
    int want = !op ? 0 : !strcmp(op, "rename") ? 1 : !strcmp(op, "pthread_create") ? 2 : 0;
    if (kind == 0 && !is_regular(fd))
        return 0;
    long n = ++calls[kind], k = at ? atol(at) : 0;
    if (!at || kind != want)
        return 0;
    int fail = n == k || (getenv("RR_FAULT_STICKY") && n > k);
    if (fail)
        log_line(kind == 2 ? "pthread_create" : kind ? "rename" : "write");
    return fail;
}

__attribute__((destructor)) static void log_calls(void) { log_line("calls"); }

#define REAL(name) ((__typeof__(&name))dlsym(RTLD_NEXT, #name))

ssize_t write(int fd, const void *buf, size_t n)
{
    if (should_fail(0, fd))
        return errno = ENOSPC, -1;
    return REAL(write)(fd, buf, n);
}

ssize_t pwrite(int fd, const void *buf, size_t n, off_t off)
{
    if (should_fail(0, fd))
        return errno = ENOSPC, -1;
    return REAL(pwrite)(fd, buf, n, off);
}

ssize_t pwrite64(int fd, const void *buf, size_t n, off_t off)
{
    if (should_fail(0, fd))
        return errno = ENOSPC, -1;
    return REAL(pwrite64)(fd, buf, n, off);
}

size_t fwrite(const void *buf, size_t size, size_t n, FILE *f)
{
    if (should_fail(0, fileno(f)))
        return errno = ENOSPC, 0;
    return REAL(fwrite)(buf, size, n, f);
}

int fflush(FILE *f)
{
    if (f && should_fail(0, fileno(f)))
        return errno = ENOSPC, EOF;
    return REAL(fflush)(f);
}

int fclose(FILE *f)
{
    int fail = should_fail(0, fileno(f));
    int rc = REAL(fclose)(f);
    return fail ? (errno = ENOSPC, EOF) : rc;
}

int rename(const char *from, const char *to)
{
    if (should_fail(1, -1))
        return errno = EIO, -1;
    return REAL(rename)(from, to);
}

/* RR_FAULT_OP=memory-in-threads (read once). */
static int memory_mode(void)
{
    static int mode = -1;
    if (mode < 0) {
        const char *op = getenv("RR_FAULT_OP");
        mode = op && !strcmp(op, "memory-in-threads");
    }
    return mode;
}

/* The render's worker threads are the only ones that grow scratch while
 * rendering; the main thread reads the scene and writes the outputs. */
void *realloc(void *p, size_t n)
{
    static void *(*real)(void *, size_t);
    if (!real)
        real = (void *(*)(void *, size_t))dlsym(RTLD_NEXT, "realloc");
    if (memory_mode() && n > 0 && syscall(SYS_gettid) != getpid())
        return errno = ENOMEM, NULL;
    return real(p, n);
}

/* The smallest arena chunk: rr_arena_init's default first chunk (64 KiB,
 * core/arena.h). The workers' other mallocs (their sample arrays, integrator
 * state) are smaller, and the threads of libraries (Embree's TBB) are not
 * refrender's own: neither fails. */
#define ARENA_CHUNK_MIN 65536
static __thread int own_thread; /* started by refrender (pthread_create below) */

/* Under AddressSanitizer (make SAN=1) malloc stays ASan's: it must see
 * every block it frees, and a preloaded malloc took the renders down at
 * start-up (SIGSEGV). The memory test that needs it is skipped there. */
#ifndef FAULTINJECT_NO_MALLOC
extern void *__libc_malloc(size_t n);

void *malloc(size_t n)
{
    static void *(*real)(size_t);
    static int resolving;
    if (!real) {
        if (resolving) /* (dlsym asking for memory while it finds malloc) */
            return __libc_malloc(n);
        resolving = 1;
        real = (void *(*)(size_t))dlsym(RTLD_NEXT, "malloc");
        resolving = 0;
    }
    if (own_thread && n >= ARENA_CHUNK_MIN && memory_mode())
        return errno = ENOMEM, NULL;
    return real(n);
}
#endif

/* A thread refrender starts runs its start routine through this, marked
 * as its own. */
typedef struct {
    void *(*start)(void *);
    void *arg;
} own_start;

static void *run_own(void *p)
{
    own_start s = *(own_start *)p;
    free(p);
    own_thread = 1;
    return s.start(s.arg);
}

/* Is fn in the executable rather than in a shared library? */
static int in_executable(void *fn)
{
    Dl_info info;
    return dladdr(fn, &info) && info.dli_fname && !strstr(info.dli_fname, ".so");
}

int pthread_create(pthread_t *t, const pthread_attr_t *attr, void *(*start)(void *), void *arg)
{
    static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER; /* (TBB's threads start threads too) */
    int fail = 0;
    if (in_executable((void *)start)) {
        pthread_mutex_lock(&lock);
        fail = should_fail(2, -1);
        pthread_mutex_unlock(&lock);
    }
    if (fail)
        return EAGAIN;
    own_start *own = in_executable((void *)start) ? malloc(sizeof *own) : NULL;
    if (!own)
        return REAL(pthread_create)(t, attr, start, arg);
    own->start = start, own->arg = arg;
    int rc = REAL(pthread_create)(t, attr, run_own, own);
    if (rc)
        free(own);
    return rc;
}
