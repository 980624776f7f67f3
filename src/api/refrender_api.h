/* refrender as a C library (librefrender.so; the Python package python/
 * calls it through ctypes). One entry point renders as the command line
 * `refrender ARGS...` does (src/cmd/main.c: the same option parsing, checks,
 * render and header) and keeps the final image in memory: the channels and
 * attributes its EXR would hold, value for value. */
#ifndef REFRENDER_API_H
#define REFRENDER_API_H

#include <stddef.h>

typedef struct refrender_result refrender_result;

/* Renders `refrender argv[1] ... argv[argc-1]` (argv[0] names the program, as
 * main's; -o, --preview, --pass, --checkpoint, --resume and --frames are
 * refused: the image is returned). Returns 0 with *out set, or the command
 * line's exit status (1 bad input or render error, 2 usage error, 130
 * interrupted) with the line it prints after "refrender: " in message
 * (cut to message_size). Setting *interrupt non-zero from any thread stops
 * the render as SIGINT stops the command line (no signal handler is
 * installed: the host process keeps its own). Warnings, notes and the
 * progress bar go to stderr as the command line's. One render at a time in
 * a process: a second call waits for the first. */
int refrender_render(int argc, const char *const *argv, volatile int *interrupt, refrender_result **out,
                     char *message, size_t message_size);
void refrender_result_free(refrender_result *r);

/* The image's display window and data window (the crop window's pixels
 * with --crop-window): full width, full height, x0, y0, width, height. */
void refrender_result_window(const refrender_result *r, int window[6]);
/* Channels in the EXR's order: R G B A, variance.* and stderr.* (R G B A)
 * when some pixel has 2 or more batches, samples; each width x height
 * floats, row after row. */
int refrender_result_channels(const refrender_result *r);
const char *refrender_result_channel_name(const refrender_result *r, int i);
const float *refrender_result_channel(const refrender_result *r, int i);
/* The header's attributes: name, text, its EXR type (0 string, 1 int, 2
 * double, 3 4x4 float matrix) and the numbers the EXR holds for it (returns
 * how many: 0 for a string, 1 for an int or double, 16 for a matrix,
 * row-major, each a float). */
int refrender_result_attrs(const refrender_result *r);
const char *refrender_result_attr_key(const refrender_result *r, int i);
const char *refrender_result_attr_text(const refrender_result *r, int i);
int refrender_result_attr_type(const refrender_result *r, int i);
int refrender_result_attr_numbers(const refrender_result *r, int i, double out[16]);

/* "refrender VERSION (build ID)", as `refrender --version` prints. */
const char *refrender_version(void);

#endif
