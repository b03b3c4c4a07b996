/*
 * atan of a slope in [0, 1) from a 65-node table and cubic Hermite interpolation,
 * inlined by the hot paths (private to estimator/src; the table is in fixmath.c).
 */
#ifndef ESTIMATOR_FIX_ATAN_H
#define ESTIMATOR_FIX_ATAN_H

#include <stdint.h>

#include "estimator/fixmath.h"
#include "fix_inline.h"

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

#endif /* ESTIMATOR_FIX_ATAN_H */
