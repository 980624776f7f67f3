/* Exact time integration, steps 1 and 2 (exact.h): the plan of motion
 * bounds, candidate gathering and the certified partition of the shutter
 * into pieces of fixed blended set. Step 3 is in exact_integrate.c.
 *
 * Every bound below rests on how fast (object units per unit time) a point
 * of the sample's ray can move in the object's own space, where the splats
 * stand still: at most base + angular |X - center| (object_plan). Over a
 * piece of length h about its middle tm, every point X(t, s) = O(t) +
 * s D(t) of the ray near a candidate stays within delta of X(tm, s)
 * (reach_delta); the direction D moves by at most dir_rate h / 2. */
#include "render/exact_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- plan --------------------------------------------------------------- */

/* The part of the ray's depth range each candidate box covers: 32 depth
 * slices for each time slice (object_plan.time_slices). */
enum { BOX_DEPTH_SLICES = 32 };

/* W for the object (exact_internal.h). A world point Y seen in model
 * space, X = F^-1(Y), moves at (DF)^-1 (dY/dt - v_F(X)), where v_F is the
 * object's own motion (animation_motion_bound) and |(DF)^-1| <= 1 /
 * min_scale. The camera's part is bounded once for the depths the object
 * can be at (rest-pose ray points out to depth_hi). The direction
 * D = S^-1 R^T d turns at most at (turn + camera turn) / min_scale +
 * scale_rate / min_scale^2. */
static void object_speed(const exact_plan *p, const scene_object *o, object_plan *op)
{
    motion_bound m = animation_motion_bound(&o->anim, p->shut->open, p->shut->close);
    const motion_bound cam = p->camera_speed;
    double cam_reach = v3_len(v3_sub(p->sc->cam.position, cam.center)) + op->depth_hi;
    double camera = cam.linear + cam.angular * cam_reach;
    op->base = (m.linear + camera) / op->min_scale;
    op->angular = m.angular / op->min_scale;
    op->center = m.center;
    op->dir_rate = (m.turn + cam.turn) / op->min_scale + m.scale_rate / (op->min_scale * op->min_scale);
}

/* How far a point at distance dist from the center (in model space) can
 * move in time h/2: delta = (base + angular (dist + delta)) h / 2 (it may
 * drift delta farther out while moving), solved for delta. */
static double reach_delta(const object_plan *op, double dist, double h)
{
    double k = op->angular * h * 0.5;
    if (op->base == 0 && op->angular == 0)
        return 0.0;
    if (!(k < 0.5))
        return INFINITY;
    return (op->base + op->angular * dist) * h * 0.5 / (1.0 - k);
}

/* Depths along a ray from any camera position of the shutter at which the
 * object can be: the distance from the camera's swept box to the swept
 * sphere's center, plus or minus its radius. */
static void depth_range(const exact_plan *p, object_plan *op)
{
    vec3 c = op->swept_center, lo = p->camera_path.lo, hi = p->camera_path.hi;
    vec3 near = v3(fmin(fmax(c.x, lo.x), hi.x), fmin(fmax(c.y, lo.y), hi.y), fmin(fmax(c.z, lo.z), hi.z));
    vec3 far = v3(fabs(c.x - lo.x) > fabs(c.x - hi.x) ? lo.x : hi.x, fabs(c.y - lo.y) > fabs(c.y - hi.y) ? lo.y : hi.y,
                  fabs(c.z - lo.z) > fabs(c.z - hi.z) ? lo.z : hi.z);
    op->depth_lo = fmax(0.0, v3_len(v3_sub(c, near)) - op->swept_radius);
    op->depth_hi = v3_len(v3_sub(c, far)) + op->swept_radius;
}

/* Time slices of the candidate boxes: enough that a slice's turn k =
 * angular h / 2 stays at most 1/4 (reach_delta is finite only for k < 1/2,
 * and 1/(1 - k) inflates the boxes by at most 4/3); 0, meaning every
 * primitive is a candidate, past EXACT_MAX_TIME_SLICES or with no finite
 * bound. A fixed 16 slices once made fast spins (1000 degrees a shutter)
 * and steep scalings give infinite boxes, which Embree meets nowhere: the
 * object vanished from exact renders. */
