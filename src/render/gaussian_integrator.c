/* The Gaussian integrator (gaussian_integrator.h): windows, chunks in order
 * of key floors, and compositing between them. */
#include "render/gaussian_integrator.h"

#include <stdlib.h>
#include <string.h>

#include "gaussians/gaussian_dynamic.h"
#include "render/surfel_integrator.h"

void gaussian_integrator_init(gaussian_integrator *g, rr_arena *arena)
{
    memset(g, 0, sizeof *g);
    if (!arena)
        rr_arena_init(&g->own, 0), arena = &g->own;
    g->arena = arena;
    gaussian_hits_init(&g->hits, arena);
}

void gaussian_integrator_reset(gaussian_integrator *g) { g->hits.count = g->hits.dropped = 0; }

void gaussian_integrator_begin_batch(gaussian_integrator *g)
{
    if (g->instant_cap_batch > g->instant_cap_reached)
        g->instant_cap_reached = g->instant_cap_batch;
    g->instant_cap_batch = 0;
    if (g->arena == &g->own) /* a worker's arena the render loop resets after each batch (integrator.h) */
        rr_arena_reset(g->arena);
    gaussian_hits_begin(&g->hits);
    g->rays = NULL, g->instants = NULL, g->rays_cap = 0; /* (one per object: a few) */
    g->candidates_count = 0;
    rr_arena_renew(g->arena, (void **)&g->candidates, &g->candidates_cap, sizeof *g->candidates);
    rr_arena_renew(g->arena, (void **)&g->candidate_order, &g->candidate_order_cap, sizeof *g->candidate_order);
}

void gaussian_integrator_free(gaussian_integrator *g)
{
    rr_arena_free(&g->own); /* (empty when the arena is a worker's) */
    memset(g, 0, sizeof *g);
}

/* ---- listing a window's candidates ------------------------------------ */

/* What the candidate callback needs: the object ray being traversed. */
typedef struct {
    gaussian_integrator *g;
    const scene_object *o;
    const gaussian_object_ray *r;
} listing;

static void evaluate(const listing *l, unsigned prim)
{
    gaussian_hit h;
    if (l->r->instant) { /* (no room for its state at the ray's time either) */
        l->g->hits.dropped++;
        return;
    }
    if (gaussian_hit_any(l->r->model, prim, l->o->order, &l->r->ray, &h)) {
        h.obj = l->r->obj;
        gaussian_hits_add(&l->g->hits, &h);
    }
}

/* Every Gaussian the ray passes is listed (cull_candidates and
 * evaluate_window take them after the traversal). Listing first lets the
 * cull prefetch their loads a few ahead (a prefetch here too, a traversal
 * ahead, measured 1-9% slower on the benchmark-scale view:
 * src/bench/BENCH.md). */
static void list_candidate(void *user, unsigned prim)
{
    const listing *l = user;
    gaussian_integrator *g = l->g;
    if (rr_arena_grow(g->arena, (void **)&g->candidates, &g->candidates_cap, g->candidates_count + 1, sizeof *g->candidates)) {
        evaluate(l, prim); /* no room to list it: evaluated at once, as listed ones are */
        return;
    }
    g->candidates[g->candidates_count++].prim = prim;
}

static void cull_candidates(const listing *l, size_t first, unsigned ray)
{
    gaussian_integrator *g = l->g;
    size_t n = g->candidates_count - first;
    if (n) /* (none listed yet: no array to offset) */
        g->candidates_count = first + gaussian_cull_candidates(l->r->model, &l->r->ray, g->candidates + first, n, ray);
}

/* Room for n Gaussians in an instant model: its arrays grow together
 * (rr_arena_grow each from the shared capacity, which moves only when all have);
 * a new one (after a reset) at once to the largest capacity an instant
 * reached (rr_arena_renew's reason). */
