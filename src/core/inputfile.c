#include "core/inputfile.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

uint64_t input_hash(uint64_t h, const void *data, size_t len)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < len; i++)
        h = (h ^ p[i]) * 0x100000001b3ULL;
    return h;
}

/* Reads exactly len bytes; a file that shrank or grew meanwhile is an error. */
static int read_exactly(FILE *fp, const char *path, char *buf, size_t len, rr_error *err)
{
    if (fread(buf, 1, len, fp) != len || ferror(fp))
        return rr_fail(err, "%s: read error (the file changed while being read?)", path);
    if (fgetc(fp) != EOF)
        return rr_fail(err, "%s: the file grew while being read", path);
    return 0;
}

/* Opens path for reading without blocking (opening a FIFO waits for a
 * writer, so a FIFO named as an input would hang before its type could be
 * checked); the type is checked on the open descriptor, so the
 * file checked is the file read. NULL with err filled on failure. */
static FILE *open_regular(const char *path, struct stat *st, rr_error *err)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return rr_fail(err, "%s: cannot open: %s", path, strerror(errno)), NULL;
    FILE *fp = NULL;
    if (fstat(fd, st))
        rr_fail(err, "%s: cannot stat: %s", path, strerror(errno));
    else if (!S_ISREG(st->st_mode))
        rr_fail(err, "%s: not a regular file", path);
    else if (fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK) || !(fp = fdopen(fd, "rb")))
        rr_fail(err, "%s: cannot open: %s", path, strerror(errno));
    if (!fp)
        close(fd);
    return fp;
}

/* Reads the open file fp (st: its stat) whole into f, and closes fp. */
static int read_open_file(FILE *fp, const struct stat *st, const char *path, size_t max_bytes, input_file *f,
                          rr_error *err)
{
    int rc = 0;
    if ((uint64_t)st->st_size > max_bytes)
        rc = rr_fail(err, "%s: %lld bytes, larger than the %zu this kind of input may have", path,
                     (long long)st->st_size, max_bytes);
    else if (!(f->data = malloc((size_t)st->st_size + 1)))
        rc = rr_fail(err, "%s: out of memory for %lld bytes", path, (long long)st->st_size);
    else
        rc = read_exactly(fp, path, f->data, (size_t)st->st_size, err);
    fclose(fp);
    if (rc) {
        input_file_free(f);
        return -1;
    }
    f->len = (size_t)st->st_size;
    f->data[f->len] = 0;
    return 0;
}

int input_file_read(const char *path, size_t max_bytes, input_file *f, rr_error *err)
{
    memset(f, 0, sizeof *f);
    struct stat st;
    FILE *fp = open_regular(path, &st, err);
    return fp ? read_open_file(fp, &st, path, max_bytes, f, err) : -1;
}

void input_file_free(input_file *f)
{
    if (f->mapped)
        munmap(f->data, f->len);
    else
        free(f->data);
    memset(f, 0, sizeof *f);
}

/* Below this, a copy costs little; a mapping whose size is a whole number
 * of pages would have no NUL after its end for the text parsers. */
#define STREAM_MIN_BYTES ((size_t)64 << 20)

int input_file_stream(const char *path, size_t max_bytes, input_file *f, rr_error *err)
{
    memset(f, 0, sizeof *f);
    struct stat st;
    FILE *fp = open_regular(path, &st, err);
    if (!fp)
        return -1;
    size_t page = (size_t)sysconf(_SC_PAGESIZE), size = (size_t)st.st_size;
    void *map = (uint64_t)st.st_size > max_bytes || size < STREAM_MIN_BYTES || size % page == 0
                    ? MAP_FAILED : mmap(NULL, size, PROT_READ, MAP_PRIVATE, fileno(fp), 0);
    if (map == MAP_FAILED) /* small, a whole number of pages, too large (refused there) or not mappable */
        return read_open_file(fp, &st, path, max_bytes, f, err);
    fclose(fp); /* the mapping stays */
    madvise(map, size, MADV_SEQUENTIAL);
    f->data = map, f->len = size, f->mapped = 1;
    return 0;
}

void input_file_consume(input_file *f, size_t upto)
{
    if (!f->mapped || upto <= f->released)
        return;
    size_t page = (size_t)sysconf(_SC_PAGESIZE), end = upto / page * page;
    if (end <= f->released)
        return;
    f->hash = input_hash(f->hash, f->data + f->released, end - f->released);
    madvise(f->data + f->released, end - f->released, MADV_DONTNEED);
    f->released = end;
}

uint64_t input_file_hash(const input_file *f)
{
    return input_hash(f->hash, f->data + f->released, f->len - f->released);
}
