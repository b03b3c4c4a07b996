/*
 * The fixed-point family's private parts (estimator/src only): the small helpers the hot
 * paths of the estimator inline, and the atan table's interpolation (the table is in
 * fixmath.c). Same rounding conventions as estimator/fixmath.h.
 */
#ifndef ESTIMATOR_FIXMATH_INTERNAL_H
#define ESTIMATOR_FIXMATH_INTERNAL_H

#include <stdint.h>

#include "estimator/fixmath.h"

/* Inlined even at -Os (GCC, Clang): the hot helpers below are a few instructions each,
 * a call would cost more than the body. */
#if defined(__GNUC__)
#define FIX_INLINE __attribute__((always_inline)) static inline
#else
#define FIX_INLINE static inline
#endif

/* Never inlined (GCC, Clang): keeps a large frame off the paths that do not need it. */
#if defined(__GNUC__)
#define FIX_NOINLINE __attribute__((noinline)) static
#else
#define FIX_NOINLINE static
#endif

/* Number of significant bits of v (0 for 0, 64 for values >= 2^63). GCC and Clang
 * have a count-leading-zeros builtin (one CLZ instruction on Armv7-M, a libgcc helper
 * on Armv6-M); any other compiler gets the portable binary search. Both are exact, so
 * results never depend on the compiler. */
FIX_INLINE unsigned fix_bitlen_u64(uint64_t v) {
#if defined(__GNUC__)
    return v == 0u ? 0u : 64u - (unsigned)__builtin_clzll(v);
#else
    unsigned n = 0;
    uint64_t rest = v;
    static const unsigned widths[6] = {32u, 16u, 8u, 4u, 2u, 1u};
    for (unsigned i = 0; i < 6u; ++i) {
        if ((rest >> widths[i]) != 0u) {
            rest >>= widths[i];
            n += widths[i];
        }
    }
    return rest != 0u ? n + 1u : n;
#endif
}

/* The bias that makes every |v| < 2^62 non-negative, so that floor(v / 2^s) is an
 * unsigned shift: ((v + 2^62) >> s) - 2^62 / 2^s, exact for s <= 62. MISRA forbids
 * shifting negative values; this form is defined C and compiles to the few
 * instructions of an arithmetic shift. */
#define FIX_SHIFT_BIAS ((uint64_t)1 << 62)

/* floor(v / 2^shift) for |v| < 2^62, shift 0..62. */
FIX_INLINE int64_t fix_floor_shr_s64(int64_t v, unsigned shift) {
    const uint64_t biased = (uint64_t)v + FIX_SHIFT_BIAS; /* in [0, 2^63) */
    const uint64_t q = biased >> shift;
    const uint64_t bias_q = FIX_SHIFT_BIAS >> shift;
    return (int64_t)q - (int64_t)bias_q;
}

/* round(v / 2^shift), halves up, for |v| < 2^62 - 2^(shift - 1), shift 1..62. */
FIX_INLINE int64_t fix_round_shr_s64(int64_t v, unsigned shift) {
    return fix_floor_shr_s64(v + ((int64_t)1 << (shift - 1u)), shift);
}

/* floor(v / 2^32) for |v| < 2^62: the high word of a 32x32 -> 64 product. */
FIX_INLINE int32_t fix_hi32(int64_t v) {
    const uint64_t biased = (uint64_t)v + FIX_SHIFT_BIAS; /* in [0, 2^63) */
    const uint64_t hi = biased >> 32;
    const int64_t q = (int64_t)hi - (int64_t)(FIX_SHIFT_BIAS >> 32);
    return (int32_t)q;
}

/* fix_norm31() and fix_recip31() (estimator/fixmath.h) for the hot path that inlines them. */
FIX_INLINE uint32_t fix_norm31_inline(uint64_t v, int32_t *e) {
    const int32_t ex = (int32_t)fix_bitlen_u64(v) - 31;
    *e = ex;
    if (ex >= 0) {
        const uint64_t m = v >> (unsigned)ex;
        return (uint32_t)m;
    }
    const uint32_t small = (uint32_t)v; /* v < 2^30 here */
    return small << (unsigned)(-ex);
}

FIX_INLINE int32_t fix_recip31_inline(uint32_t m) {
    const uint32_t d = m >> 15; /* >= 2^15 */
    const uint32_t q16 = 0xFFFFFFFFu / (d != 0u ? d : 1u);
    const int32_t y0 = (int32_t)(q16 << 14);              /* < 2^31 */
    const uint64_t prod = (uint64_t)m * (uint32_t)y0;     /* 2^61 (1 ± 2^-15) */
    const uint64_t err_bits = ((uint64_t)1 << 61) - prod; /* two's complement */
    const int64_t err = (int64_t)err_bits;                /* |err| < 2^48 */
    const int64_t err29 = fix_floor_shr_s64(err, 29u);    /* < 2^19 */
    const int64_t r = (int64_t)y0 + fix_hi32((int64_t)y0 * err29);
    return r < INT32_MAX ? (int32_t)r : INT32_MAX;
}

