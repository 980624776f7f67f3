/* The library entry point (refrender_api.h): the render command run with a
 * sink (cmd/render_sink.h) that copies the final image's channels and
 * attributes as output_write_final_into would write them. */
#include "api/refrender_api.h"

#include <getopt.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd/commands.h"
#include "cmd/render_sink.h"
#include "io/render_attrs.h"

/* the caller's int is the render's interrupt flag */
_Static_assert(sizeof(sig_atomic_t) == sizeof(int), "sig_atomic_t is not an int");

struct refrender_result {
    int window[6]; /* full_w, full_h, x0, y0, w, h */
    int nchannels;
    char names[OUTPUT_FINAL_CHANNELS_MAX][32];
    float *channels[OUTPUT_FINAL_CHANNELS_MAX];
    attr_list attrs;
};

typedef struct {
    refrender_result *result;
    char *message;
    size_t message_size;
} api_call;

void refrender_result_free(refrender_result *r)
{
    if (!r)
        return;
    for (int i = 0; i < r->nchannels; i++)
        free(r->channels[i]);
    free(r);
}

/* Each channel's window pixels, row after row (exr.h: element (x, y) at
 * base + (y w + x) stride bytes). */
static int copy_channels(refrender_result *r, const exr_channel *chs, int nch, const exr_window *win)
{
    size_t n = (size_t)win->w * win->h;
    for (int i = 0; i < nch; i++) {
        float *dst = malloc(n * sizeof *dst);
        if (!dst)
            return -1;
        r->channels[r->nchannels++] = dst;
        snprintf(r->names[i], sizeof r->names[i], "%s", chs[i].name);
        for (size_t k = 0; k < n; k++)
            memcpy(dst + k, (const char *)chs[i].base + k * (size_t)chs[i].stride, sizeof *dst);
    }
    return 0;
}

static int keep_final(void *user, const image *img, int samples_per_batch, const attr_list *attrs,
                      const exr_window *win, rr_error *err)
{
    api_call *call = user;
    image_planes p;
    exr_channel chs[OUTPUT_FINAL_CHANNELS_MAX];
    int nch;
    if (output_final_channels(img, samples_per_batch, win, &p, chs, &nch, err))
        return -1;
    refrender_result *r = calloc(1, sizeof *r);
    int rc = r ? copy_channels(r, chs, nch, win) : -1;
    image_planes_free(&p);
    if (rc) {
        refrender_result_free(r);
        return rr_fail(err, "out of memory for the image");
    }
    memcpy(r->window, (int[6]){win->full_w, win->full_h, win->x0, win->y0, win->w, win->h}, sizeof r->window);
    r->attrs = *attrs;
    call->result = r;
    return 0;
}

static void keep_message(void *user, const char *msg)
{
    api_call *call = user;
    if (call->message_size)
        snprintf(call->message, call->message_size, "%s", msg);
}

static pthread_mutex_t one_render = PTHREAD_MUTEX_INITIALIZER;

/* cmd_render with the sink set: getopt's state is the process's, reset for
 * each call (optind 0: a full re-initialisation in glibc) and made quiet
 * (the sink says the failure). */
static int run_command(int argc, char **argv, const render_sink *sink)
{
    int saved_opterr = opterr;
    optind = 0, opterr = 0;
    render_command_sink = sink;
    int rc = cmd_render(argc, argv);
    render_command_sink = NULL;
    opterr = saved_opterr;
    return rc;
}

int refrender_render(int argc, const char *const *argv, volatile int *interrupt, refrender_result **out,
                     char *message, size_t message_size)
{
    static volatile sig_atomic_t never = 0;
    api_call call = {NULL, message, message_size};
    render_sink sink = {keep_final, keep_message, interrupt ? (volatile sig_atomic_t *)interrupt : &never, &call};
    *out = NULL;
    if (message_size)
        message[0] = 0;
    /* getopt permutes its argv: a copy of the pointers, the strings are the caller's */
    char **args = argc > 0 ? calloc((size_t)argc + 1, sizeof *args) : NULL;
    if (!args) {
        keep_message(&call, argc > 0 ? "out of memory" : "argv must hold at least the program name");
        return argc > 0 ? 1 : 2;
    }
    memcpy(args, argv, (size_t)argc * sizeof *args);
    pthread_mutex_lock(&one_render);
    int rc = run_command(argc, args, &sink);
    pthread_mutex_unlock(&one_render);
    free(args);
    if (!rc && !call.result) { /* --help or --version: printed, nothing rendered */
        keep_message(&call, "no image was rendered (--help and --version only print)");
        rc = 2;
    }
    if (rc) {
        refrender_result_free(call.result);
        return rc;
    }
    *out = call.result;
    return 0;
}

void refrender_result_window(const refrender_result *r, int window[6])
{
    memcpy(window, r->window, sizeof r->window);
}

int refrender_result_channels(const refrender_result *r) { return r->nchannels; }

const char *refrender_result_channel_name(const refrender_result *r, int i)
{
    return i >= 0 && i < r->nchannels ? r->names[i] : NULL;
}

const float *refrender_result_channel(const refrender_result *r, int i)
{
    return i >= 0 && i < r->nchannels ? r->channels[i] : NULL;
}

int refrender_result_attrs(const refrender_result *r) { return r->attrs.n; }

const char *refrender_result_attr_key(const refrender_result *r, int i)
{
    return i >= 0 && i < r->attrs.n ? r->attrs.key[i] : NULL;
}

const char *refrender_result_attr_text(const refrender_result *r, int i)
{
    return i >= 0 && i < r->attrs.n ? r->attrs.value[i] : NULL;
}

/* rr_attr_kind's order is the API's: 0 text, 1 int, 2 double, 3 m44f */
_Static_assert(RR_ATTR_TEXT == 0 && RR_ATTR_INT == 1 && RR_ATTR_DOUBLE == 2 && RR_ATTR_M44F == 3,
               "rr_attr_kind is no longer refrender_result_attr_type's numbering");

int refrender_result_attr_type(const refrender_result *r, int i)
{
    return i >= 0 && i < r->attrs.n ? (int)r->attrs.kind[i] : -1;
}

int refrender_result_attr_numbers(const refrender_result *r, int i, double out[16])
{
    if (i < 0 || i >= r->attrs.n)
        return -1;
    exr_string_attr a = {r->attrs.key[i], r->attrs.value[i], r->attrs.kind[i]};
    return exr_attr_numbers(&a, out);
}

static char version_text[160];
static void fill_version(void)
{
    snprintf(version_text, sizeof version_text, "refrender %s (build %s)", RR_VERSION, render_build_id());
}

const char *refrender_version(void)
{
    static pthread_once_t once = PTHREAD_ONCE_INIT;
    pthread_once(&once, fill_version);
    return version_text;
}