static int instant_room(rr_arena *a, gaussian_instant *in, size_t n, size_t reached)
{
    if (!in->cap && n < reached)
        n = reached;
    size_t mean = in->cap, scale = in->cap, rotation = in->cap, opacity = in->cap, prim = in->cap;
    if (rr_arena_grow(a, (void **)&in->model.mean, &mean, n, 3 * sizeof *in->model.mean) ||
        rr_arena_grow(a, (void **)&in->model.scale, &scale, n, 3 * sizeof *in->model.scale) ||
        rr_arena_grow(a, (void **)&in->model.rotation, &rotation, n, 4 * sizeof *in->model.rotation) ||
        rr_arena_grow(a, (void **)&in->model.opacity, &opacity, n, sizeof *in->model.opacity) ||
        rr_arena_grow(a, (void **)&in->prim, &prim, n, sizeof *in->prim))
        return 0;
    in->cap = mean;
    return 1;
}

/* How far ahead an instant's loads are started (the Gaussians are spread
 * over a model far larger than the caches, as gaussian_prefetch_cull's). */
enum { INSTANT_PREFETCH_AHEAD = 8 };

/* A dynamic model's window: the candidates listed from `first` on
 * (Gaussians of model m) become the slots of the ray's instant model that
 * hold them at the ray's time, so that the cull and the kernels draw each
 * as the static Gaussian of its instant (gaussian_dynamic_instant_cull and _rest); their
 * hits go back to the Gaussian's own index (original_prim). Here the mean
 * and scale, all the cull reads; instantiate_kept adds the rest for the
 * candidates it keeps (most fail it: on a sphere of 20k, the instants'
 * full state before the cull took 45% of the render). A window's
 * candidates are evaluated before the next window's are listed, so the
 * slots are reused from window to window. With no room they are dropped,
 * as hits that find no memory are. */
static void instantiate_for_cull(gaussian_integrator *g, const gaussian_model *m, gaussian_object_ray *r, size_t first)
{
    gaussian_instant *in = r->instant;
    size_t n = g->candidates_count - first;
    in->model.count = 0;
    if (!instant_room(g->arena, in, n, g->instant_cap_reached)) {
        g->hits.dropped += n;
        g->candidates_count = first;
        return;
    }
    if (in->cap > g->instant_cap_batch)
        g->instant_cap_batch = in->cap;
    for (size_t k = 0; k < n; k++) {
        gaussian_candidate *c = &g->candidates[first + k];
        if (k + INSTANT_PREFETCH_AHEAD < n)
            gaussian_dynamic_prefetch_cull(m, c[INSTANT_PREFETCH_AHEAD].prim);
        gaussian_dynamic_instant_cull(m, c->prim, r->time, &in->model, k);
        in->prim[k] = c->prim;
        c->prim = (unsigned)k;
    }
    in->model.count = n;
}

/* The rotation and opacity of the candidates the cull kept from `first` on. */
static void instantiate_kept(const gaussian_integrator *g, const gaussian_model *m, gaussian_object_ray *r,
                             size_t first)
{
    gaussian_instant *in = r->instant;
    for (size_t k = first; k < g->candidates_count; k++) {
        if (k + INSTANT_PREFETCH_AHEAD < g->candidates_count)
            gaussian_dynamic_prefetch_rest(m, in->prim[g->candidates[k + INSTANT_PREFETCH_AHEAD].prim]);
        unsigned slot = g->candidates[k].prim;
        gaussian_dynamic_instant_rest(m, in->prim[slot], r->time, &in->model, slot);
    }
}

/* The index in the object's model of a hit's Gaussian, which is the
 * index in the ray's instant model for a dynamic one. */
static inline unsigned original_prim(const gaussian_object_ray *r, unsigned prim)
{
    return r->instant ? r->instant->prim[prim] : prim;
}

/* A hit of object o's model found by ray r, as o's own: its object, its
 * Gaussian's index there (original_prim), and for a dynamic model the
 * direction its kind sees the colour along (4DGS: from the camera to the
 * canonical mean; the instant's is the moved mean's:
 * gaussian_dynamic_view_dir). */
