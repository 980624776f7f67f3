/* Where the render command (cmd_render) hands its final image, failure
 * message and interrupt flag when a library caller runs it in-process
 * (src/api/refrender_api.h) instead of the command line: the same option
 * parsing, checks, render and header as the CLI, with the image kept in
 * memory rather than written to -o. NULL (the default): the command line. */
#ifndef RR_RENDER_SINK_H
#define RR_RENDER_SINK_H

#include <signal.h>

#include "io/output.h"

typedef struct {
    /* the final image, exactly as output_write_final_into would write it */
    int (*final)(void *user, const image *img, int samples_per_batch, const attr_list *attrs, const exr_window *win,
                 rr_error *err);
    /* the message the command line prints after "refrender: " before exiting non-zero */
    void (*failed)(void *user, const char *msg);
    /* the caller's flag, watched instead of installing SIGINT/SIGTERM handlers
     * (a library must not take the host process's signals) */
    volatile sig_atomic_t *interrupt;
    void *user;
} render_sink;

/* Set by the caller around one cmd_render call (one at a time: the
 * command's state is the process's, as getopt's is). */
extern const render_sink *render_command_sink;

#endif
