#include "render/surfel_integrator.h"

#include <stdlib.h>
#include <string.h>

#include "scene/shade.h"

void surfel_kbuffer_rgba(const scene *s, const kbuffer *kb, vec3 org, vec3 dir, double rgba[4])
{
    vec3 c = kb->count ? shade_hits(s, kb, org, dir) : s->background;
    rgba[0] = c.x, rgba[1] = c.y, rgba[2] = c.z, rgba[3] = kb->count ? 1.0 : 0.0;
}

int surfel_hits_rgba(const scene *s, const surface_hit *hits, int n, float epsilon, vec3 org, vec3 dir,
                     double rgba[4])
{
    kbuffer kb;
    kbuffer_reset(&kb, epsilon);
    for (int i = 0; i < n; i++)
        kbuffer_insert(&kb, &hits[i]);
    surfel_kbuffer_rgba(s, &kb, org, dir, rgba);
    return kbuffer_overflowed(&kb);
}

/* Per raster position (a still camera's world ray): its static hits from
 * accel, and their colour, shaded once and reused for every time at which
 * no moving object is hit. */
struct surfel_thread {
    double x, y;
    accel_ray ray;
    double rgba[4];
    int shaded;
};

surfel_thread *surfel_thread_new(void)
{
    surfel_thread *st = malloc(sizeof *st);
    if (st)
        surfel_thread_begin_batch(st);
    return st;
}

void surfel_thread_free(surfel_thread *st) { free(st); }

void surfel_thread_begin_batch(surfel_thread *st) { st->x = st->y = NAN; }

/* What a sample whose window is kb leaves for what is composited over it. */
static void fill_surface(surfel_sample *surf, vec3 org, vec3 dir, const kbuffer *kb)
{
    if (surf)
        surf->org = org, surf->dir = dir, surf->closest = kb->count ? kb->closest : INFINITY;
}

/* The colour of one sample whose hits are `result` (the cached static
 * colour when they are the position's static hits). */
static void still_camera_color(const scene *s, surfel_thread *st, const kbuffer *result, double rgba[4],
                               integrator_counts *c)
{
    c->overflows += (uint64_t)kbuffer_overflowed(result);
    int is_static = result == &st->ray.static_hits;
    if (is_static && st->shaded) {
        memcpy(rgba, st->rgba, sizeof st->rgba);
        return;
    }
    surfel_kbuffer_rgba(s, result, s->cam.position, st->ray.dir, rgba);
    if (is_static) {
        memcpy(st->rgba, rgba, sizeof st->rgba);
        st->shaded = 1;
    }
}

/* A still camera: samples at the same raster position share one world ray
 * (accel_ray), whose n <= ACCEL_PACKET times are traced together. */
static void samples_still_camera(surfel_thread *st, const integrator_context *ctx, double x, double y,
                                 const double *t, int n, double (*rgba)[4], surfel_sample *surf,
                                 integrator_counts *c)
{
    const scene *s = ctx->sc;
    if (x != st->x || y != st->y) {
        st->x = x, st->y = y, st->shaded = 0;
        accel_ray_begin(ctx->acc, s->cam.position, camera_ray_direction(&s->cam, x, y), &st->ray);
        c->static_traversals++;
    }
    kbuffer kbs[ACCEL_PACKET];
    const kbuffer *result[ACCEL_PACKET];
    accel_ray_trace_times(ctx->acc, &st->ray, t, n, kbs, result);
    for (int i = 0; i < n; i++) {
        still_camera_color(s, st, result[i], rgba[i], c);
        fill_surface(surf ? &surf[i] : NULL, s->cam.position, st->ray.dir, result[i]);
    }
}

/* A moving camera (thesis eq. 3.6): the sample has its own world ray. */
static void sample_own_ray(const integrator_context *ctx, double x, double y, double t, double rgba[4],
                           surfel_sample *surf, integrator_counts *c)
{
    vec3 org, dir;
    kbuffer kb;
    scene_camera_ray(ctx->sc, x, y, t, &org, &dir);
    accel_trace(ctx->acc, org, dir, t, &kb);
    c->static_traversals++;
    c->overflows += (uint64_t)kbuffer_overflowed(&kb);
    surfel_kbuffer_rgba(ctx->sc, &kb, org, dir, rgba);
    fill_surface(surf, org, dir, &kb);
}

int surfel_group(surfel_thread *st, const integrator_context *ctx, const pixel_samples *ps, int first,
                 double (*rgba)[4], surfel_sample *surf, integrator_counts *c)
{
    if (ctx->camera_moves) {
        sample_own_ray(ctx, ps->x[first], ps->y[first], ps->t[first], rgba[0], surf, c);
        return first + 1;
    }
    int end = first + 1;
    while (end < ps->count && end - first < ACCEL_PACKET && ps->x[end] == ps->x[first] &&
           ps->y[end] == ps->y[first])
        end++;
    samples_still_camera(st, ctx, ps->x[first], ps->y[first], ps->t + first, end - first, rgba, surf, c);
    return end;
}

/* ---- the sampled-surfel integrator (integrator.h) ---- */

static void *surfel_new(const integrator_context *ctx, rr_arena *arena)
{
    (void)ctx, (void)arena; /* its scratch is fixed-size (k-buffers): nothing grows */
    return surfel_thread_new();
}

static int surfel_group_fn(void *thread, const integrator_context *ctx, const pixel_samples *ps, int first,
                           double (*rgba)[4], integrator_counts *c)
{
    return surfel_group(thread, ctx, ps, first, rgba, NULL, c);
}

static int surfel_batch(void *thread, const integrator_context *ctx, const pixel_samples *ps, double est[4],
                        integrator_counts *c)
{
    surfel_thread_begin_batch(thread);
    return integrator_sampled_batch(thread, ctx, ps, surfel_group_fn, est, c);
}

static void surfel_free(void *thread, integrator_counts *c)
{
    (void)c;
    surfel_thread_free(thread);
}

const integrator_ops surfel_integrator_row = {
    .id = "surfels", .name = "sampled surfels", .thread_new = surfel_new, .pixel_batch = surfel_batch,
    .thread_free = surfel_free,
};