static inline void own_hit(const gaussian_object_ray *r, const scene_object *o, gaussian_hit *h)
{
    h->obj = r->obj, h->prim = original_prim(r, h->prim);
    const gaussian_model *m = &o->gaussians;
    if (m->dynamic)
        gaussian_dynamic_view_dir(m, h->prim, r->ray.eye, h->dir);
}

/* Lists and culls (cull_candidates) the Gaussians of object ray `ray`
 * whose boxes its stretch [t0, t1) meets. The traversal's stretch is wider
 * by the pad: a hit's box holds a point of the ray within that of the hit
 * (gaussian_traversal_pad). */
static void list_window(const scene *s, const accel *a, gaussian_integrator *g, unsigned ray, double t0, double t1)
{
    gaussian_object_ray *r = &g->rays[ray];
    r->ray.tmin = t0, r->ray.tmax = t1;
    listing l = {g, &s->objects[r->obj], r};
    double pad = r->pad + 1e-6 * t1;
    size_t first = g->candidates_count;
    accel_gaussian_candidates(a, r->obj, r->ray.org, r->ray.dir, t0 - pad, t1 + pad, list_candidate, &l);
    if (r->instant)
        instantiate_for_cull(g, &l.o->gaussians, r, first);
    cull_candidates(&l, first, ray);
    if (r->instant)
        instantiate_kept(g, &l.o->gaussians, r, first);
}

/* ---- evaluating a window's candidates ---------------------------------- */

static void evaluate_kept(const scene *s, gaussian_integrator *g, const gaussian_candidate *k)
{
    const gaussian_object_ray *r = &g->rays[k->ray];
    const scene_object *o = &s->objects[r->obj];
    gaussian_hit hit;
    if (gaussian_hit_after_cull(r->model, k->prim, o->order, &r->ray, k->p, &hit)) {
        own_hit(r, o, &hit);
        gaussian_hits_add(&g->hits, &hit);
    }
}

/* evaluate_kept on the n candidates cand[order[k]] in turn, four at a time
 * where four in a row share a ray (gaussian_hits_after_cull4). */
static void evaluate_chunk(const scene *s, gaussian_integrator *g, const gaussian_candidate *cand,
                           const uint64_t *order, size_t n)
{
    size_t k = 0;
    while (k < n) {
        const gaussian_candidate *c[4];
        for (int j = 0; j < 4 && k + (size_t)j < n; j++)
            c[j] = &cand[(uint32_t)order[k + (size_t)j]];
        if (k + 4 > n || c[1]->ray != c[0]->ray || c[2]->ray != c[0]->ray || c[3]->ray != c[0]->ray) {
            evaluate_kept(s, g, c[0]);
            k++;
            continue;
        }
        const gaussian_object_ray *r = &g->rays[c[0]->ray];
        const scene_object *o = &s->objects[r->obj];
        unsigned prim[4] = {c[0]->prim, c[1]->prim, c[2]->prim, c[3]->prim};
        vec3 p[4] = {c[0]->p, c[1]->p, c[2]->p, c[3]->p};
        gaussian_hit hit[4];
        int found = gaussian_hits_after_cull4(r->model, prim, o->order, &r->ray, p, hit);
        for (int j = 0; j < 4; j++)
            if (found >> j & 1) {
                own_hit(r, o, &hit[j]);
                gaussian_hits_add(&g->hits, &hit[j]);
            }
        k += 4;
    }
}

/* The window's kept candidates in order of their key floors, finished a
 * prefix at a time (`order`: room for 3n words): the evaluation stops
 * where the transmittance is spent, most often a third of the way in. */
static void order_by_key_floor(const gaussian_candidate *cand, size_t n, uint64_t *order, rr_lazy_sort *sorted)
{
    for (size_t k = 0; k < n; k++)
        order[k] = (uint64_t)rr_float_order_bits(cand[k].key_floor) << 32 | (uint64_t)k;
    rr_lazy_sort_begin(sorted, order, order + n, n);
}

