/* The render command's frames: each frame's settings and header, its
 * render with progress and checkpoints, resume, the reports after it, and
 * its outputs (render_cmd.h). */
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cmd/cli.h"
#include "cmd/noise_report.h"
#include "cmd/render_sink.h"
#include "cmd/render_cmd.h"
#include "render/integrator.h"
#include "io/output.h"
#include "io/render_attrs.h"

static void print_progress(void *user, double fraction, uint64_t rays, double seconds)
{
    (void)user;
    int width = 30, filled = (int)(fraction * width);
    double eta = fraction > 0 ? seconds * (1 - fraction) / fraction : 0;
    char bar[64];
    for (int i = 0; i < width; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[width] = 0;
    fprintf(stderr, "\r[%s] %5.1f%%  elapsed %5.1fs  ETA %5.1fs  %6.2f Mrays/s ", bar,
            100 * fraction, seconds, eta, seconds > 0 ? rays / seconds * 1e-6 : 0.0);
    if (fraction >= 1)
        fputc('\n', stderr);
    fflush(stderr);
}

typedef struct {
    const render_options *o;
    const accel *acc; /* the frame's: accel_scene(acc)'s shutter is the render's */
    render_settings rs;
    attr_list attrs;
    uint32_t total_batches;
    double last_progress; /* seconds into the render of the last progress line */
} render_run;

static int write_checkpoint(void *user, const image *img, rr_error *err)
{
    render_run *run = user;
    attrs_set(&run->attrs, ATTR_RENDER_SECONDS, "%.3f", img->seconds);
    attrs_set(&run->attrs, ATTR_RAYS, "%llu", (unsigned long long)img->rays);
    attrs_set(&run->attrs, ATTR_CLAMPED, "%llu", (unsigned long long)img->clamped);
    const shutter *sh = &accel_scene(run->acc)->shut;
    output_counter_attrs(&run->attrs, &img->counters, img->rays, sh->close - sh->open);
    return output_write_state(run->o->checkpoint, img, run->rs.batch_begin,
                              run->rs.batch_begin + run->rs.batches, &run->attrs, err);
}

static void warn_checkpoint(void *user, const rr_error *err)
{
    (void)user;
    fprintf(stderr, "\nrefrender: warning: checkpoint not written, the previous one is kept; rendering goes on: %s\n",
            err->msg);
}

/* --progress-every without a terminal (a batch job's log): a line at most
 * every S seconds, and the last one. */
static void print_progress_line(void *user, double fraction, uint64_t rays, double seconds)
{
    render_run *run = user;
    if (fraction < 1 && seconds - run->last_progress < run->o->progress_every)
        return;
    run->last_progress = seconds;
    double eta = fraction > 0 ? seconds * (1 - fraction) / fraction : 0;
    fprintf(stderr, "refrender: %5.1f%% after %.1fs, ETA %.1fs, %.2f Mrays/s\n", 100 * fraction, seconds, eta,
            seconds > 0 ? rays / seconds * 1e-6 : 0.0);
    fflush(stderr);
}

/* No pixel of a resumed state may hold more batches than this render gives
 * one: its range, or with --target-error the batch cap. */
static int check_resumable_counts(const render_run *run, image *img, rr_error *err)
{
    uint32_t most = run->rs.target_error > 0 ? run->rs.max_batches : run->rs.batches;
    size_t n = (size_t)img->width * img->height;
    for (size_t i = 0; i < n; i++)
        if (img->px[i].batches > most) {
            rr_fail(err, "%s: pixel (%zu, %zu) holds %u batches, more than the %u this render gives a pixel",
                    run->o->resume, i % (size_t)img->width, i / (size_t)img->width, img->px[i].batches, most);
            image_free(img);
            return -1;
        }
    return 0;
}

/* The integrator's counters the state holds (write_checkpoint), summed
 * again from their header values (to their 6 digits), so that the resumed
 * render's are the whole render's; the row is the one the render will use
 * (integrator_for, the one rule that picks it). */
static void resume_counters(const render_run *run, const attr_list *saved, image *img)
{
    integrator_context ctx = {.sc = accel_scene(run->acc), .acc = run->acc, .rs = &run->rs};
    const integrator_ops *row = integrator_for(&ctx);
    img->counters.spec = row->counters, img->counters.n = row->ncounters;
    double shutter = ctx.sc->shut.close - ctx.sc->shut.open;
    for (int i = 0; i < row->ncounters; i++) {
        const char *value = attrs_get(saved, row->counters[i].attribute);
        double held = value ? strtod(value, NULL) : 0.0;
        img->counters.sum[i] = output_counter_sum(&row->counters[i], held, img->rays, shutter);
    }
}

/* Loads --resume into img after checking it is this very render. */
static int resume_state(render_run *run, image *img, rr_error *err)
{
    attr_list saved;
    uint32_t begin, end;
    if (output_read_state(run->o->resume, img, &saved, &begin, &end, err))
        return -1;
    if (attrs_check_identity(&saved, run->o->resume, &run->attrs, "this render", err)) {
        image_free(img);
        return -1;
    }
    if (begin != run->rs.batch_begin || end != run->rs.batch_begin + run->rs.batches) {
        image_free(img);
        return rr_fail(err, "%s holds batches %u-%u, this render %u-%u", run->o->resume, begin, end,
                       run->rs.batch_begin, run->rs.batch_begin + run->rs.batches);
    }
    if (check_resumable_counts(run, img, err))
        return -1;
    /* the work the state took goes on counting (render.c, checkpoint_paused) */
    const char *rays = attrs_get(&saved, ATTR_RAYS), *seconds = attrs_get(&saved, ATTR_RENDER_SECONDS);
    const char *clamped = attrs_get(&saved, ATTR_CLAMPED);
    img->rays = rays ? (uint64_t)strtod(rays, NULL) : 0;
    img->clamped = clamped ? (uint64_t)strtod(clamped, NULL) : 0;
    img->seconds = seconds ? strtod(seconds, NULL) : 0.0;
    resume_counters(run, &saved, img);
    if (!run->o->quiet) { /* a log then shows the work kept */
        uint64_t done = 0, n = (uint64_t)img->width * img->height;
        for (uint64_t i = 0; i < n; i++)
            done += img->px[i].batches;
        fprintf(stderr, "refrender: resuming %s: %llu of %llu pixel batches already done\n", run->o->resume,
                (unsigned long long)done, (unsigned long long)(n * run->rs.batches));
    }
    return 0;
}

/* --max-batches, by default 8 B (at most FILM_MAX_BATCHES). */
static uint32_t max_batches_of(const render_options *o)
{
    uint64_t eight = 8 * (uint64_t)o->batches;
    return o->max_batches ? (uint32_t)o->max_batches : (uint32_t)(eight < FILM_MAX_BATCHES ? eight : FILM_MAX_BATCHES);
}

static void setup_run(render_run *run, const accel *acc, const render_options *o, const char *cmdline)
{
    const scene *s = accel_scene(acc);
    uint32_t total = (uint32_t)o->batches;
    uint32_t begin = o->passes ? (uint32_t)((uint64_t)o->pass * total / o->passes) : 0;
    uint32_t end = o->passes ? (uint32_t)((uint64_t)(o->pass + 1) * total / o->passes) : total;
    run->o = o, run->acc = acc;
    run->total_batches = total;
    run->last_progress = 0;
    run->rs = (render_settings){
        .smp = {.kind = o->sampler, .seed = o->seed, .grid = sampler_grid_for_spp(o->spp), .tspp = o->tspp,
                .time_factor = s->time_factor, .random_strata = total >= 2}, /* error bars (a target error needs B >= 2 too) */
        .threads = o->threads,
        .batch_begin = begin,
        .batches = end - begin,
        .max_batches = max_batches_of(o),
        .target_error = o->target_error,
        .integrator = o->exact_time ? integrator_named("exact") : NULL,
        .filter = o->filter,
        .blur = o->blur,
    };
    if (o->crop_set) {
        int px[4];
        render_options_crop_pixels(o, s->cam.width, s->cam.height, px);
        run->rs.crop_x0 = px[0], run->rs.crop_x1 = px[1], run->rs.crop_y0 = px[2], run->rs.crop_y1 = px[3];
    }
    run->attrs.n = 0;
    attrs_for_render(&run->attrs, s, &run->rs, total, cmdline);
}

/* The summary line (not with --quiet), and the warnings: those are no
 * progress output, so --quiet keeps them (a clamped estimate once left no
 * trace under --quiet; its count is in the header too). */
static void report(const render_options *o, const scene *s, const image *img, int tty)
{
    if (!o->quiet && !tty)
        fprintf(stderr, "refrender: %s: %dx%d, %llu rays in %.2fs (%.2f Mrays/s)\n", s->path, img->width,
                img->height, (unsigned long long)img->rays, img->seconds,
                img->seconds > 0 ? img->rays / img->seconds * 1e-6 : 0.0);
    if (img->kbuffer_overflows)
        fprintf(stderr, "refrender: warning: %llu samples had more than %d hits within epsilon; "
                        "the farthest were dropped\n", (unsigned long long)img->kbuffer_overflows, KBUFFER_MAX);
    if (img->clamped)
        fprintf(stderr, "refrender: warning: %llu batch estimates exceeded +-%g and were clamped "
                        "(refrender:clampedEstimates)\n", (unsigned long long)img->clamped, FILM_LIMIT);
}

/* The integrator's own counters into the header, and its warnings about
 * them on stderr (not with --quiet), whatever they mean (render/counters.h). */
static void report_counters(const render_options *o, const image *img, const shutter *shut, attr_list *attrs)
{
    const counter_set *c = &img->counters;
    output_counter_attrs(attrs, c, img->rays, shut->close - shut->open);
    for (int i = 0; i < c->n && !o->quiet; i++)
        if (c->spec[i].warn)
            c->spec[i].warn(output_counter_value(c, i, img->rays, shut->close - shut->open));
}

/* A keyframed scale through zero is held at 1e-9 (animation.h): the
 * object all but vanishes there, which must not pass unnoticed. */
static void warn_about_scales(const render_options *o, const scene *s)
{
    const shutter *shut = &s->shut;
    for (int i = 0; i < s->nobjects && !o->quiet; i++)
        if (animation_scale_clamped(&s->objects[i].anim, shut->open, shut->close))
            fprintf(stderr, "refrender: warning: object '%s': its keyframed scale reaches zero or below during the "
                            "shutter [%g, %g] and is held at 1e-9 there (the object vanishes; Maya would mirror it)\n",
                    s->objects[i].name, shut->open, shut->close);
}

static void warn_about_settings(const render_options *o, const render_settings *rs)
{
    int k = rs->smp.grid;
    int64_t n = sampler_count(&rs->smp);
    if (o->quiet)
        return;
    if (k * k != o->spp)
        fprintf(stderr, "refrender: --spp %d rounded to a %dx%d grid (%d samples)\n", o->spp, k, k, k * k);
    /* any count is first-class (src/SAMPLING.md, Counts that are no power of two); only the error
     * bars' two time halves need an even one */
    if (rs->smp.kind == SAMPLER_SOBOL && rs->smp.random_strata && n % 2)
        fprintf(stderr, "refrender: note: sobol's error bars want an even spp*tspp (now %lld): with an odd one a pixel "
                        "stepping in time can report too small an error\n", (long long)n);
}

/* The final image, only the crop window's pixels with --crop-window. */
static int write_final(atomic_set *set, const char *output, const image *img, render_run *run, rr_error *err)
{
    const render_settings *rs = &run->rs;
    exr_window win = {img->width, img->height, 0, 0, img->width, img->height};
    if (rs->crop_x1 > 0) {
        win = (exr_window){img->width, img->height, rs->crop_x0, rs->crop_y0, rs->crop_x1 - rs->crop_x0,
                           rs->crop_y1 - rs->crop_y0};
        const double *c = run->o->crop;
        attrs_set(&run->attrs, ATTR_CROP_WINDOW, "%.17g %.17g %.17g %.17g", c[0], c[1], c[2], c[3]);
    }
    if (render_command_sink)
        return render_command_sink->final(render_command_sink->user, img, (int)sampler_count(&rs->smp), &run->attrs,
                                          &win, err);
    return output_write_final_into(set, output, img, (int)sampler_count(&rs->smp), &run->attrs, &win, err);
}

/* The image (a pass's state with --pass) and the preview: both put in
 * place or neither, as every command's outputs. */
static int write_outputs(const image *img, render_run *run, const char *output, const char *preview, rr_error *err)
{
    atomic_set set = {0};
    int rc = run->o->passes ? output_write_state_into(&set, output, img, run->rs.batch_begin,
                                                      run->rs.batch_begin + run->rs.batches, &run->attrs, err)
                            : write_final(&set, output, img, run, err);
    if (!rc && preview)
        rc = output_write_preview_into(&set, preview, img, &run->attrs, err);
    if (rc) {
        atomic_set_discard(&set);
        return -1;
    }
    return atomic_set_commit(&set, err);
}

/* Says what the render was handed, not what was asked for: the period it
 * uses is the one stated (render.h: 0 means only when interrupted). */
static void announce_checkpoints(const render_options *o, const render_hooks *h)
{
    if (!o->checkpoint || o->quiet)
        return;
    if (h->checkpoint_every > 0)
        fprintf(stderr, "refrender: checkpoint %s: every %g s and when interrupted\n", o->checkpoint,
                h->checkpoint_every);
    else
        fprintf(stderr, "refrender: checkpoint %s: only when interrupted\n", o->checkpoint);
}

/* Renders the frame accel was built for (its scene, accel_scene, holds the
 * frame's shutter) into output (and preview). */
static int render_one(const accel *acc, long long frame, const render_options *o, const char *cmdline,
                      const char *output, const char *preview, volatile sig_atomic_t *cancel, rr_error *err)
{
    const scene *s = accel_scene(acc);
    render_run run;
    setup_run(&run, acc, o, cmdline);
    warn_about_settings(o, &run.rs);
    warn_about_scales(o, s);
    image img;
    if (o->resume ? resume_state(&run, &img, err) : (image_alloc(&img, s->cam.width, s->cam.height)
                                                         ? rr_fail(err, "out of memory for the image") : 0))
        return -1;
    int tty = !o->quiet && isatty(STDERR_FILENO);
    void (*progress)(void *, double, uint64_t, double) =
        tty ? print_progress : !o->quiet && o->progress_every > 0 ? print_progress_line : NULL;
    render_hooks hooks = {progress, o->checkpoint ? write_checkpoint : NULL, warn_checkpoint, o->checkpoint_every,
                          &run};
    if (o->passes && !o->quiet)
        fprintf(stderr, "refrender: pass %d/%d: batches %u-%u of %u\n", o->pass, o->passes, run.rs.batch_begin,
                run.rs.batch_begin + run.rs.batches, run.total_batches);
    announce_checkpoints(o, &hooks);
    int rc = render_image(acc, &run.rs, &img, &hooks, cancel, err);
    if (!rc) {
        report(o, s, &img, tty);
        if (!o->passes) /* a final image: its noise (a pass's state has a share of the batches) */
            rc = noise_report(&img, o->target_error, max_batches_of(o), o->quiet, &run.attrs, err);
        attrs_set(&run.attrs, ATTR_RENDER_SECONDS, "%.3f", img.seconds);
        attrs_set(&run.attrs, ATTR_RAYS, "%llu", (unsigned long long)img.rays);
        attrs_set(&run.attrs, ATTR_CLAMPED, "%llu", (unsigned long long)img.clamped);
        report_counters(o, &img, &s->shut, &run.attrs);
        if (o->frames && s->frame_rate > 0)
            attrs_set(&run.attrs, ATTR_FRAME_RATE, "%.17g", s->frame_rate);
        if (o->frames)
            attrs_set(&run.attrs, ATTR_FRAME, "%lld", frame);
        if (!rc)
            rc = write_outputs(&img, &run, output, preview, err);
    }
    image_free(&img);
    return rc;
}

/* No output may overwrite an input (scene, model, .anim, the resumed state)
 * or another output of the same run; the checkpoint may be the resumed
 * state (that is how a render is continued). */
static int check_distinct_files(const scene *s, const render_options *o, const char *out, const char *prev,
                                rr_error *err)
{
    const char *outputs[3] = {out, prev, o->checkpoint}, *names[3] = {"-o", "--preview", "--checkpoint"};
    for (int i = 0; i < 3; i++) {
        if (!outputs[i])
            continue;
        for (int k = 0; k < s->ninputs; k++)
            if (cli_same_file(outputs[i], s->inputs[k]))
                return rr_fail(err, "%s %s is an input of this render (%s): refusing to overwrite it", names[i],
                               outputs[i], s->inputs[k]);
        if (o->resume && i < 2 && cli_same_file(outputs[i], o->resume))
            return rr_fail(err, "%s %s is the state being resumed: refusing to overwrite it", names[i], outputs[i]);
        for (int j = 0; j < i; j++)
            if (outputs[j] && cli_same_file(outputs[i], outputs[j]))
                return rr_fail(err, "%s and %s name the same file %s", names[j], names[i], outputs[i]);
    }
    return 0;
}

/* Frame f's output and preview names (prev NULL without --preview); a '%'
 * that is no frame field stays literal. */
static const char *frame_names(const render_options *o, long long f, char *out, char *prev, size_t size)
{
    cli_frame_path(o->output, (int)f, out, size);
    if (!o->preview)
        return NULL;
    cli_frame_path(o->preview, (int)f, prev, size);
    return prev;
}

/* Every frame's outputs are checked before anything is built or rendered. */
static int check_frame_outputs(const scene *s, const render_options *o, rr_error *err)
{
    char out[PATH_MAX], prev[PATH_MAX];
    for (long long f = o->first_frame; f <= o->last_frame; f++)
        if (check_distinct_files(s, o, out, frame_names(o, f, out, prev, sizeof out), err))
            return -1;
    return 0;
}

/* Frame f's shutter; without --frame or --frames the scene's own (as
 * written, or as --time/--shutter set it), with frames at a rate or at a
 * trajectory's poses alike. */
static int frame_shutter(const scene *s, const render_options *o, long long f, shutter *out, rr_error *err)
{
    *out = s->shut;
    return o->frames ? scene_frame_shutter(s, (int)f, out, err) : 0;
}

/* Every frame's shutter is one the scene has, within its camera
 * trajectory, and its camera fits the header, before the first frame is
 * rendered (a sequence must not stop after writing some frames); a
 * refused frame is named. */
static int check_frame_shutters(const scene *s, const render_options *o, rr_error *err)
{
    for (long long f = o->first_frame; f <= o->last_frame; f++) {
        shutter shut;
        char frame[128];
        scene_frame_label(s, f, o->frames, frame, sizeof frame);
        if (frame_shutter(s, o, f, &shut, err) || scene_check_shutter_in_trajectory(s, &shut, frame, err) ||
            scene_check_frame_camera(s, &shut, frame, err))
            return -1;
    }
    return 0;
}

/* Says so when <frames at="trajectory"> moves the shutter as given onto
 * the poses (the header records each frame's; a run must not be silent
 * about a shutter it did not render as written). */
static void note_moved_shutter(const scene *s, const render_options *o, const shutter *first)
{
    char note[512];
    if (o->frames && !o->quiet && scene_frame_shutter_note(s, first, o->first_frame, note, sizeof note))
        fprintf(stderr, "refrender: note: %s\n", note);
}

/* Frame f's scene, fs: the scene as it renders frame f, which owns the
 * frame's shutter (scene_for_shutter), refilled in place (the accel
 * built for it keeps pointing at it); the previous frame's is freed
 * first. */
static int next_frame(const scene *s, const render_options *o, long long f, scene *fs, rr_error *err)
{
    shutter shut;
    scene_for_shutter_free(fs, s);
    *fs = *s; /* (nothing of its own if the next call fails) */
    return frame_shutter(s, o, f, &shut, err) || scene_for_shutter(s, &shut, fs, err) ? -1 : 0;
}

/* One frame or a sequence, sharing the loaded models and their BVHs; only
 * the top levels are rebuilt for each frame's scene (accel_retime), and
 * each frame is rendered through the accel, the one way to its scene. */
int render_frames(const scene *s, const render_options *o, const char *cmdline, volatile sig_atomic_t *cancel,
                  rr_error *err)
{
    accel *acc;
    scene fs = *s;
    if (check_frame_outputs(s, o, err) || check_frame_shutters(s, o, err) ||
        next_frame(s, o, o->first_frame, &fs, err))
        return -1;
    note_moved_shutter(s, o, &fs.shut);
    accel_settings set = {s->epsilon, s->kernel_sigma, !o->no_static_reuse};
    if (accel_build(&fs, &set, &acc, err)) {
        scene_for_shutter_free(&fs, s);
        return -1;
    }
    int rc = 0;
    if (*cancel) /* the build cannot be stopped midway; it is not rendered */
        rc = rr_fail(err, "interrupted while building the BVH");
    /* 64-bit: --frame 2147483647 must not wrap around into more frames */
    for (long long f = o->first_frame; !rc && f <= o->last_frame; f++) {
        char out[PATH_MAX], prev[PATH_MAX];
        if (f > o->first_frame && (next_frame(s, o, f, &fs, err) || accel_retime(acc, &fs, err))) {
            rc = -1;
            break;
        }
        const char *preview = frame_names(o, f, out, prev, sizeof out);
        if (o->frames == 2 && !o->quiet)
            fprintf(stderr, "refrender: frame %lld: shutter [%g, %g] -> %s\n", f, fs.shut.open, fs.shut.close, out);
        rc = render_one(acc, f, o, cmdline, out, preview, cancel, err);
    }
    accel_free(acc);
    scene_for_shutter_free(&fs, s);
    return rc;
}
