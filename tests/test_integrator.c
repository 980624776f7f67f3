/* The integrator seam (render/integrator.h): a fourth integrator, defined
 * here alone, plugs into render_image with one line in a table of rows,
 * with no edit to render.c, render.h or film.h. Its answers are known
 * without our renderer: with the point filter every sample of pixel
 * (px, py) lies at its centre, so a toy estimate of (x / W, y / H) is
 * exactly the centre's; its setup, check, status and counts are its own,
 * its two counters too (summed by the loop, written by output.h's
 * output_counter_attrs without a line about them anywhere else). */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "io/output.h"
#include "render/integrator.h"
#include "render/render.h"
#include "scenexml/scene_xml.h"

enum { W = 16, H = 16, TOY_FAILED = -7, FAIL_X = 5, FAIL_Y = 3 };
enum { TOY_COUNTER_ONE, TOY_COUNTER_COLUMN }; /* the toy's counters, by index (toy_counters) */

static const char *const EMPTY_SCENE =
    "<scene><camera position='0 0 0' lookat='0 0 -1' up='0 1 0' fov='20' width='16' height='16'/>"
    "<shutter open='2' close='5'/>"
    "<object><pointModel><splat center='0 0 -10' normal='0 0 1' radius='0.1' color='1 1 1'/>"
    "</pointModel></object></scene>";

/* The toy's per-render plan: its estimate's green channel, and whether its
 * batch at (FAIL_X, FAIL_Y) fails (from toy_fails at setup). */
typedef struct {
    double green;
    int fail;
} toy_plan;
static int toy_fails, toy_setups, toy_teardowns;
static int toy_arena_mallocs; /* most chunks a worker's arena took */
static pthread_mutex_t toy_lock = PTHREAD_MUTEX_INITIALIZER;

typedef struct {
    rr_arena *arena;
} toy_thread;

/* The toy refuses a crop window (any rule of its own would do). */
static int toy_check(const integrator_context *ctx, rr_error *err)
{
    return ctx->rs->crop_x1 > 0 ? rr_fail(err, "toy: no crop window") : 0;
}

static int toy_setup(integrator_context *ctx, rr_error *err)
{
    toy_plan *p = malloc(sizeof *p);
    if (!p)
        return rr_fail(err, "toy: out of memory");
    p->green = 0.25, p->fail = toy_fails;
    ctx->plan = p;
    toy_setups++;
    return 0;
}

static void toy_teardown(integrator_context *ctx)
{
    free(ctx->plan);
    ctx->plan = NULL;
    toy_teardowns++;
}

static void *toy_thread_new(const integrator_context *ctx, rr_arena *arena)
{
    (void)ctx;
    toy_thread *t = malloc(sizeof *t);
    if (t)
        t->arena = arena;
    return t;
}

/* (x / W, plan's green, y / H, 1): the mean of the samples' raster
 * positions, all at the pixel's centre with the point filter. Each batch
 * takes 4 KiB of the arena: without the loop's reset after every batch a
 * worker's 64 KiB first chunk would not hold its hundreds of batches. */
static int toy_batch(void *thread, const integrator_context *ctx, const pixel_samples *ps, double est[4],
                     integrator_counts *c)
{
    toy_thread *t = thread;
    const toy_plan *p = ctx->plan;
    if (!rr_arena_alloc(t->arena, 4096, 16))
        return INTEGRATOR_NO_MEMORY;
    double x = 0, y = 0;
    for (int i = 0; i < ps->count; i++)
        x += ps->x[i], y += ps->y[i];
    x /= ps->count, y /= ps->count;
    if (p->fail && (int)x == FAIL_X && (int)y == FAIL_Y)
        return TOY_FAILED;
    est[0] = x / W, est[1] = p->green, est[2] = y / H, est[3] = 1;
    c->rays += (uint64_t)ps->count;
    double shutter = ctx->sc->shut.close - ctx->sc->shut.open;
    c->counter[TOY_COUNTER_COLUMN] += ps->count * shutter * x / W;
    c->counter[TOY_COUNTER_ONE] += ps->count * shutter;
    return INTEGRATOR_OK;
}

