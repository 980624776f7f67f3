/* See gaussian_hit_util.h. */
#include "gaussian_hit_util.h"

#include <math.h>
#include <stdlib.h>

#include "harness.h"

double rand_uniform(unsigned *state) { return (double)rand_r(state) / RAND_MAX; }

void hit_test_model(gaussian_model *m, size_t n, gaussian_kind kind)
{
    gaussian_model_init(m);
    m->kind = kind, m->sh_degree = 0, m->sh_coeffs = 1;
    CHECK(gaussian_model_alloc(m, n) == 0);
    m->count = n;
}

void random_splat(gaussian_model *m, size_t i, unsigned *st, double size)
{
    double q[4], len = 0;
    for (int k = 0; k < 4; k++)
        q[k] = rand_uniform(st) - 0.5, len += q[k] * q[k];
    for (int k = 0; k < 4; k++)
        m->rotation[4 * i + k] = (float)(q[k] / sqrt(len));
    for (int k = 0; k < 3; k++) {
        m->mean[3 * i + k] = (float)(rand_uniform(st) - 0.5);
        m->scale[3 * i + k] = k < 2 || m->kind == GAUSSIAN_3D ? (float)(size * (0.2 + rand_uniform(st))) : 0.0f;
        m->sh[3 * i + k] = (float)rand_uniform(st);
    }
    m->opacity[i] = (float)(0.05 + 0.95 * rand_uniform(st));
}

int box_holds_point(aabb b, vec3 p)
{
    return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z;
}

int ray_in_box_near(aabb box, vec3 dir, double t, double lead)
{
    double lo = t - lead, hi = t + lead, d[3] = {dir.x, dir.y, dir.z};
    double b0[3] = {box.lo.x, box.lo.y, box.lo.z}, b1[3] = {box.hi.x, box.hi.y, box.hi.z};
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0) {
            if (!(b0[a] <= 0 && 0 <= b1[a]))
                return 0;
            continue;
        }
        double ta = b0[a] / d[a], tb = b1[a] / d[a];
        lo = fmax(lo, fmin(ta, tb)), hi = fmin(hi, fmax(ta, tb));
    }
    return lo <= hi;
}

int hit_in_its_box(const gaussian_model *m, vec3 dir, const gaussian_hit *h, double lead)
{
    gaussian_view_bound vb = {v3_len(v3(m->mean[0], m->mean[1], m->mean[2])), 100, 1, gaussian_filter_near(1, 1),
                              v3(0, 0, 1), 0};
    return ray_in_box_near(gaussian_view_bounds(m, 0, &vb), dir, h->t, lead);
}

const gaussian_formation splatting_formations[SPLATTING_FORMATIONS] = {
    GAUSSIAN_FORMATION_2DGS, GAUSSIAN_FORMATION_2DGS_UNIT_CIRCLE, GAUSSIAN_FORMATION_3DGS,
    GAUSSIAN_FORMATION_3DGS_ANTIALIASED, GAUSSIAN_FORMATION_GSPLAT, GAUSSIAN_FORMATION_GSPLAT_ANTIALIASED,
    GAUSSIAN_FORMATION_2DGS_CENTER_NEAR};