/* Room to order n candidates (3n words), if it can be had. */
static int order_room(gaussian_integrator *g, size_t n)
{
    return n <= SIZE_MAX / 3 &&
           !rr_arena_grow(g->arena, (void **)&g->candidate_order, &g->candidate_order_cap, 3 * n,
                          sizeof *g->candidate_order);
}

/* Evaluates the window's kept candidates EVALUATION_CHUNK at a time in
 * order of their key floors, compositing after each chunk the hits whose
 * keys lie below every floor left (and final_below: the later windows').
 * A ray that crosses a surface spends its transmittance a few thousandths
 * of a unit into it, and a window wide enough to reach the surface held
 * hits up to 0.05 beyond that (on make bench's sphere 58 of the 91 hits
 * a ray evaluated were never composited). The same hits are composited in
 * the same order: no hit is composited while a candidate whose key can be
 * smaller waits. */
enum { EVALUATION_CHUNK = 16 };
static void evaluate_window(const scene *s, const gaussian_model *const *models, gaussian_integrator *g,
                            gaussian_blend *blend, double final_below)
{
    size_t n = g->candidates_count;
    const gaussian_candidate *cand = g->candidates;
    if (n <= EVALUATION_CHUNK || !order_room(g, n)) { /* (no room to order them: all at once) */
        for (size_t k = 0; k < n; k++)
            evaluate_kept(s, g, &cand[k]);
        gaussian_blend_hits(blend, &g->hits, models, final_below);
        return;
    }
    rr_lazy_sort sorted;
    order_by_key_floor(cand, n, g->candidate_order, &sorted);
    for (size_t from = 0; from < n && !blend->done; from += EVALUATION_CHUNK) {
        size_t to = n - from < EVALUATION_CHUNK ? n : from + EVALUATION_CHUNK;
        rr_lazy_sort_through(&sorted, to < n ? to + 1 : n); /* the chunk, and the floor after it */
        evaluate_chunk(s, g, cand, g->candidate_order + from, to - from);
        double below = to < n ? cand[(uint32_t)g->candidate_order[to]].key_floor : INFINITY;
        if (below > -INFINITY) /* (else nothing can be composited yet) */
            gaussian_blend_hits(blend, &g->hits, models, rr_fmin(below, final_below));
    }
}

/* ---- the sample -------------------------------------------------------- */

/* The instant model of a dynamic model m: m's kind, formation and rules
 * over the instant's own arrays. */
static void instant_of(gaussian_instant *in, const gaussian_model *m)
{
    gaussian_model arrays = in->model;
    in->model = *m;
    in->model.count = 0, in->model.dynamic = NULL, in->model.sh = NULL;
    in->model.mean = arrays.mean, in->model.scale = arrays.scale;
    in->model.rotation = arrays.rotation, in->model.opacity = arrays.opacity;
}

/* The sample's ray in Gaussian object obj's space, with the stretch
 * [enter, exit] where it can meet it (its swept sphere); a dynamic model's
 * is evaluated through `instant`. */
static void object_ray(const scene *s, const accel *a, const gaussian_sample *smp, unsigned obj,
                       gaussian_object_ray *r, gaussian_instant *instant)
{
    const scene_object *o = &s->objects[obj];
    r->time = smp->time, r->model = &o->gaussians, r->instant = NULL;
    if (o->gaussians.dynamic) {
        instant_of(instant, &o->gaussians);
        r->model = &instant->model, r->instant = instant;
    }
    xform xf = accel_object_at(a, obj, smp->time);
    gaussian_ray_init(&r->ray, smp->view, &xf, smp->x, smp->y, smp->org, smp->dir);
    if (s->sh_eye_fixed) /* gsplat's rolling shutter: one SH origin for the frame (scene_for_shutter) */
        r->ray.eye = xform_inverse_point(&xf, s->sh_eye);
    vec3 centre;
    double radius, largest = accel_gaussian_largest_scale(a, obj);
    accel_object_swept_sphere(a, obj, &centre, &radius);
    double along = v3_dot(v3_sub(centre, smp->org), smp->dir);
    r->lead = gaussian_key_lead(&o->gaussians, o->order, largest, r->ray.depth_per_t);
    r->pad = gaussian_traversal_pad(&o->gaussians, largest, r->ray.depth_per_t);
    /* a 2D hit can lie the pad beyond where its box (inside the sphere) holds the ray */
    r->obj = obj, r->enter = fmax(0.0, along - radius - r->pad), r->exit = along + radius + r->pad;
}

