#include "inputfile.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

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

int input_file_read(const char *path, size_t max_bytes, input_file *f, rr_error *err)
{
    f->data = NULL, f->len = 0;
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return rr_fail(err, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    int rc = 0;
    if (fstat(fileno(fp), &st))
        rc = rr_fail(err, "%s: cannot stat: %s", path, strerror(errno));
    else if (!S_ISREG(st.st_mode))
        rc = rr_fail(err, "%s: not a regular file", path);
    else if ((uint64_t)st.st_size > max_bytes)
        rc = rr_fail(err, "%s: %lld bytes, larger than the %zu this kind of input may have", path,
                     (long long)st.st_size, max_bytes);
    else if (!(f->data = malloc((size_t)st.st_size + 1)))
        rc = rr_fail(err, "%s: out of memory for %lld bytes", path, (long long)st.st_size);
    else
        rc = read_exactly(fp, path, f->data, (size_t)st.st_size, err);
    fclose(fp);
    if (rc) {
        input_file_free(f);
        return -1;
    }
    f->len = (size_t)st.st_size;
    f->data[f->len] = 0;
    return 0;
}

void input_file_free(input_file *f)
{
    free(f->data);
    f->data = NULL;
    f->len = 0;
}