static void toy_thread_free(void *thread, integrator_counts *c)
{
    toy_thread *t = thread;
    (void)c;
    pthread_mutex_lock(&toy_lock);
    if ((int)t->arena->mallocs > toy_arena_mallocs)
        toy_arena_mallocs = (int)t->arena->mallocs;
    pthread_mutex_unlock(&toy_lock);
    free(t);
}

static int toy_batch_failure(int status, int px, int py, rr_error *err)
{
    return rr_fail(err, "toy: status %d at pixel (%d, %d)", status, px, py);
}

/* The toy's counters: per sample, its column's centre x / W and 1, each
 * times the shutter's length (a share of the shutter per ray, as exact
 * time's). The header values are then the mean column centre over the
 * image, 1/2 by its symmetry about the middle column line, and 1. */
static const counter_spec toy_counters[] = {
    [TOY_COUNTER_ONE] = {"toy:one", COUNTER_SHARE_PER_RAY, NULL},
    [TOY_COUNTER_COLUMN] = {"toy:meanColumn", COUNTER_SHARE_PER_RAY, NULL},
};

static const integrator_ops toy_integrator_row = {
    .id = "toy", .name = "toy", .check = toy_check, .setup = toy_setup, .teardown = toy_teardown,
    .thread_new = toy_thread_new, .pixel_batch = toy_batch, .thread_free = toy_thread_free,
    .batch_failure = toy_batch_failure, .counters = toy_counters, .ncounters = 2,
};

/* The built-in rows and the toy's: the one line that plugs it in. */
static const integrator_ops *const rows[] = {&surfel_integrator_row, &gaussian_integrator_row, &exact_integrator_row,
                                             &toy_integrator_row};

/* A 16x16 render of the toy row (found by id in `rows`): 2 batches of a
 * 2x2 grid at each pixel centre (point filter) on 2 threads. */
static int toy_render(image *img, int crop, const render_hooks *hooks, rr_error *err)
{
    scene s;
    accel *a;
    CHECK(scene_load_memory(EMPTY_SCENE, strlen(EMPTY_SCENE), "mem.xml", ".", &s, err) == 0);
    accel_settings set = {s.epsilon, s.kernel_sigma, 1};
    CHECK(accel_build(&s, &set, &a, err) == 0);
    render_settings rs = render_settings_default();
    rs.smp.grid = 2, rs.threads = 2, rs.batches = 2, rs.max_batches = 2;
    rs.filter = PIXEL_FILTER_POINT;
    rs.integrator = integrator_find(rows, (int)(sizeof rows / sizeof *rows), "toy");
    if (crop)
        rs.crop_x0 = 0, rs.crop_x1 = 8, rs.crop_y0 = 0, rs.crop_y1 = 8;
    volatile sig_atomic_t cancel = 0;
    CHECK(image_alloc(img, W, H) == 0);
    toy_setups = toy_teardowns = toy_arena_mallocs = 0;
    int rc = render_image(a, &rs, img, hooks, &cancel, err);
    accel_free(a);
    scene_free(&s);
    return rc;
}

TEST(integrator_rows_are_found_by_id)
{
    CHECK(integrator_find(rows, 4, "toy") == &toy_integrator_row);
    CHECK(integrator_find(rows, 4, "none") == NULL && integrator_find(rows, 4, NULL) == NULL);
    CHECK(integrator_named("exact") == &exact_integrator_row);
    CHECK(integrator_named("surfels") == &surfel_integrator_row);
    CHECK(integrator_named("gaussians") == &gaussian_integrator_row);
    CHECK(integrator_named("toy") == NULL); /* not built in: plugged in by the table above only */
}

/* Every pixel holds the toy's exact estimate of its centre, every ray is
 * counted once, the plan was set up and torn down once, and the loop reset
 * the worker's arena after each batch (one chunk enough for all). */