/* fix_mul_q31() (estimator/fixmath.h), any sign of r: floor(v · r / 2^31) for |v| < 2^62. */
FIX_INLINE int64_t fix_mul_q31_inline(int64_t v, int32_t r) {
    const int64_t vh = fix_floor_shr_s64(v, 31u);
    const int64_t vl = v - vh * ((int64_t)1 << 31); /* in [0, 2^31) */
    return vh * r + fix_floor_shr_s64(vl * r, 31u);
}

/* floor(v / 2^sh) as int32 for sh in [1, 62] when the result fits int32 and, for
 * sh >= 32, |v| < 2^62: from the two 32-bit halves (the low word of the floor is the same
 * bits for either sign). */
FIX_INLINE int32_t fix_shr_to_s32(int64_t v, unsigned sh) {
    const uint64_t u = (uint64_t)v;
    const uint32_t lo = (uint32_t)u;
    const uint32_t hi = (uint32_t)(u >> 32);
    uint32_t r;
    if (sh < 32u) {
        r = (lo >> sh) | (hi << (32u - sh));
    } else {
        /* the high word alone, in [−2^30, 2^30): shifted with the bias 2^30 (which 2^s2
         * divides) it stays unsigned */
        const unsigned s2 = sh - 32u;
        r = ((hi + 0x40000000u) >> s2) - (0x40000000u >> s2);
    }
    return (int32_t)r; /* two's complement bits: in range by the precondition */
}

/* --- atan of a slope in [0, 1): a 65-node table and cubic Hermite interpolation --- */

#define FIX_ATAN_SEGMENTS     64u
#define FIX_ATAN_SEGMENT_BITS 25u /* Q31 slope: 2^31 / 64 segments */

/* atan(k/64) and its tangent (1/64)/(1 + (k/64)^2), udeg x 16 (fixmath.c). */
extern const int32_t fix_atan_nodes[FIX_ATAN_SEGMENTS + 1u][2];

/* c + floor(acc * x) with x = x31 / 2^31 in [0, 1): one multiply, its high word
 * (|acc| < 2^30). */
FIX_INLINE int32_t fix_atan_step(int32_t c, int32_t acc, int32_t x31) {
    const int32_t acc2 = 2 * acc;
    return c + fix_hi32((int64_t)acc2 * x31);
}

/*
 * atan(t31 / 2^31) in udeg for t31 in [0, 2^31) (0 .. 45 deg). Segment k = t31 / 2^25,
 * x = fraction in [0, 1) as Q31. The Hermite cubic p0 + m0 x + c2 x^2 + c3 x^3 with
 * c2 = 3(p1 - p0) - 2 m0 - m1, c3 = 2(p0 - p1) + m0 + m1 interpolates atan and its slope
 * at both nodes: error < 0.05 udeg (h = 1/64: h^4 / 384 times the largest fourth
 * derivative of atan); the roundings of the table and of the three steps add < 0.2 udeg,
 * the final rounding 0.5.
 */
FIX_INLINE fix_udeg_t fix_atan_q31_inline(uint32_t t31) {
    const uint32_t k = t31 >> FIX_ATAN_SEGMENT_BITS;
    const uint32_t frac = t31 & (((uint32_t)1 << FIX_ATAN_SEGMENT_BITS) - 1u);
    const uint32_t x = frac << (31u - FIX_ATAN_SEGMENT_BITS); /* < 2^31 */
    const int32_t x31 = (int32_t)x;
    const int32_t p0 = fix_atan_nodes[k][0];
    const int32_t m0 = fix_atan_nodes[k][1];
    const int32_t p1 = fix_atan_nodes[k + 1u][0];
    const int32_t m1 = fix_atan_nodes[k + 1u][1];
    const int32_t c2 = 3 * (p1 - p0) - 2 * m0 - m1;
    const int32_t c3 = 2 * (p0 - p1) + m0 + m1;
    int32_t acc = fix_atan_step(c2, c3, x31);
    acc = fix_atan_step(m0, acc, x31);
    acc = fix_atan_step(p0, acc, x31); /* udeg x 16, >= 0 */
    return (fix_udeg_t)(((uint32_t)acc + 8u) >> 4);
}

#endif /* ESTIMATOR_FIXMATH_INTERNAL_H */
