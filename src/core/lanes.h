/* Lanes: a kernel written once for two widths (after Embree's vfloat<K>
 * and splat.c's DEFINE_SPLAT_RULES). A kernel body is a macro over a type
 * T, instantiated for T = double (one value) and, where RR_LANES, for T =
 * v4d (four values in one AVX2 register: GCC/Clang vector types). In the
 * body + - * / and the comparisons are plain operators, lane by lane, and
 * a double operand counts in every lane; max, min, abs, sqrt, not and
 * select are the helpers below, one name for both widths. A comparison
 * gives a mask: an int (0 or 1) for double, a v4l (0 or all ones per lane)
 * for v4d; & and | combine either. IEEE sums, products, quotients and
 * square roots are exact per lane, and -ffp-contract=off (Makefile) fuses
 * none into an FMA, so the two widths give the same bits: the lane tests
 * (tests/test_gaussian_hit.c, tests/test_gaussian.c) check it.
 *
 * Per width W (double, v4d), a body uses lanes_mask_W (its mask type) and
 * LANES_TARGET_W (what its functions are compiled for: AVX2 for v4d). */
#ifndef RR_LANES_H
#define RR_LANES_H

#include "core/common.h"

/* Whether the v4d instantiations may run: the CPU has AVX2 and the
 * environment has no RR_NO_LANES (RR_NO_LANES=1 forces the scalar path). */
int rr_lanes_available(void);

typedef int lanes_mask_double;
#define LANES_TARGET_double

static inline double d_select(int mask, double a, double b) { return mask ? a : b; }
static inline int d_not(int mask) { return !mask; }

#if defined(__x86_64__) && defined(__GNUC__)
#define RR_LANES 1
#include <immintrin.h>

typedef double v4d __attribute__((vector_size(32)));
typedef __typeof__((v4d){0} < (v4d){0}) v4l; /* what a v4d comparison gives */
typedef float v4f __attribute__((vector_size(16)));
typedef v4l lanes_mask_v4d;
#define LANES_TARGET_v4d __attribute__((target("avx2")))
#define RR_LANES_TARGET LANES_TARGET_v4d

/* a where mask, else b */
RR_LANES_TARGET static inline v4d v4d_select(v4l mask, v4d a, v4d b)
{
    return _mm256_blendv_pd(b, a, (__m256d)mask);
}
/* rr_fmax's and rr_fmin's values: y only where x is not on its side and y is no NaN */
RR_LANES_TARGET static inline v4d v4d_max(v4d x, v4d y) { return v4d_select((x >= y) | (y != y), x, y); }
RR_LANES_TARGET static inline v4d v4d_min(v4d x, v4d y) { return v4d_select((x <= y) | (y != y), x, y); }
RR_LANES_TARGET static inline v4d v4d_abs(v4d x) { return _mm256_andnot_pd(_mm256_set1_pd(-0.0), x); }
RR_LANES_TARGET static inline v4d v4d_sqrt(v4d x) { return _mm256_sqrt_pd(x); }
RR_LANES_TARGET static inline v4l v4l_not(v4l mask) { return ~mask; }
/* bit j set where lane j of the mask is */
RR_LANES_TARGET static inline int v4l_bits(v4l mask) { return _mm256_movemask_pd((__m256d)mask); }
/* v[j][a] in lane j, as doubles (exact) */
RR_LANES_TARGET static inline v4d v4d_gather(const float *const v[4], int a)
{
    return _mm256_cvtps_pd(_mm_set_ps(v[3][a], v[2][a], v[1][a], v[0][a]));
}
/* v[0..2] in lanes 0..2 as doubles (exact), lane 3 zero: a masked load,
 * which reads no fourth float (v may be an array's last three) */
RR_LANES_TARGET static inline v4d v4d_load3f(const float *v)
{
    return _mm256_cvtps_pd(_mm_maskload_ps(v, _mm_set_epi32(0, -1, -1, -1)));
}

#define LANES_PICK(x, for_double, for_v4d) _Generic((x), double: for_double, v4d: for_v4d)
#define LANES_PICK_MASK(m, for_int, for_v4l) _Generic((m), int: for_int, v4l: for_v4l)
#else
#define RR_LANES 0
#define LANES_PICK(x, for_double, for_v4d) _Generic((x), double: for_double)
#define LANES_PICK_MASK(m, for_int, for_v4l) _Generic((m), int: for_int)
#endif

#define lanes_max(x, y) LANES_PICK((x), rr_fmax, v4d_max)(x, y)
#define lanes_min(x, y) LANES_PICK((x), rr_fmin, v4d_min)(x, y)
#define lanes_abs(x) LANES_PICK((x), fabs, v4d_abs)(x)
#define lanes_sqrt(x) LANES_PICK((x), sqrt, v4d_sqrt)(x)
#define lanes_select(mask, a, b) LANES_PICK((a), d_select, v4d_select)(mask, a, b)
#define lanes_not(mask) LANES_PICK_MASK((mask), d_not, v4l_not)(mask)

#endif
