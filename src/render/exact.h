/* Exact time integration (--time-integration exact): the a(t)-weighted
 * average over the whole shutter of what one spatial sample position sees,
 * with no temporal sampling, so the only noise left is spatial.
 *
 * The thesis estimates the time integral of sec. 3.1 (eq. 3.3) by sampling
 * (sec. 4.5); here it is computed the way Gribel et al. resolve visibility
 * over time ("High-Quality Spatio-Temporal Rendering using Semi-Analytical
 * Visibility", SIGGRAPH 2011, ACM TOG 30(4)), but exactly and for
 * epsilon-blended splats:
 *  1. candidates: every splat (or sphere) the moving ray may meet during the
 *     shutter, from Embree's BVH of each object (accel_collide_boxes) with
 *     boxes around time slices of the object-space ray, padded by a bound on
 *     how fast that ray moves (animation_motion_bound);
 *  2. events: the shutter is split until, on each piece, every candidate is
 *     certified covered or not covered, and in or out of the epsilon window,
 *     for the whole piece (bounds on how far the hit point and the depth can
 *     move, below); pieces shorter than EXACT_TIME_TOL of the shutter are
 *     not split further;
 *  3. integration: on a piece the blended set is fixed and a(t) * color(t)
 *     is smooth: adaptive Gauss-Kronrod (7-15) to EXACT_REL_TOL, each node
 *     shaded exactly as the sampled path shades one time (kbuffer, shade_hits).
 * The result equals the expectation of the sampled path's time average at
 * the same spatial position. */
#ifndef RR_EXACT_H
#define RR_EXACT_H

#include <signal.h>
#include <stdint.h>

#include "accel/accel.h"
#include "core/arena.h"
#include "scene/scene.h"
#include "motion/shutter.h"
#include "render/render_settings.h"

/* A piece of the shutter shorter than this fraction of it is not split
 * further: its blended set is the one at its middle. The total time so
 * classified is reported (exact_stats.unresolved). */
#define EXACT_TIME_TOL 1e-9
/* Exact time's one counter (integrator.h, counters.h): that total time,
 * in the header as a share of the shutter per spatial sample. */
#define EXACT_UNRESOLVED_SHARE_ATTR "refrender:exactUnresolvedShare"
/* Gauss-Kronrod: a piece is split until the 7- and 15-point rules agree to
 * this fraction of the piece's largest integral (its weight integral or a
 * color's). */
#define EXACT_REL_TOL 1e-7

typedef struct exact_plan exact_plan;       /* per shutter; read-only, shared by threads */
typedef struct exact_scratch exact_scratch; /* per thread */

/* The plan for the scene accel traces (accel_scene), over its shutter.
 * box_scale: 1; tests shrink the candidate boxes with it to show that the
 * candidate test can fail. cancel: the flag render_image watches (NULL:
 * never cancelled), which a sample checks as it goes, so an interrupt
 * does not wait for a costly sample to end. */
int exact_plan_new(const accel *a, double box_scale, volatile sig_atomic_t *cancel, exact_plan **out,
                   rr_error *err);
void exact_plan_free(exact_plan *p);

/* A thread's scratch, its arrays in `arena` (NULL: an arena of its own),
 * which must outlive it; NULL when out of memory. */
exact_scratch *exact_scratch_new(rr_arena *arena);
/* A new batch, after the arena's reset (the render loop resets a
 * worker's; this one resets an arena of its own): the arrays of the
 * samples before are gone, and the next samples reuse the memory. */
void exact_scratch_begin_batch(exact_scratch *scr);
void exact_scratch_free(exact_scratch *scr);

typedef struct {
    uint64_t candidates;  /* splats and spheres gathered */
    uint64_t pieces;      /* pieces of fixed blended set integrated */
    uint64_t nodes;       /* integrand evaluations (shaded times) */
    uint64_t overflows;   /* samples where more than KBUFFER_MAX hits blended */
    double unresolved;    /* shutter time in pieces left at EXACT_TIME_TOL */
} exact_stats;

/* What exact_sample returns. A sample that did not finish gives no value:
 * its batch is not added (render.c), so no pixel holds a partial average. */
enum {
    EXACT_OK = 0,
    EXACT_NO_MEMORY = -1,
    EXACT_INTERRUPTED = -2,     /* *cancel became non-zero during the sample */
    EXACT_TOO_MANY_CANDIDATES = -3, /* more than EXACT_MAX_CANDIDATES */
    EXACT_TOO_COSTLY = -4,      /* more than EXACT_MAX_EVALUATIONS */
    EXACT_EMBREE_ERROR = -5,    /* rtcCollide reported an error */
};
/* Bounds on one spatial sample's work. Candidates cost about 9 KB of
 * scratch each (a list and two evaluations per split level); evaluations
 * (certificates and shaded nodes) take about 50 ns: 5e7 is seconds for one
 * sample, far beyond what an image of them can afford. A scene past either
 * is refused, naming the sample, rather than left running for hours. */
#define EXACT_MAX_CANDIDATES 32768
#define EXACT_MAX_EVALUATIONS 50000000ULL

/* Exact time integration with the blur space: refused (-1, err naming
 * --blur-space) for linear and clamped, whose change of each instant's
 * colour must come before the time average, while exact time integrates
 * colours over time first. One rule for the command line and the exact
 * integrator's check. */
int exact_check_blur_space(blur_space b, rr_error *err);

/* A one-line reason for a status other than EXACT_OK, into buf. */
void exact_status_text(int status, char *buf, size_t size);

/* The exact weighted time average of the color (rgb) and coverage (a) seen
 * through raster position (x, y): integral of a(t) rgba(t) over the
 * shutter divided by the integral of a(t). Returns an EXACT_ status. */
int exact_sample(const exact_plan *p, exact_scratch *scr, double x, double y, double rgba[4], exact_stats *st);

/* For tests: gathers the candidates for (x, y) into the scratch and
 * returns their count (< 0: an EXACT_ status); exact_candidate reads the i-th
 * as (object, primitive), object-major and sorted. */
int exact_candidates(const exact_plan *p, exact_scratch *scr, double x, double y);
void exact_candidate(const exact_scratch *scr, int i, unsigned *obj, unsigned *prim);

#endif