/* The sample's ray in each Gaussian object whose swept bounds it meets;
 * returns how many. */
static size_t object_rays(const scene *s, const accel *a, const gaussian_sample *smp, gaussian_integrator *g)
{
    unsigned count;
    const unsigned *objects = accel_gaussian_objects(a, &count);
    /* (the two grow alike from the shared capacity, which moves only when both have) */
    size_t rays = g->rays_cap, instants = g->rays_cap;
    if (rr_arena_grow(g->arena, (void **)&g->rays, &rays, count, sizeof *g->rays) ||
        rr_arena_grow(g->arena, (void **)&g->instants, &instants, count, sizeof *g->instants))
        return g->hits.dropped++, 0; /* out of memory: the sample's Gaussians are dropped, and counted so */
    if (instants > g->rays_cap) /* new instants hold no arrays yet */
        memset(g->instants + g->rays_cap, 0, (instants - g->rays_cap) * sizeof *g->instants);
    g->rays_cap = instants;
    size_t n = 0;
    for (unsigned k = 0; k < count; k++)
        if (accel_ray_meets_object(a, objects[k], smp->org, smp->dir)) {
            object_ray(s, a, smp, objects[k], &g->rays[n], &g->instants[n]);
            n++;
        }
    return n;
}

/* Windows start at 1/64 of the stretch the objects span and double while
 * they hold few hits: a few traversals for a ray through empty space, and
 * no evaluation far behind the hits that spend the transmittance. */
enum { WINDOW_FRACTION = 64, WINDOW_FEW_HITS = 16 };

void gaussian_integrate(const scene *s, const accel *a, const gaussian_sample *smp, double tmax, gaussian_integrator *g,
                        gaussian_blend *blend)
{
    size_t n = object_rays(s, a, smp, g);
    blend->time = smp->time; /* (a 4DGS colour's time) */
    double start = INFINITY, end = 0, lead = 0;
    for (size_t k = 0; k < n; k++) {
        start = fmin(start, g->rays[k].enter), end = fmax(end, g->rays[k].exit);
        lead = fmax(lead, g->rays[k].lead);
    }
    end = fmin(end, tmax);
    double width = (end - start) / WINDOW_FRACTION;
    const gaussian_model *const *models = accel_gaussian_models(a);
    for (double t0 = start; t0 < end && !blend->done;) {
        double t1 = end - t0 <= width ? end : t0 + width;
        size_t before = g->hits.added;
        g->candidates_count = 0;
        for (size_t k = 0; k < n; k++)
            if (g->rays[k].enter < t1 && g->rays[k].exit >= t0)
                list_window(s, a, g, (unsigned)k, t0, t1);
        evaluate_window(s, models, g, blend, t1 < end ? t1 - lead : INFINITY);
        if (g->hits.added - before < WINDOW_FEW_HITS)
            width *= 2;
        t0 = t1;
    }
}

/* ---- the sampled-Gaussian integrator (integrator.h) ---- */

/* A thread's state: the surfels' (static reuse included) and the
 * Gaussians' scratch. */
typedef struct {
    surfel_thread *surfels;
    gaussian_integrator gaussians;
} gaussian_thread;

/* The Gaussian objects' hits on a sample's ray, composited over the
 * surfaces' colour (the nearest surface hides what is behind it: a
 * Gaussian behind an opaque surface is not seen). */
