/* Exact time integration, step 3 (exact.h): on each piece of fixed blended
 * set, the integral of a(t) (rgb(t), coverage(t)) by adaptive
 * Gauss-Kronrod, each node shaded as the sampled path shades one time. */
#include "render/exact_internal.h"

#include <stdio.h>

#include "render/integrator.h"
#include "scene/shade.h"

/* Components: a r, a g, a b, a coverage, and a itself (the normaliser). */
enum { NCOMP = 5 };

/* Exact time's own counters (exact_counters, below), by index. */
enum { EXACT_COUNTER_UNRESOLVED };

/* One blended candidate at time t, as accel's callbacks would report it
 * (same side rule, world normal, kernel weight). Returns 0 when the ray is
 * parallel to the splat's plane (no hit, as in splat_intersect). */
static int candidate_hit(const sample_ctx *c, int index, double t, surface_hit *h)
{
    const cand_info *info = &c->scr->info[index];
    const scene_object *o = &c->p->sc->objects[info->obj];
    const exact_kind_ops *row = exact_kind_row(o);
    const object_ray *r = exact_object_ray(c, info->obj, t);
    exact_crossing x;
    if (!row->cross(o, info, r, &x))
        return 0;
    vec3 wn = xform_normal(&r->xf, normal_facing_eye(x.normal, r->dir));
    double w = hit_weight(row->opaque, x.r2, accel_sigma(c->p->acc));
    *h = (surface_hit){(float)x.s, info->obj, info->prim, (float)w, (float)x.r2,
                       {(float)x.color.x, (float)x.color.y, (float)x.color.z}, {(float)wn.x, (float)wn.y, (float)wn.z}};
    return 1;
}

/* a(t) (rgb, coverage, 1) with the piece's blended set at time t. */
static void integrand(const sample_ctx *c, const piece *pc, double t, double out[NCOMP], int *overflow)
{
    const scene *s = c->p->sc;
    double w = shutter_weight(c->p->shut, t);
    kbuffer kb;
    kbuffer_reset(&kb, (float)accel_epsilon(c->p->acc));
    for (int k = 0; k < pc->count; k++) {
        surface_hit h;
        if (candidate_hit(c, c->scr->sets[pc->first + (size_t)k], t, &h))
            kbuffer_insert(&kb, &h);
    }
    *overflow |= kbuffer_overflowed(&kb);
    vec3 col = s->background;
    if (kb.count) {
        vec3 org, dir;
        exact_world_ray(c, t, &org, &dir);
        col = shade_hits(s, &kb, org, dir);
    }
    out[0] = w * col.x, out[1] = w * col.y, out[2] = w * col.z;
    out[3] = kb.count ? w : 0.0, out[4] = w;
}

/* Gauss-Kronrod 7-15 nodes on [-1, 1] (Kronrod's extension of the 7-point
 * Gauss-Legendre rule; the values of QUADPACK's qk15): xk[1], xk[3], xk[5]
 * and xk[7] = 0 are the Gauss nodes. */
static const double xk[8] = {0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
                             0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
                             0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
                             0.207784955007898467600689403773245, 0.0};
static const double wk[8] = {0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
                             0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
                             0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
                             0.204432940075298892414161999234649, 0.209482141084727828012999174891714};
static const double wg[4] = {0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
                             0.381830050505118944950369775488975, 0.417959183673469387755102040816327};

/* Both rules on [a, b]: returns the largest difference of their components. */
static double gauss_kronrod(const sample_ctx *c, const piece *pc, double a, double b, double kron[NCOMP],
                            int *overflow)
{
    double half = 0.5 * (b - a), mid = 0.5 * (a + b), gauss[NCOMP] = {0};
    for (int j = 0; j < NCOMP; j++)
        kron[j] = 0;
    for (int i = 0; i < 8; i++) {
        int nodes = i == 7 ? 1 : 2;
        for (int side = 0; side < nodes; side++) {
            double f[NCOMP];
            integrand(c, pc, mid + (side ? -1 : 1) * half * xk[i], f, overflow);
            for (int j = 0; j < NCOMP; j++) {
                kron[j] += wk[i] * f[j];
                if (i & 1)
                    gauss[j] += wg[i / 2] * f[j];
            }
        }
    }
    double diff = 0;
    for (int j = 0; j < NCOMP; j++) {
        kron[j] *= half, gauss[j] *= half;
        diff = fmax(diff, fabs(kron[j] - gauss[j]));
    }
    if (c->st)
        c->st->nodes += 15;
    exact_spend(c, 15 * ((uint64_t)pc->count + 1));
    return diff;
}

/* Adaptive: halves [a, b] until the two rules agree to EXACT_REL_TOL of the
 * piece's largest component (the weight integral is one, so colors near 0
 * are held to the same absolute accuracy), or the halves are shorter than
 * the time tolerance, or the midpoint rounds to an end (far from t = 0),
 * or the depth the partition allows is reached. Stops early when the
 * sample's budget is spent or it is interrupted (scratch status). */
static void integrate(const sample_ctx *c, const piece *pc, double a, double b, int depth, double sum[NCOMP],
                      int *overflow)
{
    double kron[NCOMP];
    double diff = gauss_kronrod(c, pc, a, b, kron, overflow);
    double scale = 0, mid = 0.5 * (a + b);
    for (int j = 0; j < NCOMP; j++)
        scale = fmax(scale, fabs(kron[j]));
    if (diff <= EXACT_REL_TOL * scale || b - a <= c->p->tol || !(a < mid && mid < b) || depth >= EXACT_MAX_DEPTH ||
        c->scr->status) {
        for (int j = 0; j < NCOMP; j++)
            sum[j] += kron[j];
        return;
    }
    integrate(c, pc, a, mid, depth + 1, sum, overflow);
    integrate(c, pc, mid, b, depth + 1, sum, overflow);
}

