/* The splatting methods' settings (splat_settings.h): their names and the
 * instants they splat. */
#include "splatting/splat_settings.h"

#include <stdlib.h>

const char *splat_method_name(splat_method m)
{
    return m == SPLAT_ACCUM        ? "accum"
           : m == SPLAT_BUCKET     ? "bucket"
           : m == SPLAT_VOLUMETRIC ? "volumetric"
           : m == SPLAT_GUAN_MUELLER ? "guan-mueller"
                                   : "instant";
}

const char *splat_filter_name(splat_filter f)
{
    return f == SPLAT_FILTER_BOTSCH ? "botsch" : f == SPLAT_FILTER_EWA ? "ewa" : "none";
}

const char *splat_alpha_name(splat_alpha a) { return a == SPLAT_ALPHA_NORMALIZED ? "normalized" : "thesis"; }

const char *splat_trails_name(splat_trails t) { return t == SPLAT_TRAILS_ADD ? "add" : "blend"; }

const char *splat_times_name(splat_times t)
{
    return t == SPLAT_TIMES_STRATIFIED ? "stratified" : t == SPLAT_TIMES_RANDOM ? "random" : "midpoint";
}

/* splitmix64 (Steele, Lea, Flood 2014): the seeded offsets of stratified
 * and random instants. */
static double next_unit(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return (double)((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
}

static int by_time(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Sec. 3.6.1: the instants t_j of eq. 3.24 ("chosen stochastically"; which
 * distribution is not said). */
void splat_instants(const splat_settings *set, const shutter *shut, double *times)
{
    int n = set->samples;
    double t0 = shut->open, len = shut->close - shut->open;
    uint64_t state = set->seed;
    for (int k = 0; k < n; k++) {
        double u = set->times == SPLAT_TIMES_MIDPOINT ? 0.5 : next_unit(&state);
        times[k] = set->times == SPLAT_TIMES_RANDOM ? t0 + u * len : t0 + (k + u) / n * len;
    }
    if (set->times == SPLAT_TIMES_RANDOM)
        qsort(times, (size_t)n, sizeof *times, by_time);
}
