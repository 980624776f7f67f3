/* 'refrender merge': combines render states of one render (from --pass)
 * into the final image. Sums are exact integers (film.h), so the result is
 * bit-identical to rendering all batches in one run. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd/cli.h"
#include "cmd/commands.h"
#include "cmd/noise_report.h"
#include "io/output.h"
#include "io/preview.h"

static void merge_usage(FILE *f)
{
    fputs(
"usage: refrender merge STATE.exr [STATE.exr ...] -o OUT.exr [--preview OUT.png]\n"
"\n"
"Combines the render states written by 'refrender --pass K/N' (all N of them)\n"
"into the final EXR, identical to a single render with all batches. Refuses\n"
"states of different renders (the build of refrender, hashes of the scene\n"
"and of every model and .anim file, resolution, sampler, counts, seed,\n"
"epsilon, sigma, shutter, weight, time factor, batches), of different frames or cameras (frame,\n"
"frame rate, shutter, worldToCamera, worldToNDC, the camera's open and close\n"
"poses and their times must be equal), overlapping\n"
"or missing batch ranges, incomplete states, and states whose contents no\n"
"render can produce. The output carries the states' attributes; its\n"
"refrender:rays and refrender:renderSeconds are the states' sums.\n"
"  -o, --output F   output EXR (required); written atomically\n"
"  --preview F      also an 8-bit sRGB preview of the merged image (PNG, by\n"
"                   extension), as a render's --preview: both files or neither\n"
"  --quiet          no summary line\n", f);
}

typedef struct {
    uint32_t begin, end;
    const char *path;
} batch_range;

static int by_begin(const void *a, const void *b)
{
    const batch_range *x = a, *y = b;
    return (x->begin > y->begin) - (x->begin < y->begin);
}

static int check_ranges(batch_range *r, int n, uint32_t total, rr_error *err)
{
    qsort(r, (size_t)n, sizeof *r, by_begin);
    uint32_t next = 0;
    for (int i = 0; i < n; i++) {
        if (r[i].begin < next)
            return rr_fail(err, "%s (batches %u-%u) overlaps another state", r[i].path, r[i].begin, r[i].end);
        if (r[i].begin > next)
            return rr_fail(err, "batches %u-%u are missing: no state holds them", next, r[i].begin);
        next = r[i].end;
    }
    if (next != total)
        return rr_fail(err, "batches %u-%u are missing: no state holds them", next, total);
    return 0;
}

/* A state's range lies within its own render's batches (a render writes
 * nothing else): checked before its pixels, whose counts a resume could
 * not bring up to a range the render never gives. */
static int check_range_in_render(const attr_list *a, const batch_range *r, rr_error *err)
{
    unsigned long total = strtoul(attrs_get(a, ATTR_BATCHES), NULL, 10);
    if (r->end > total)
        return rr_fail(err, "%s holds batches %u-%u, beyond the %lu batches of its render (refrender:batches): "
                            "a damaged or crafted state", r->path, r->begin, r->end, total);
    return 0;
}

static int check_complete(const image *img, const batch_range *r, rr_error *err)
{
    size_t n = (size_t)img->width * img->height;
    for (size_t i = 0; i < n; i++) {
        uint32_t has = img->px[i].batches, range = r->end - r->begin;
        if (has > range) /* a --pass state never does: --pass and --target-error exclude each other */
            return rr_fail(err, "%s: pixel %zu holds %u batches, more than the %u of its range %u-%u: not a --pass "
                                "state but a checkpoint of a --target-error render (finish it with --resume, which "
                                "writes the final image) or a damaged one", r->path, i, has, range, r->begin, r->end);
        if (has < range)
            return rr_fail(err, "%s is incomplete (pixel %zu has %u of %u batches): resume it first", r->path, i,
                           has, range);
    }
    return 0;
}

/* The batches of all states together stay within the render's count, which
 * is at most FILM_MAX_BATCHES: so the summed fixed-point sums cannot overflow
 * (film.h), whatever overlapping states a user or a crafted file offers. */
static int check_batch_total(const attr_list *first, const batch_range *range, uint32_t *so_far, rr_error *err)
{
    unsigned long total = strtoul(attrs_get(first, ATTR_BATCHES), NULL, 10);
    if (total > FILM_MAX_BATCHES)
        return rr_fail(err, "%s: refrender:batches %lu is more than %u", range->path, total, FILM_MAX_BATCHES);
    if ((uint64_t)*so_far + (range->end - range->begin) > total)
        return rr_fail(err, "%s (batches %u-%u) overlaps another state: more than the render's %lu batches",
                       range->path, range->begin, range->end, total);
    *so_far += range->end - range->begin;
    return 0;
}

