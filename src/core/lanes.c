#include "core/lanes.h"

#include <stdlib.h>
#include <string.h>

/* The one place that decides, once: the CPU (AVX2) and RR_NO_LANES (set
 * and neither empty nor "0"). Threads may race to the first answer: they
 * compute the same one. */
int rr_lanes_available(void)
{
    static int known = -1; /* -1: not yet asked */
    int answer = __atomic_load_n(&known, __ATOMIC_RELAXED);
    if (answer < 0) {
        const char *off = getenv("RR_NO_LANES");
        answer = RR_LANES && !(off && *off && strcmp(off, "0"));
#if RR_LANES
        answer = answer && __builtin_cpu_supports("avx2");
#endif
        __atomic_store_n(&known, answer, __ATOMIC_RELAXED);
    }
    return answer;
}
