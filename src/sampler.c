#include "sampler.h"

#include <math.h>

enum { DIM_X = 0, DIM_Y = 1, DIM_TIME_JITTER = 2, DIM_TIME_PICK = 3 };

int sampler_grid_for_spp(int spp)
{
    int k = (int)lround(sqrt((double)(spp > 0 ? spp : 1)));
    return k < 1 ? 1 : k;
}

/* SplitMix64 finaliser: a bijective mixer with good avalanche. */
static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

double sampler_uniform(uint64_t seed, uint64_t a, uint64_t b, uint32_t dim)
{
    uint64_t h = mix64(seed + 0x9e3779b97f4a7c15ULL);
    h = mix64(h ^ (a + 0x632be59bd9b4e019ULL));
    h = mix64(h ^ (b + 0x85157af5ULL * (dim + 1)));
    h = mix64(h ^ dim);
    return (double)(h >> 11) * (1.0 / 9007199254740992.0); /* 53 bits */
}

void sampler_position(const sampler *s, uint64_t pixel, int px, int py, int i,
                      double *x, double *y)
{
    int k = s->grid;
    int cx = i % k, cy = i / k;
    *x = px + (cx + sampler_uniform(s->seed, pixel, (uint64_t)i, DIM_X)) / k;
    *y = py + (cy + sampler_uniform(s->seed, pixel, (uint64_t)i, DIM_Y)) / k;
}

void sampler_time_jitter(const sampler *s, uint64_t pixel, double *jitter)
{
    int m = s->tspp * s->time_factor;
    for (int j = 0; j < m; j++)
        jitter[j] = sampler_uniform(s->seed, pixel, (uint64_t)j, DIM_TIME_JITTER);
}

void sampler_times(const sampler *s, uint64_t pixel, int i, const double *jitter,
                   int *perm, double *times)
{
    int m = s->tspp * s->time_factor;
    for (int j = 0; j < m; j++)
        perm[j] = j;
    for (int k = 0; k < s->tspp; k++) {
        /* choose uniformly among the strata not yet taken */
        uint64_t counter = (uint64_t)i * (uint64_t)m + (uint64_t)k;
        double u = sampler_uniform(s->seed, pixel, counter, DIM_TIME_PICK);
        int pick = k + (int)(u * (m - k));
        if (pick >= m)
            pick = m - 1;
        int stratum = perm[pick];
        perm[pick] = perm[k];
        perm[k] = stratum;
        double t = s->t0 + (s->t1 - s->t0) * (stratum + jitter[stratum]) / m;
        times[k] = t < s->t1 ? t : nextafter(s->t1, s->t0);
    }
}