TEST(a_toy_integrator_plugs_into_the_loop_with_one_table_line)
{
    image img;
    rr_error e;
    toy_fails = 0;
    CHECK(toy_render(&img, 0, NULL, &e) == 0);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double mean[4], var[4];
            const pixel_state *p = &img.px[(size_t)y * W + x];
            film_resolve(p, mean, var);
            CHECK(p->batches == 2);
            CHECK_NEAR(mean[0], (x + 0.5) / W, 1e-15);
            CHECK_NEAR(mean[1], 0.25, 1e-15);
            CHECK_NEAR(mean[2], (y + 0.5) / H, 1e-15);
            CHECK_NEAR(mean[3], 1.0, 1e-15);
        }
    CHECK(img.rays == 2u * 4 * W * H);
    CHECK(img.counters.spec == toy_counters && img.counters.n == 2);
    static attr_list attrs; /* (330 KB) */
    output_counter_attrs(&attrs, &img.counters, img.rays, 5.0 - 2.0); /* the scene's shutter */
    printf("    toy:one %s, toy:meanColumn %s\n", attrs_get(&attrs, "toy:one"), attrs_get(&attrs, "toy:meanColumn"));
    CHECK(attrs.n == 2 && !strcmp(attrs_get(&attrs, "toy:one"), "1"));
    CHECK(!strcmp(attrs_get(&attrs, "toy:meanColumn"), "0.5"));
    CHECK(toy_setups == 1 && toy_teardowns == 1);
    printf("    most arena chunks a worker took: %d\n", toy_arena_mallocs);
    CHECK(toy_arena_mallocs == 1);
    image_free(&img);
}

/* The toy's own check refuses before any setup; its own status is put in
 * words by its own batch_failure, and its plan is still torn down. */
TEST(a_toy_integrators_check_and_failure_are_its_own)
{
    image img;
    rr_error e;
    toy_fails = 0;
    CHECK(toy_render(&img, 1, NULL, &e) == -1);
    CHECK(!strcmp(e.msg, "toy: no crop window"));
    CHECK(toy_setups == 0 && toy_teardowns == 0);
    image_free(&img);
    toy_fails = 1;
    CHECK(toy_render(&img, 0, NULL, &e) == -1);
    printf("    %s\n", e.msg);
    CHECK(!strcmp(e.msg, "toy: status -7 at pixel (5, 3)"));
    CHECK(toy_setups == 1 && toy_teardowns == 1);
    image_free(&img);
}

/* A checkpoint taken while the render runs holds the row's counters as far
 * as its rays (a resumed render reads them back, render_frames.c): the
 * toy's "one" counter adds the shutter's length, 3, per ray, so in every
 * checkpoint its sum is exactly 3 x rays (integers in doubles). Taken at
 * each of the coordinator's waits (every 1e-9 s), so each of the 2 rounds
 * has one, the second's after round 1's rays at least. */
static int toy_checkpoints, toy_checkpoints_with_rays, toy_checkpoints_wrong;

static int toy_checkpoint(void *user, const image *img, rr_error *err)
{
    (void)user, (void)err;
    toy_checkpoints++;
    toy_checkpoints_with_rays += img->rays > 0;
    toy_checkpoints_wrong += img->counters.n != 2 || img->counters.sum[TOY_COUNTER_ONE] != 3.0 * (double)img->rays;
    return 0;
}

TEST(a_checkpoint_holds_the_rows_counters_as_far_as_its_rays)
{
    image img;
    rr_error e;
    render_hooks hooks = {NULL, toy_checkpoint, NULL, 1e-9, NULL};
    toy_fails = toy_checkpoints = toy_checkpoints_with_rays = toy_checkpoints_wrong = 0;
    CHECK(toy_render(&img, 0, &hooks, &e) == 0);
    printf("    %d checkpoints, %d with rays, %d without the counters' sums\n", toy_checkpoints,
           toy_checkpoints_with_rays, toy_checkpoints_wrong);
    CHECK(toy_checkpoints_with_rays >= 1 && toy_checkpoints_wrong == 0);
    CHECK(img.counters.sum[TOY_COUNTER_ONE] == 3.0 * (double)img.rays); /* the final sums too */
    image_free(&img);
}
