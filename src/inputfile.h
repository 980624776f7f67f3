/* Input files (scene, PLY, .anim) read whole, once, with a content hash.
 *
 * Reading everything through one function gives three guarantees: only
 * regular files of a bounded size are read (a FIFO or /dev/zero named as a
 * model would otherwise be read forever), the bytes that are parsed are the
 * bytes that are hashed (a render state's identity covers the content of
 * every input, issue 18.3), and every failure names the file. */
#ifndef RR_INPUTFILE_H
#define RR_INPUTFILE_H

#include <stdint.h>

#include "common.h"

#define INPUT_HASH_INIT 0xcbf29ce484222325ULL /* FNV-1a 64-bit offset basis */

typedef struct {
    char *data; /* len bytes plus a terminating NUL (for text parsers) */
    size_t len;
} input_file;

/* Reads path into f; fails naming the file if it is not a regular file, is
 * larger than max_bytes or cannot be read. */
int input_file_read(const char *path, size_t max_bytes, input_file *f, rr_error *err);
void input_file_free(input_file *f);

/* FNV-1a over len bytes, continuing from h (start with INPUT_HASH_INIT). */
uint64_t input_hash(uint64_t h, const void *data, size_t len);

#endif
