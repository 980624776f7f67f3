/* The culls (gaussian_hit.h): from a Gaussian's mean and scale alone, no
 * hit for certain, and the key floor of those kept; a traversal's
 * candidates four at a time in AVX2 lanes (the same bits as one at a time),
 * with their loads prefetched. */
#include "gaussians/gaussian_hit_internal.h"

/* The 2DGS cull of Gaussian i, its mean at camera-space p. */
int cull_2d(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    double pc[3] = {p.x, p.y, p.z};
    return cull_2d_double(r, filter_circle(m), pc, larger_scale(m, i));
}

/* The 3D rasterizers' cull of Gaussian i (cull_3d), its mean at
 * camera-space p. */
int cull_3d_raster(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    double pc[3] = {p.x, p.y, p.z};
    return cull_3d_double(r, raster_rules_of(gaussian_formation_of(m)), pc, larger_scale(m, i));
}

void gaussian_prefetch_cull(const gaussian_model *m, size_t i)
{
    __builtin_prefetch(&m->mean[3 * i]);
    __builtin_prefetch(&m->scale[3 * i]);
}

void gaussian_prefetch_hit(const gaussian_model *m, size_t i)
{
    __builtin_prefetch(&m->rotation[4 * i]);
    __builtin_prefetch(&m->opacity[i]);
}

void gaussian_prefetch_sh(const gaussian_model *m, size_t i)
{
    const float *sh = &m->sh[(size_t)3 * m->sh_coeffs * i];
    uintptr_t last = (uintptr_t)(sh + 3 * (size_t)m->sh_coeffs) - 1;
    for (uintptr_t line = (uintptr_t)sh & ~(uintptr_t)63; line <= last; line += 64) /* each line once */
        __builtin_prefetch((const void *)line);
}

int gaussian_cull(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 *p)
{
    *p = camera_mean(m, i, r);
    if (m->kind == GAUSSIAN_2D)
        return cull_2d(m, i, r, *p);
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        return 1; /* its test is the ray's closest approach: nothing cheaper */
    return cull_3d_raster(m, i, r, *p);
}

float gaussian_key_floor(const gaussian_model *m, size_t i, const gaussian_ray *r, vec3 p)
{
    /* rounding is monotone: a hit's key (float)t >= (float)floor for t >=
     * floor, and compositing takes keys strictly below it */
    if (m->kind == GAUSSIAN_2D) /* within 3.33 scales of the centre's depth (gaussian_traversal_pad) */
        return (float)key_floor_2d_double(r, p.z, larger_scale(m, i));
    if (gaussian_formation_of(m) == GAUSSIAN_FORMATION_3DGRT)
        return -INFINITY; /* the closest approach: not tied to the centre's depth */
    return (float)centre_key_double(r, p.z); /* the rasterizers' key is the centre's depth, computed alike */
}

/* Keeps cand[k] (k < n) that the cull passes, at the front, with p and
 * key floor (gaussian_cull_candidates). */
static size_t keep_culled(gaussian_candidate *cand, size_t kept, unsigned prim, vec3 p, float key_floor, unsigned ray)
{
    cand[kept] = (gaussian_candidate){p, key_floor, prim, ray};
    return kept + 1;
}

enum { PREFETCH_AHEAD = 8 };
#if RR_LANES
/* The candidates' culls and key floors four at a time in lanes (cull_2d_v4d,
 * cull_3d_v4d: the cull led the time of 2DGS rendering in a profile, a ray
 * culls about 190 candidates); returns how many it took (a multiple of
 * four), *kept advanced as keep_culled does. */
RR_LANES_TARGET static size_t cull_in_lanes(const gaussian_model *m, const gaussian_ray *r, gaussian_candidate *cand,
                                            size_t n, unsigned ray, size_t *kept)
{
    const raster_rules *rules = m->kind == GAUSSIAN_3D ? raster_rules_of(gaussian_formation_of(m)) : NULL;
    double circle = filter_circle(m);
    size_t k = 0;
    for (; k + 4 <= n; k += 4) {
        unsigned prim[4];
        const float *mu[4], *sc[4];
        for (int j = 0; j < 4; j++) {
            if (k + j + PREFETCH_AHEAD < n)
                gaussian_prefetch_cull(m, cand[k + j + PREFETCH_AHEAD].prim);
            prim[j] = cand[k + j].prim;
            mu[j] = &m->mean[3 * prim[j]], sc[j] = &m->scale[3 * prim[j]];
        }
        /* the lanes built in registers: doubles stored one by one and
         * loaded as a vector stalled on store forwarding (perf annotate) */
        v4d mean[3] = {v4d_gather(mu, 0), v4d_gather(mu, 1), v4d_gather(mu, 2)}, p[3], floor;
        v4d s = rules ? v4d_max(v4d_gather(sc, 0), v4d_max(v4d_gather(sc, 1), v4d_gather(sc, 2)))
                      : v4d_max(v4d_gather(sc, 0), v4d_gather(sc, 1)); /* larger_scale */
        camera_point_v4d(r->m, mean, p);
        int keep = v4l_bits(rules ? cull_3d_v4d(r, rules, p, s) : cull_2d_v4d(r, circle, p, s));
        floor = rules ? centre_key_v4d(r, p[2]) : key_floor_2d_v4d(r, p[2], s); /* gaussian_key_floor */
        v4f key_floor = __builtin_convertvector(floor, v4f);
        /* without a branch (whether a lane is kept is a coin toss): every
         * lane is written where the next kept one goes, at or below its own
         * slot, which the loop above has read */
        for (int j = 0; j < 4; j++)
            *kept = keep_culled(cand, *kept, prim[j], v3(p[0][j], p[1][j], p[2][j]), key_floor[j], ray) -
                    !(keep >> j & 1);
    }
    return k;
}
#endif

size_t gaussian_cull_candidates(const gaussian_model *m, const gaussian_ray *r, gaussian_candidate *cand, size_t n,
                                unsigned ray)
{
    size_t kept = 0, k = 0;
#if RR_LANES /* (3DGRT has no cull) */
    if (gaussian_formation_of(m) != GAUSSIAN_FORMATION_3DGRT && rr_lanes_available())
        k = cull_in_lanes(m, r, cand, n, ray, &kept);
#endif
    for (; k < n; k++) {
        if (k + PREFETCH_AHEAD < n)
            gaussian_prefetch_cull(m, cand[k + PREFETCH_AHEAD].prim);
        unsigned prim = cand[k].prim;
        vec3 p;
        if (gaussian_cull(m, prim, r, &p))
            kept = keep_culled(cand, kept, prim, p, gaussian_key_floor(m, prim, r, p), ray);
    }
    for (size_t j = 0; j < kept; j++) /* what their evaluation reads */
        gaussian_prefetch_hit(m, cand[j].prim);
    return kept;
}
