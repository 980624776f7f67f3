/* A fuzz target's corpus replayed without libFuzzer: `make test` links each
 * target's LLVMFuzzerTestOneInput with this main and the build's own
 * objects (build-check/: RR_DCHECK on; build-san/ under SAN=1: ASan and
 * UBSan, as the fuzz builds), so the regression run costs no second,
 * clang-instrumented build of the whole source (make fuzz keeps that one,
 * in build-fuzz/). The entry point is made for this: LLVM's
 * compiler-rt/lib/fuzzer/standalone/StandaloneFuzzTargetMain.c feeds files
 * to a target the same way. Each input is handed over once, in a buffer of
 * exactly its size, so a read past its end is the overflow the sanitizers
 * see; a finding aborts, as under libFuzzer.
 *
 * replay_TARGET DIR: every regular file in DIR, in name order (the same
 * order on every machine), each named on stderr before it is replayed;
 * prints how many were replayed. */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The file's bytes in a malloc of exactly its size (one byte for an empty
 * file, which is passed with size 0); NULL with a message on failure. */
static uint8_t *read_input(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    struct stat st;
    if (!f || fstat(fileno(f), &st)) {
        perror(path);
        if (f)
            fclose(f);
        return NULL;
    }
    *size = (size_t)st.st_size;
    uint8_t *data = malloc(*size ? *size : 1);
    if (!data || fread(data, 1, *size, f) != *size) {
        fprintf(stderr, "%s: cannot read %zu bytes\n", path, *size);
        free(data);
        data = NULL;
    }
    fclose(f);
    return data;
}

static int by_name(const struct dirent **a, const struct dirent **b) { return strcmp((*a)->d_name, (*b)->d_name); }

static const char *corpus_dir; /* scandir's filter takes no argument */

/* A regular file, or a link to one (stat follows it): a file system that
 * leaves d_type unknown (XFS without ftype, some NFS) is asked by stat,
 * which also keeps "." and ".." out. */
static int regular_file(const struct dirent *e)
{
    if (e->d_type == DT_REG)
        return 1;
    if (e->d_type != DT_UNKNOWN && e->d_type != DT_LNK)
        return 0;
    char path[4096];
    struct stat st;
    snprintf(path, sizeof path, "%s/%s", corpus_dir, e->d_name);
    return !stat(path, &st) && S_ISREG(st.st_mode);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s CORPUS-DIR\n", argv[0]);
        return 2;
    }
    struct dirent **names;
    corpus_dir = argv[1];
    int n = scandir(argv[1], &names, regular_file, by_name);
    if (n < 0) {
        perror(argv[1]);
        return 1;
    }
    int rc = 0;
    for (int i = 0; i < n; i++) {
        char path[4096];
        size_t size;
        snprintf(path, sizeof path, "%s/%s", argv[1], names[i]->d_name);
        uint8_t *data = rc ? NULL : read_input(path, &size);
        if (!rc && !data)
            rc = 1;
        if (data) {
            fprintf(stderr, "replaying %s\n", path); /* the last line before a finding names its input */
            LLVMFuzzerTestOneInput(data, size);
            free(data);
        }
        free(names[i]);
    }
    free(names);
    if (!rc)
        printf("%s: replayed %d corpus inputs\n", argv[0], n);
    return rc;
}