/* Adds state `path` into merged (allocated from the first state). */
static int add_state(const char *path, image *merged, attr_list *first, const char *first_path,
                     batch_range *range, int is_first, uint32_t *so_far, rr_error *err)
{
    image img;
    attr_list attrs;
    range->path = path;
    if (output_read_state(path, &img, &attrs, &range->begin, &range->end, err))
        return -1;
    int rc = check_range_in_render(&attrs, range, err);
    if (!rc)
        rc = check_complete(&img, range, err);
    if (!rc && !is_first)
        rc = attrs_check_identity(first, first_path, &attrs, path, err);
    if (!rc && !is_first)
        rc = attrs_combine(first, first_path, &attrs, path, err);
    if (!rc)
        rc = check_batch_total(is_first ? &attrs : first, range, so_far, err);
    if (!rc && is_first) {
        *first = attrs;
        *merged = img;
        return 0;
    }
    size_t n = (size_t)img.width * img.height;
    for (size_t i = 0; i < n && !rc; i++)
        film_merge(&merged->px[i], &img.px[i]);
    image_free(&img);
    return rc;
}

/* The merged image and its preview (NULL: none), both put in place or
 * neither, as a render's outputs (render_frames.c, write_outputs). */
static int write_merged(const char *out, const char *preview, const image *merged, const attr_list *attrs,
                        rr_error *err)
{
    int per_batch = atoi(attrs_get(attrs, ATTR_SPP)) * atoi(attrs_get(attrs, ATTR_TSPP));
    exr_window whole = {merged->width, merged->height, 0, 0, merged->width, merged->height};
    atomic_set set = {0};
    int rc = output_write_final_into(&set, out, merged, per_batch, attrs, &whole, err);
    if (!rc && preview)
        rc = output_write_preview_into(&set, preview, merged, attrs, err);
    if (rc) {
        atomic_set_discard(&set);
        return -1;
    }
    return atomic_set_commit(&set, err);
}

static int merge_files(char **paths, int n, const char *out, const char *preview, int quiet, rr_error *err)
{
    batch_range *ranges = calloc((size_t)n, sizeof *ranges);
    image merged = {0};
    static attr_list attrs; /* large; one merge per process */
    int rc = ranges ? 0 : rr_fail(err, "out of memory");
    uint32_t so_far = 0;
    for (int i = 0; i < n && !rc; i++)
        rc = add_state(paths[i], &merged, &attrs, paths[0], &ranges[i], i == 0, &so_far, err);
    if (!rc)
        rc = check_ranges(ranges, n, (uint32_t)strtoul(attrs_get(&attrs, ATTR_BATCHES), NULL, 10), err);
    if (!rc) {
        attrs_set(&attrs, ATTR_COMMAND, "refrender merge (%d states)", n);
        rc = noise_report(&merged, 0, 0, 1, &attrs, err) || /* the noise reached, as a render writes it */
             write_merged(out, preview, &merged, &attrs, err);
    }
    if (!rc && !quiet)
        fprintf(stderr, "refrender merge: %d states -> %s%s%s\n", n, out, preview ? " and " : "",
                preview ? preview : "");
    image_free(&merged);
    free(ranges);
    return rc;
}

/* --preview as a render's: a writable name of a format OpenImageIO writes,
 * checked before anything is merged, neither a state nor -o's file. */
static int check_preview(const char *out, const char *preview, char *const *states, int n, rr_error *err)
{
    if (cli_check_writable("--preview", preview, err) || preview_check_format(preview, err) ||
        cli_refuse_overwriting_inputs(preview, states, n, err))
        return -1;
    if (cli_same_file(out, preview))
        return rr_fail(err, "-o and --preview name the same file %s", preview);
    return 0;
}

int cmd_merge(int argc, char **argv)
{
    static const struct option longopts[] = {{"output", required_argument, 0, 'o'},
                                             {"preview", required_argument, 0, 'p'},
                                             {"quiet", no_argument, 0, 'q'},
                                             {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    const char *out = NULL, *preview = NULL;
    int quiet = 0, c;
    while ((c = getopt_long(argc, argv, "ho:", longopts, NULL)) != -1) {
        if (c == 'h') { merge_usage(stdout); return 0; }
        if (c == 'o') out = optarg;
        else if (c == 'p') preview = optarg;
        else if (c == 'q') quiet = 1;
        else {
            cli_suggest_option("refrender merge", argv[optind - 1], longopts);
            fputs("Try 'refrender merge --help'.\n", stderr);
            return 2;
        }
    }
    if (!out || optind >= argc) {
        fputs("refrender merge: need STATE files and -o OUT.exr; try 'refrender merge --help'\n", stderr);
        return 2;
    }
    rr_error err = {{0}};
    if (cli_check_exr_name("-o", out, 1, &err) || cli_check_writable("-o", out, &err) ||
        cli_refuse_overwriting_inputs(out, argv + optind, argc - optind, &err) ||
        (preview && check_preview(out, preview, argv + optind, argc - optind, &err)) ||
        merge_files(argv + optind, argc - optind, out, preview, quiet, &err)) {
        fprintf(stderr, "refrender merge: %s\n", err.msg);
        return 1;
    }
    return 0;
}