int exact_sample(const exact_plan *p, exact_scratch *scr, double x, double y, double rgba[4], exact_stats *st)
{
    sample_ctx c;
    if (exact_context(p, scr, x, y, st, &c))
        return EXACT_NO_MEMORY;
    int rc = exact_gather(&c);
    if (!rc)
        rc = exact_partition(&c);
    if (rc)
        return rc;
    double sum[NCOMP] = {0};
    int overflow = 0;
    for (size_t i = 0; i < scr->npieces && !scr->status; i++)
        integrate(&c, &scr->leaves[i], scr->leaves[i].a, scr->leaves[i].b, 0, sum, &overflow);
    if (scr->status)
        return scr->status;
    for (int j = 0; j < 4; j++)
        rgba[j] = sum[4] > 0 ? sum[j] / sum[4] : 0.0;
    if (st) {
        st->candidates += scr->nkeys;
        st->pieces += scr->npieces;
        st->overflows += (uint64_t)overflow;
    }
    return EXACT_OK;
}

/* ---- the exact-time integrator (integrator.h) ---- */

_Static_assert((int)EXACT_OK == (int)INTEGRATOR_OK && (int)EXACT_NO_MEMORY == (int)INTEGRATOR_NO_MEMORY &&
                   (int)EXACT_INTERRUPTED == (int)INTEGRATOR_INTERRUPTED,
               "exact time's statuses are the integrator seam's where they mean the same");

/* What exact time cannot integrate, refused before any work. */
static int exact_check(const integrator_context *ctx, rr_error *err)
{
    if (exact_check_blur_space(ctx->rs->blur, err))
        return -1;
    if (ctx->sc->shut.rolling.kind != ROLLING_OFF)
        return rr_fail(err, "exact time integration does not integrate a rolling shutter (each line its own "
                            "window): use sampled time");
    if (accel_has_gaussians(ctx->acc))
        return rr_fail(err, "exact time integration does not integrate Gaussian-splat objects: use sampled time");
    return 0;
}

/* The render's plan (exact.h), watching the render's cancel flag (ctx->cancel). */
static int exact_setup(integrator_context *ctx, rr_error *err)
{
    exact_plan *plan;
    if (exact_plan_new(ctx->acc, 1.0, ctx->cancel, &plan, err))
        return -1;
    ctx->plan = plan;
    return 0;
}

static void exact_teardown(integrator_context *ctx)
{
    exact_plan_free(ctx->plan);
    ctx->plan = NULL;
}

static void *exact_thread_new(const integrator_context *ctx, rr_arena *arena)
{
    (void)ctx;
    return exact_scratch_new(arena);
}

/* The mean over the batch's spatial positions of each one's exact time
 * average (the sampler's times and weights are not used). A batch with a
 * sample missing is no estimate: on failure it returns that sample's
 * status and counts nothing. */
static int exact_batch(void *thread, const integrator_context *ctx, const pixel_samples *ps, double est[4],
                       integrator_counts *c)
{
    exact_stats st = {0};
    exact_scratch_begin_batch(thread);
    for (int ch = 0; ch < 4; ch++)
        est[ch] = 0;
    for (int i = 0; i < ps->count; i++) {
        double rgba[4];
        int rc = exact_sample(ctx->plan, thread, ps->x[i], ps->y[i], rgba, &st);
        if (rc)
            return rc;
        for (int ch = 0; ch < 4; ch++)
            est[ch] += rgba[ch] / ps->count;
    }
    c->rays += (uint64_t)ps->count;
    c->overflows += st.overflows;
    c->counter[EXACT_COUNTER_UNRESOLVED] += st.unresolved;
    return EXACT_OK;
}

static void exact_thread_free(void *thread, integrator_counts *c)
{
    (void)c;
    exact_scratch_free(thread);
}

/* A sample past the candidate or evaluation bounds says the scene is
 * beyond exact time integration. */
static int exact_batch_failure(int status, int px, int py, rr_error *err)
{
    char why[128];
    exact_status_text(status, why, sizeof why);
    if (status == EXACT_NO_MEMORY || status == EXACT_EMBREE_ERROR)
        return rr_fail(err, "exact time integration at pixel (%d, %d): %s", px, py, why);
    return rr_fail(err,
                   "exact time integration at pixel (%d, %d): one spatial sample needs %s; exact time cannot "
                   "finish this scene in reasonable time: render it with sampled time (the default)",
                   px, py, why);
}

/* The share of the shutter, over all spatial samples, left in pieces too
 * short to certify (EXACT_TIME_TOL): their blended set is the one at their
 * middle. Said on stderr when above 100 times the tolerance, since every
 * coverage event leaves a few pieces of the tolerance's length. */
static void warn_unresolved(double share)
{
    if (share > 100 * EXACT_TIME_TOL)
        fprintf(stderr, "refrender: warning: exact time left %.3g of the shutter (over all spatial samples) in pieces "
                        "shorter than %g of it, taken with the blended set at their middle\n",
                share, EXACT_TIME_TOL);
}

static const counter_spec exact_counters[] = {
    [EXACT_COUNTER_UNRESOLVED] = {EXACT_UNRESOLVED_SHARE_ATTR, COUNTER_SHARE_PER_RAY, warn_unresolved},
};

const integrator_ops exact_integrator_row = {
    .id = "exact", .name = "exact time", .check = exact_check, .setup = exact_setup, .teardown = exact_teardown,
    .thread_new = exact_thread_new, .pixel_batch = exact_batch, .thread_free = exact_thread_free,
    .batch_failure = exact_batch_failure, .counters = exact_counters,
    .ncounters = (int)(sizeof exact_counters / sizeof *exact_counters),
};