static int time_slices_for(const exact_plan *p, const object_plan *op)
{
    double turn = op->angular * (p->shut->close - p->shut->open);
    if (!isfinite(op->base) || !isfinite(turn))
        return 0;
    double need = ceil(2.0 * turn);
    if (need > EXACT_MAX_TIME_SLICES)
        return 0;
    return need < EXACT_MIN_TIME_SLICES ? EXACT_MIN_TIME_SLICES : (int)need;
}

static void plan_object(exact_plan *p, unsigned i)
{
    const scene_object *o = &p->sc->objects[i];
    object_plan *op = &p->obj[i];
    accel_object_swept_sphere(p->acc, i, &op->swept_center, &op->swept_radius);
    op->min_scale = animation_min_scale(&o->anim, p->shut->open, p->shut->close);
    op->gathered = p->camera_moves || accel_object_moves(p->acc, i);
    depth_range(p, op);
    if (op->gathered) {
        object_speed(p, o, op);
        op->time_slices = time_slices_for(p, op);
    }
}

/* Times where a(t) has a kink or a jump (shutter_knots): the integrand is
 * split there. */
static int weight_breaks(exact_plan *p)
{
    p->breaks = malloc(SHUTTER_MAX_KNOTS * sizeof *p->breaks);
    if (!p->breaks)
        return -1;
    p->nbreaks = shutter_knots(p->shut, p->breaks);
    return 0;
}

int exact_plan_new(const accel *a, double box_scale, volatile sig_atomic_t *cancel, exact_plan **out,
                   rr_error *err)
{
    const scene *s = accel_scene(a);
    const shutter *shut = &s->shut;
    exact_plan *p = calloc(1, sizeof *p);
    if (!p)
        return rr_fail(err, "out of memory");
    p->sc = s, p->acc = a, p->shut = shut, p->box_scale = box_scale, p->cancel = cancel;
    p->tol = EXACT_TIME_TOL * (shut->close - shut->open);
    p->camera_moves = scene_camera_moves(s);
    aabb at_rest = {s->cam.position, s->cam.position};
    p->camera_path = animation_swept_bounds(&s->camera_motion, at_rest, shut->open, shut->close);
    p->camera_speed = animation_motion_bound(&s->camera_motion, shut->open, shut->close);
    p->obj = calloc((size_t)s->nobjects + 1, sizeof *p->obj);
    if (!p->obj || weight_breaks(p)) {
        exact_plan_free(p);
        return rr_fail(err, "out of memory");
    }
    for (int i = 0; i < s->nobjects; i++)
        plan_object(p, (unsigned)i);
    *out = p;
    return 0;
}


int exact_check_blur_space(blur_space b, rr_error *err)
{
    if (b != BLUR_SPACE_MODEL)
        return rr_fail(err, "--blur-space %s %s each instant's colour before the time average, which exact time "
                            "cannot do (it integrates colours over time): use sampled time",
                       blur_space_name(b), b == BLUR_SPACE_LINEAR ? "decodes" : "clamps");
    return 0;
}

void exact_status_text(int status, char *buf, size_t size)
{
    switch (status) {
    case EXACT_OK: snprintf(buf, size, "ok"); break;
    case EXACT_NO_MEMORY: snprintf(buf, size, "out of memory"); break;
    case EXACT_INTERRUPTED: snprintf(buf, size, "interrupted"); break;
    case EXACT_TOO_MANY_CANDIDATES:
        snprintf(buf, size, "more than %d candidate splats (EXACT_MAX_CANDIDATES)", EXACT_MAX_CANDIDATES);
        break;
    case EXACT_TOO_COSTLY:
        snprintf(buf, size, "more than %.3g evaluations (EXACT_MAX_EVALUATIONS)", (double)EXACT_MAX_EVALUATIONS);
        break;
    default: snprintf(buf, size, "Embree failed while gathering candidates");
    }
}