static void composite_over_surfaces(gaussian_thread *th, const integrator_context *ctx, double x, double y, double t,
                                    const surfel_sample *surf, double rgba[4])
{
    camera_view moved;
    const camera_view *view = &ctx->rest_view;
    if (ctx->camera_moves)
        scene_camera_view(ctx->sc, t, &moved), view = &moved;
    gaussian_integrator *g = &th->gaussians;
    gaussian_integrator_reset(g);
    gaussian_blend blend;
    gaussian_blend_init(&blend);
    gaussian_sample smp = {view, x, y, surf->org, surf->dir, t};
    gaussian_integrate(ctx->sc, ctx->acc, &smp, surf->closest, g, &blend);
    /* out of memory, not a full k-buffer: counted apart (a sample with
     * both was counted twice, and warned of as too many hits) */
    g->short_samples += g->hits.dropped > 0;
    vec3 rgb = gaussian_blend_over(&blend, v3(rgba[0], rgba[1], rgba[2]));
    int surface = isfinite(surf->closest);
    rgba[0] = rgb.x, rgba[1] = rgb.y, rgba[2] = rgb.z;
    rgba[3] = surface ? 1.0 : 1.0 - blend.T;
}

static void *gaussian_new(const integrator_context *ctx, rr_arena *arena)
{
    (void)ctx;
    gaussian_thread *th = malloc(sizeof *th);
    if (!th)
        return NULL;
    gaussian_integrator_init(&th->gaussians, arena);
    if (!(th->surfels = surfel_thread_new())) {
        free(th);
        return NULL;
    }
    return th;
}

/* The surfels' group (static reuse for a still camera), then each sample's
 * Gaussians over it. */
static int gaussian_group_fn(void *thread, const integrator_context *ctx, const pixel_samples *ps, int first,
                             double (*rgba)[4], integrator_counts *c)
{
    gaussian_thread *th = thread;
    surfel_sample surf[ACCEL_PACKET];
    int end = surfel_group(th->surfels, ctx, ps, first, rgba, surf, c);
    for (int i = first; i < end; i++)
        composite_over_surfaces(th, ctx, ps->x[i], ps->y[i], ps->t[i], &surf[i - first], rgba[i - first]);
    return end;
}

static int gaussian_batch(void *thread, const integrator_context *ctx, const pixel_samples *ps, double est[4],
                          integrator_counts *c)
{
    gaussian_thread *th = thread;
    surfel_thread_begin_batch(th->surfels);
    gaussian_integrator_begin_batch(&th->gaussians);
    uint64_t short_before = th->gaussians.short_samples;
    int rc = integrator_sampled_batch(thread, ctx, ps, gaussian_group_fn, est, c);
    /* A sample that found no memory for some of its Gaussians was drawn
     * without them: its colour can be off by anything up to 1 (a ball of
     * 407 pixels once came out as background, exit 0, issue 56.1), far
     * beyond the batch's noise. The batch has no estimate and the render
     * fails, as the surfels' and exact time's do out of memory. */
    if (!rc && th->gaussians.short_samples > short_before)
        return INTEGRATOR_NO_MEMORY;
    return rc;
}

static void gaussian_free(void *thread, integrator_counts *c)
{
    gaussian_thread *th = thread;
    (void)c;
    surfel_thread_free(th->surfels);
    gaussian_integrator_free(&th->gaussians);
    free(th);
}

/* A sampled batch fails only so (gaussian_batch). */
static int gaussian_batch_failure(int status, int px, int py, rr_error *err)
{
    RR_DCHECK(status == INTEGRATOR_NO_MEMORY);
    (void)status;
    return rr_fail(err, "%s at pixel (%d, %d): out of memory for a sample's Gaussians (drawn without them it "
                        "could be off by its whole colour, far beyond the noise): give the render more memory "
                        "or fewer threads", gaussian_integrator_row.name, px, py);
}

const integrator_ops gaussian_integrator_row = {
    .id = "gaussians", .name = "sampled Gaussians", .thread_new = gaussian_new, .pixel_batch = gaussian_batch,
    .thread_free = gaussian_free, .batch_failure = gaussian_batch_failure,
};
