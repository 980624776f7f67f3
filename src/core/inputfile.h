/* Input files (scene, PLY, .anim) read whole, once, with a content hash.
 *
 * Reading everything through one function gives three guarantees: only
 * regular files of a bounded size are read (a FIFO or /dev/zero named as a
 * model would otherwise be read forever), the bytes that are parsed are the
 * bytes that are hashed (a render state's identity covers the content of
 * every input, so a resume never mixes two versions of a file), and every
 * failure names the file. */
#ifndef RR_INPUTFILE_H
#define RR_INPUTFILE_H

#include <signal.h>
#include <stdint.h>

#include "core/common.h"

#define INPUT_HASH_INIT 0xcbf29ce484222325ULL /* FNV-1a 64-bit offset basis */

typedef struct {
    char *data; /* len bytes plus a terminating NUL (for text parsers) */
    size_t len;
    int mapped;      /* input_file_stream: data is a read-only mapping */
    size_t released; /* input_file_consume: bytes hashed and dropped from memory */
    uint64_t hash;   /* their hash so far */
    /* the reader's stop flag (NULL: never; set it after opening): a parse
     * of the file stops soon after it becomes non-zero (ply.c) */
    volatile sig_atomic_t *cancel;
} input_file;

/* Reads path into f; fails naming the file if it is not a regular file, is
 * larger than max_bytes or cannot be read. */
int input_file_read(const char *path, size_t max_bytes, input_file *f, rr_error *err);
void input_file_free(input_file *f);

/* For inputs too large to hold twice (a trained model's PLY is as large as
 * the model it holds): maps the file read-only instead of copying
 * it where it is large enough to matter, so that the parser reads it once
 * and input_file_consume drops what it has read from memory, hashing it
 * first: the bytes parsed are the bytes hashed, and the peak is the model
 * plus what the parser has not yet released. Falls back to
 * input_file_read. (A mapped file truncated by another process while it
 * is read ends the process with SIGBUS, as any reader of mapped files.) */
int input_file_stream(const char *path, size_t max_bytes, input_file *f, rr_error *err);
/* The first `upto` bytes are read and will not be looked at again: they
 * are folded into f->hash and, when mapped, released (whole pages). */
void input_file_consume(input_file *f, size_t upto);
/* f->hash (set it to the caller's running hash after opening) with the
 * bytes not yet consumed folded in: the running hash over the whole file. */
uint64_t input_file_hash(const input_file *f);

/* FNV-1a over len bytes, continuing from h (start with INPUT_HASH_INIT). */
uint64_t input_hash(uint64_t h, const void *data, size_t len);

#endif