int exact_spend(const sample_ctx *c, uint64_t n)
{
    exact_scratch *scr = c->scr;
    uint64_t before = scr->evaluations;
    scr->evaluations += n;
    if (!scr->status && scr->evaluations > EXACT_MAX_EVALUATIONS)
        scr->status = EXACT_TOO_COSTLY;
    if (!scr->status && before / EXACT_CANCEL_CHECK_EVERY != scr->evaluations / EXACT_CANCEL_CHECK_EVERY &&
        c->p->cancel && *c->p->cancel)
        scr->status = EXACT_INTERRUPTED;
    return scr->status;
}

void exact_plan_free(exact_plan *p)
{
    if (!p)
        return;
    free(p->obj);
    free(p->breaks);
    free(p);
}

exact_scratch *exact_scratch_new(rr_arena *arena)
{
    exact_scratch *scr = calloc(1, sizeof *scr);
    if (!scr)
        return NULL;
    if (!arena)
        rr_arena_init(&scr->own, 0), arena = &scr->own;
    scr->arena = arena;
    return scr;
}

void exact_scratch_begin_batch(exact_scratch *scr)
{
    if (scr->arena == &scr->own) /* a worker's arena the render loop resets after each batch (integrator.h) */
        rr_arena_reset(scr->arena);
    /* every array but prims (accel's own, malloc'd) was in the arena: each
     * taken anew at the capacity it reached (rr_arena_renew) */
    rr_arena *a = scr->arena;
    scr->nkeys = scr->npieces = scr->first_of_break = scr->nsets = 0;
    scr->evaluations = 0, scr->status = EXACT_OK;
    rr_arena_renew(a, (void **)&scr->keys, &scr->keys_cap, sizeof *scr->keys);
    rr_arena_renew(a, (void **)&scr->info, &scr->info_cap, sizeof *scr->info);
    rr_arena_renew(a, (void **)&scr->boxes, &scr->boxes_cap, sizeof *scr->boxes);
    rr_arena_renew(a, (void **)&scr->lists, &scr->lists_cap, sizeof *scr->lists);
    rr_arena_renew(a, (void **)&scr->evals, &scr->evals_cap, sizeof *scr->evals);
    rr_arena_renew(a, (void **)&scr->inherit, &scr->inherit_cap, sizeof *scr->inherit);
    rr_arena_renew(a, (void **)&scr->sorted, &scr->sorted_cap, sizeof *scr->sorted);
    rr_arena_renew(a, (void **)&scr->leaves, &scr->leaves_cap, sizeof *scr->leaves);
    rr_arena_renew(a, (void **)&scr->sets, &scr->sets_cap, sizeof *scr->sets);
    rr_arena_renew(a, (void **)&scr->ray_cache, &scr->ray_cache_cap, sizeof *scr->ray_cache);
}

void exact_scratch_free(exact_scratch *scr)
{
    if (!scr)
        return;
    free(scr->prims.ids);
    rr_arena_free(&scr->own); /* (empty when the arena is a worker's) */
    free(scr);
}

/* ---- the sample's rays ---------------------------------------------------- */

void exact_world_ray(const sample_ctx *c, double t, vec3 *org, vec3 *dir)
{
    scene_camera_ray(c->p->sc, c->x, c->y, t, org, dir);
}

/* Object obj's ray at time t, cached: candidates come object by object. */
const object_ray *exact_object_ray(const sample_ctx *c, unsigned obj, double t)
{
    object_ray *r = &c->scr->ray_cache[obj];
    if (r->valid && r->time == t)
        return r;
    vec3 org, dir;
    exact_world_ray(c, t, &org, &dir);
    r->xf = animation_at(&c->p->sc->objects[obj].anim, t);
    r->org = xform_inverse_point(&r->xf, org);
    r->dir = xform_inverse_vector(&r->xf, dir);
    r->world_org = org, r->world_dir = dir;
    r->time = t, r->valid = 1;
    return r;
}

/* ---- step 1: candidates --------------------------------------------------- */

static int push_key(exact_scratch *scr, unsigned obj, unsigned prim)
{
    if (rr_arena_grow(scr->arena, (void **)&scr->keys, &scr->keys_cap, scr->nkeys + 1, sizeof *scr->keys))
        return -1;
    scr->keys[scr->nkeys++] = (uint64_t)obj << 32 | prim;
    return 0;
}

/* Does the fixed world ray pass within the swept sphere (ahead of it)?
 * The sampled path's test (accel_ray_meets_swept_sphere). */
static int ray_meets_swept_sphere(const sample_ctx *c, unsigned obj)
{
    vec3 org, dir;
    exact_world_ray(c, c->p->shut->open, &org, &dir);
    return accel_ray_meets_swept_sphere(c->p->acc, obj, org, dir);
}

/* Boxes around the object-space ray over each time slice and depth slice:
 * every X(t, s) of the slice is within delta of the segment at the
 * slice's middle time, whose box is that of its two ends (and whose
 * farthest point from the center is an end). */
static unsigned candidate_boxes(const sample_ctx *c, unsigned obj, aabb *boxes)
{
    const exact_plan *p = c->p;
    const object_plan *op = &p->obj[obj];
    double t0 = p->shut->open, len = p->shut->close - t0, h = len / op->time_slices;
    unsigned n = 0;
    for (int k = 0; k < op->time_slices; k++) {
        const object_ray *r = exact_object_ray(c, obj, t0 + (k + 0.5) * h);
        for (int j = 0; j < BOX_DEPTH_SLICES; j++) {
            double s0 = op->depth_lo + (op->depth_hi - op->depth_lo) * j / BOX_DEPTH_SLICES;
            double s1 = op->depth_lo + (op->depth_hi - op->depth_lo) * (j + 1) / BOX_DEPTH_SLICES;
            vec3 e0 = v3_add(r->org, v3_scale(r->dir, s0)), e1 = v3_add(r->org, v3_scale(r->dir, s1));
            aabb b = aabb_empty();
            aabb_add_point(&b, e0);
            aabb_add_point(&b, e1);
            double dist = fmax(v3_len(v3_sub(e0, op->center)), v3_len(v3_sub(e1, op->center)));
            double delta = reach_delta(op, dist, h);
            RR_DCHECK(isfinite(delta)); /* time_slices_for keeps the turn per slice at most 1/4 */
            vec3 mid = v3_scale(v3_add(b.lo, b.hi), 0.5);
            vec3 half = v3_add(v3_scale(v3_sub(b.hi, b.lo), 0.5), v3(delta, delta, delta));
            half = v3_scale(half, p->box_scale);
            boxes[n++] = (aabb){v3_sub(mid, half), v3_add(mid, half)};
        }
    }
    return n;
}

/* Every primitive of the object: its motion has no usable bound. */
static int gather_all(const sample_ctx *c, unsigned obj)
{
    const scene_object *o = &c->p->sc->objects[obj];
    size_t count = scene_object_row(o)->count(o);
    if (c->scr->nkeys + count > EXACT_MAX_CANDIDATES)
        return EXACT_TOO_MANY_CANDIDATES;
    for (size_t i = 0; i < count; i++)
        if (push_key(c->scr, obj, (unsigned)i))
            return EXACT_NO_MEMORY;
    return EXACT_OK;
}

static int gather_moving(const sample_ctx *c, unsigned obj)
{
    exact_scratch *scr = c->scr;
    const object_plan *op = &c->p->obj[obj];
    if (!c->p->camera_moves && !ray_meets_swept_sphere(c, obj))
        return EXACT_OK;
    if (op->time_slices == 0)
        return gather_all(c, obj);
    size_t nboxes = (size_t)op->time_slices * BOX_DEPTH_SLICES;
    if (rr_arena_grow(scr->arena, (void **)&scr->boxes, &scr->boxes_cap, nboxes, sizeof *scr->boxes))
        return EXACT_NO_MEMORY;
    unsigned n = candidate_boxes(c, obj, scr->boxes);
    RR_DCHECK_LE(n, scr->boxes_cap);
    scr->prims.count = 0;
    int rc = accel_collide_boxes(c->p->acc, obj, scr->boxes, n, EXACT_MAX_CANDIDATES, &scr->prims);
    if (rc)
        return rc == ACCEL_COLLIDE_TOO_MANY ? EXACT_TOO_MANY_CANDIDATES
               : rc == ACCEL_COLLIDE_EMBREE ? EXACT_EMBREE_ERROR
                                            : EXACT_NO_MEMORY;
    if (scr->nkeys + scr->prims.count > EXACT_MAX_CANDIDATES)
        return EXACT_TOO_MANY_CANDIDATES;
    for (size_t i = 0; i < scr->prims.count; i++)
        if (push_key(scr, obj, scr->prims.ids[i]))
            return EXACT_NO_MEMORY;
    return EXACT_OK;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Objects that neither move nor see the camera move: their hits at any
 * time are accel's static hits of the one world ray. Those beyond the
 * static window are never blended: the closest hit can only come nearer. */
static int gather_static(const sample_ctx *c)
{
    accel_ray ray;
    accel_ray_begin(c->p->acc, c->p->sc->cam.position, c->dir0, &ray);
    for (int k = 0; k < ray.static_hits.count; k++) {
        const surface_hit *h = &ray.static_hits.hits[k];
        if (!c->p->obj[h->obj].gathered && push_key(c->scr, h->obj, h->prim))
            return -1;
    }
    return 0;
}

static void describe(const exact_plan *p, uint64_t key, cand_info *info)
{
    unsigned obj = (unsigned)(key >> 32), prim = (unsigned)key;
    const scene_object *o = &p->sc->objects[obj];
    info->obj = obj, info->prim = prim;
    exact_kind_row(o)->describe(o, prim, p->obj[obj].center, info);
}

/* The certificates' per-candidate constants (exact_internal.h). */
static int describe_candidates(const sample_ctx *c)
{
    exact_scratch *scr = c->scr;
    if (rr_arena_grow(scr->arena, (void **)&scr->info, &scr->info_cap, scr->nkeys + 1, sizeof *scr->info))
        return -1;
    for (size_t i = 0; i < scr->nkeys; i++)
        describe(c->p, scr->keys[i], &scr->info[i]);
    return 0;
}

int exact_gather(const sample_ctx *c)
{
    exact_scratch *scr = c->scr;
    scr->nkeys = 0;
    if (!c->p->camera_moves && gather_static(c))
        return EXACT_NO_MEMORY;
    for (int i = 0; i < c->p->sc->nobjects; i++) {
        int rc = c->p->obj[i].gathered ? gather_moving(c, (unsigned)i) : EXACT_OK;
        if (rc)
            return rc;
    }
    if (scr->nkeys > EXACT_MAX_CANDIDATES) /* static hits are at most KBUFFER_MAX-bounded, but count them too */
        return EXACT_TOO_MANY_CANDIDATES;
    if (scr->nkeys > 1)
        qsort(scr->keys, scr->nkeys, sizeof *scr->keys, cmp_u64);
    return describe_candidates(c) ? EXACT_NO_MEMORY : EXACT_OK;
}

int exact_candidates(const exact_plan *p, exact_scratch *scr, double x, double y)
{
    sample_ctx c;
    if (exact_context(p, scr, x, y, NULL, &c))
        return EXACT_NO_MEMORY;
    int rc = exact_gather(&c);
    return rc ? rc : (int)scr->nkeys;
}

void exact_candidate(const exact_scratch *scr, int i, unsigned *obj, unsigned *prim)
{
    *obj = scr->info[i].obj, *prim = scr->info[i].prim;
}

int exact_context(const exact_plan *p, exact_scratch *scr, double x, double y, exact_stats *st, sample_ctx *c)
{
    if (rr_arena_grow(scr->arena, (void **)&scr->ray_cache, &scr->ray_cache_cap, (size_t)p->sc->nobjects + 1, sizeof *scr->ray_cache))
        return -1;
    memset(scr->ray_cache, 0, ((size_t)p->sc->nobjects + 1) * sizeof *scr->ray_cache);
    scr->evaluations = 0, scr->status = EXACT_OK;
    c->p = p, c->scr = scr, c->x = x, c->y = y, c->st = st;
    c->dir0 = camera_ray_direction(&p->sc->cam, x, y);
    return 0;
}

/* ---- step 2: certified pieces -------------------------------------------- */

/* One candidate at the middle of [a, b]: its state, and whether that
 * state holds over the whole piece. */
static cand_eval evaluate_one(const sample_ctx *c, int index, double a, double b)
{
    const cand_info *info = &c->scr->info[index];
    const object_plan *op = &c->p->obj[info->obj];
    const scene_object *o = &c->p->sc->objects[info->obj];
    double h = b - a;
    const object_ray *r = exact_object_ray(c, info->obj, 0.5 * (a + b));
    double delta = reach_delta(op, info->reach, h);
    return exact_kind_row(o)->eval(o, info, r, delta, op->dir_rate * h * 0.5);
}

/* Evaluates list[0..n) on [a, b] into ev. A candidate whose state was
 * certain on the parent piece (inherited) keeps that evaluation: its depth
 * range holds on every part of the parent. */
static void evaluate(const sample_ctx *c, const int *list, const cand_eval *inherited, int n, double a, double b,
                     cand_eval *ev)
{
    exact_spend(c, (uint64_t)n);
    for (int i = 0; i < n; i++)
        ev[i] = inherited && inherited[i].sure ? inherited[i] : evaluate_one(c, list[i], a, b);
}

/* Re-evaluates the inherited hits on [a, b] itself: their depth ranges
 * shrink with the piece (for the window test and for the state at the
 * middle). */
static void refresh(const sample_ctx *c, const int *list, int n, double a, double b, cand_eval *ev)
{
    exact_spend(c, (uint64_t)n);
    for (int i = 0; i < n; i++)
        if (ev[i].hit)
            ev[i] = evaluate_one(c, list[i], a, b);
}

static int cmp_depth(const void *a, const void *b)
{
    double x = ((const cand_eval *)a)->s, y = ((const cand_eval *)b)->s;
    return (x > y) - (x < y);
}

/* With more hits in the window than the k-buffer holds, the nearest
 * KBUFFER_MAX are blended: their order must not change either. */
static int order_sure(const cand_eval *ev, const int *in, int m, cand_eval *tmp)
{
    for (int k = 0; k < m; k++)
        tmp[k] = ev[in[k]];
    qsort(tmp, (size_t)m, sizeof *tmp, cmp_depth);
    for (int k = 1; k < m; k++)
        if (!(tmp[k].s - tmp[k].sigma > tmp[k - 1].s + tmp[k - 1].sigma))
            return 0;
    return 1;
}

/* The epsilon window over the piece: the closest depth stays in [lo, hi];
 * a certain hit is in the window throughout if s + sigma <= lo + eps, out
 * of it throughout if s - sigma > hi + eps. A candidate whose coverage is
 * uncertain does not matter when it stays out of the window (behind a
 * certain hit by more than eps) whether it is hit or not. Fills set
 * (indices into ev) and returns 1 when the blended set is certain, 0 when
 * only depth ranges of certain hits were in doubt (tighter ranges may
 * settle it), -1 when a candidate's coverage matters and is uncertain. */
static int window_sure(const cand_eval *ev, int n, double eps, int *set, int *nset, cand_eval *tmp)
{
    double lo = INFINITY, hi = INFINITY;
    for (int i = 0; i < n; i++) {
        if (ev[i].sure && !ev[i].hit)
            continue;
        lo = fmin(lo, ev[i].s - ev[i].sigma);
        if (ev[i].sure)
            hi = fmin(hi, ev[i].s + ev[i].sigma);
    }
    *nset = 0;
    for (int i = 0; i < n; i++) {
        if (ev[i].sure && !ev[i].hit)
            continue;
        int out = ev[i].s - ev[i].sigma > hi + eps;
        if (!ev[i].sure && !out)
            return -1;
        if (ev[i].sure && ev[i].s + ev[i].sigma <= lo + eps)
            set[(*nset)++] = i;
        else if (!out)
            return 0;
    }
    return *nset <= KBUFFER_MAX || order_sure(ev, set, *nset, tmp);
}

/* The blended set at one time, for pieces too short to certify. */
static void window_at(const cand_eval *ev, int n, double eps, int *set, int *nset)
{
    double closest = INFINITY;
    for (int i = 0; i < n; i++)
        if (ev[i].hit)
            closest = fmin(closest, ev[i].s);
    *nset = 0;
    for (int i = 0; i < n; i++)
        if (ev[i].hit && ev[i].s <= closest + eps)
            set[(*nset)++] = i;
}

/* Appends the piece [a, b] with the blended set (candidate indices, in
 * increasing order), merged with the previous piece when the sets agree. */
static int emit_piece(exact_scratch *scr, double a, double b, const int *set, int n)
{
    /* never across a kink of a(t): Gauss-Kronrod needs it as a piece boundary */
    piece *last = scr->npieces > scr->first_of_break ? &scr->leaves[scr->npieces - 1] : NULL;
    if (last && last->b == a && last->count == n &&
        (n == 0 || !memcmp(scr->sets + last->first, set, (size_t)n * sizeof *set))) {
        last->b = b;
        return 0;
    }
    if (rr_arena_grow(scr->arena, (void **)&scr->leaves, &scr->leaves_cap, scr->npieces + 1, sizeof *scr->leaves) ||
        rr_arena_grow(scr->arena, (void **)&scr->sets, &scr->sets_cap, scr->nsets + (size_t)n, sizeof *scr->sets))
        return -1;
    if (n > 0) /* sets may still be unallocated (NULL) for empty sets */
        memcpy(scr->sets + scr->nsets, set, (size_t)n * sizeof *set);
    scr->leaves[scr->npieces++] = (piece){a, b, scr->nsets, n};
    scr->nsets += (size_t)n;
    return 0;
}

/* A piece's blended set as candidate indices (set holds indices into list). */
static void to_candidates(const int *list, int *set, int n)
{
    for (int k = 0; k < n; k++)
        set[k] = list[set[k]];
}

/* Can [a, b] be split? Not below the time tolerance, past the piece cap
 * or the depth the scratch holds, nor where its midpoint rounds to an end
 * (far from t = 0, ulp(t) exceeds the tolerance: a shutter at 1e7 once
 * split the same piece until the scratch overflowed). */
static int can_split(const exact_scratch *scr, double a, double b, double tol, int depth)
{
    double mid = 0.5 * (a + b);
    return b - a > tol && scr->npieces < EXACT_MAX_PIECES && depth < EXACT_MAX_DEPTH && a < mid && mid < b;
}

/* The piece [a, b] with a certain blended set, or one that cannot be split.
 * Returns 1 to split, else an EXACT_ status. */
static int settle(const sample_ctx *c, double a, double b, const int *list, int n, cand_eval *ev, int inherited,
                  int splittable)
{
    exact_scratch *scr = c->scr;
    int *set = scr->lists + (list - scr->lists) + n, nset = 0;
    double eps = accel_epsilon(c->p->acc);
    int window = window_sure(ev, n, eps, set, &nset, scr->sorted);
    if (window == 1) {
        to_candidates(list, set, nset);
        return emit_piece(scr, a, b, set, nset) ? EXACT_NO_MEMORY : EXACT_OK;
    }
    if (inherited && (window == 0 || !splittable)) { /* tighter depth ranges may settle the window */
        refresh(c, list, n, a, b, ev);
        return settle(c, a, b, list, n, ev, 0, splittable);
    }
    if (splittable)
        return 1;
    window_at(ev, n, eps, set, &nset);
    to_candidates(list, set, nset);
    if (c->st)
        c->st->unresolved += b - a;
    return emit_piece(scr, a, b, set, nset) ? EXACT_NO_MEMORY : EXACT_OK;
}

/* Splits [a, b] until every candidate's coverage and window membership is
 * certain on each piece. list (depth-first on the scratch stack, at
 * lists + top, with its inherited evaluations at inherit + top) holds the
 * candidates not yet certified absent; children get only those. Returns an
 * EXACT_ status. */
static int classify(const sample_ctx *c, double a, double b, int n, size_t top, int depth)
{
    exact_scratch *scr = c->scr;
    RR_DCHECK_LE(depth, EXACT_MAX_DEPTH);
    RR_DCHECK_LE(top + 2 * (size_t)n, scr->lists_cap); /* reserve_stack's room */
    const int *list = scr->lists + top;
    cand_eval *ev = scr->evals + top;
    int inherited = top > 0;
    evaluate(c, list, inherited ? scr->inherit + top : NULL, n, a, b, ev);
    if (scr->status)
        return scr->status;
    int rc = settle(c, a, b, list, n, ev, inherited, can_split(scr, a, b, c->p->tol, depth));
    if (rc <= 0)
        return rc ? rc : scr->status;
    int *child = scr->lists + top + (size_t)n, m = 0;
    cand_eval *child_ev = scr->inherit + top + (size_t)n;
    for (int i = 0; i < n; i++)
        if (!(ev[i].sure && !ev[i].hit)) { /* absent over [a, b]: absent over both halves */
            child_ev[m] = ev[i];
            child[m++] = list[i];
        }
    double mid = 0.5 * (a + b);
    rc = classify(c, a, mid, m, top + (size_t)n, depth + 1);
    return rc ? rc : classify(c, mid, b, m, top + (size_t)n, depth + 1);
}

/* Room on the scratch stack for the deepest recursion (EXACT_MAX_DEPTH,
 * can_split): each level keeps a list (and set) and evaluations of at most
 * all candidates, twice. */
static int reserve_stack(exact_scratch *scr)
{
    size_t need = (size_t)(EXACT_MAX_DEPTH + 2) * (scr->nkeys + 1) * 2;
    return rr_arena_grow(scr->arena, (void **)&scr->lists, &scr->lists_cap, need, sizeof *scr->lists) ||
           rr_arena_grow(scr->arena, (void **)&scr->evals, &scr->evals_cap, need, sizeof *scr->evals) ||
           rr_arena_grow(scr->arena, (void **)&scr->inherit, &scr->inherit_cap, need, sizeof *scr->inherit) ||
           rr_arena_grow(scr->arena, (void **)&scr->sorted, &scr->sorted_cap, scr->nkeys + 1, sizeof *scr->sorted);
}

int exact_partition(const sample_ctx *c)
{
    exact_scratch *scr = c->scr;
    scr->npieces = 0, scr->nsets = 0;
    if (reserve_stack(scr))
        return EXACT_NO_MEMORY;
    int n = (int)scr->nkeys;
    for (int i = 0; i < n; i++)
        scr->lists[i] = i;
    const exact_plan *p = c->p;
    for (int k = 0; k + 1 < p->nbreaks; k++) {
        scr->first_of_break = scr->npieces;
        int rc = classify(c, p->breaks[k], p->breaks[k + 1], n, 0, 0);
        if (rc)
            return rc;
    }
    return EXACT_OK;
}
