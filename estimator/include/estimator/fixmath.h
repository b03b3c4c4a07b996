/*
 * Fixed-point vocabulary of the attitude estimator: named Q formats,
 * saturating and rounding helpers, exact 128-bit intermediates, division,
 * integer square root and atan/atan2 in micro-degrees.
 *
 * Nothing here assumes an FPU or a hardware divider: 64-bit `/` compiles to
 * the libgcc helper (__aeabi_ldivmod) on a Cortex-M0+, 128-bit products are
 * built from 32x32->64 multiplies, and 128/64 division is a bounded
 * shift-subtract loop. No float, no heap, no globals (const tables only).
 *
 * Rounding convention everywhere: to nearest, halves away from zero, so that
 * every helper is odd-symmetric (f(-x) == -f(x)). The estimator relies on that
 * for alpha/beta sign symmetry.
 */
#ifndef ESTIMATOR_FIXMATH_H
#define ESTIMATOR_FIXMATH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* --- named formats: the type names the scaling, the storage is plain ints --- */
typedef int64_t fix_q32_t;      /* value x 2^32: slopes tan(angle), mm means, mm^2 variances */
typedef int64_t fix_q30_t;      /* value x 2^30: weights, gains, consensus matrix entries */
typedef int64_t fix_q28_t;      /* value x 2^28: variances of window means (mm^2) */
typedef int32_t fix_udeg_t;     /* angle in micro-degrees (1e-6 degree) */
typedef int64_t fix_udeg_q16_t; /* angle in micro-degrees x 2^16 (window means, iterations) */

#define FIX_Q32_SHIFT    32u
#define FIX_Q30_SHIFT    30u
#define FIX_Q28_SHIFT    28u
#define FIX_UDEG_Q_SHIFT 16u
#define FIX_Q32_ONE      ((int64_t)1 << 32)
#define FIX_Q30_ONE      ((int64_t)1 << 30)
#define FIX_Q28_ONE      ((int64_t)1 << 28)
#define FIX_UDEG_PER_DEG 1000000
#define FIX_UDEG_90      90000000
#define FIX_UDEG_180     180000000

/* 180e6/pi: micro-degrees per radian, rounded (57295779.513...). */
#define FIX_UDEG_PER_RAD 57295780
/* pi/180e6 * 2^32: Q32 radians per micro-degree, rounded down (74.961...). */
#define FIX_Q32_RAD_PER_UDEG_X1000 74961

/* 128-bit two's-complement integer for exact intermediates: 32-bit Arm GCC has
 * no __int128. hi holds bits 127..64 (bit 127 is the sign), lo bits 63..0. */
typedef struct {
    uint64_t hi;
    uint64_t lo;
} fix_s128;

/* --- saturation and rounding ------------------------------------------------ */

/* v clamped to [INT32_MIN, INT32_MAX]. */
int32_t fix_sat_s32(int64_t v);
/* a + b clamped to the int32 range. */
int32_t fix_sat_add_s32(int32_t a, int32_t b);
/* a + b clamped to the int64 range. */
int64_t fix_sat_add_s64(int64_t a, int64_t b);
/* a - b clamped to the int64 range. */
int64_t fix_sat_sub_s64(int64_t a, int64_t b);
/* a * b clamped to the int64 range (exact product first). */
int64_t fix_sat_mul_s64(int64_t a, int64_t b);
/* |v| as uint64 (exact also for INT64_MIN). */
uint64_t fix_abs_u64(int64_t v);

/* floor(v / 2^shift) for shift 0..63, without relying on signed >> semantics. */
int64_t fix_asr_s64(int64_t v, unsigned shift);
/* v / 2^shift rounded to nearest, halves away from zero; shift 0..62. */
int64_t fix_shr_round_s64(int64_t v, unsigned shift);
/* num / den rounded to nearest, halves away from zero; den != 0. Saturates the
 * one unrepresentable case (INT64_MIN / -1). */
int64_t fix_div_round_s64(int64_t num, int64_t den);
/* num / den truncated toward zero, as C's `/` on int64; den != 0. Saturates INT64_MIN / -1.
 * Through the unsigned division only: a Cortex-M0 image then links no signed 64-bit
 * division helper (~0.6 KB of flash). */
int64_t fix_div_trunc_s64(int64_t num, int64_t den);
/* round(2^60 / den): the reciprocal of a Q30 value, in Q30; den != 0; saturates. */
fix_q30_t fix_recip_q30(fix_q30_t den);

/* floor(sqrt(v)) for any uint64 (32 bounded steps, no division). */
uint32_t fix_isqrt_u64(uint64_t v);

/* --- exact 128-bit intermediates --------------------------------------------- */

/* v sign-extended to 128 bits. */
fix_s128 fix_s128_from_s64(int64_t v);
/* a + b, a - b and -a (modulo 2^128; callers keep magnitudes below 2^126). */
fix_s128 fix_s128_add(fix_s128 a, fix_s128 b);
fix_s128 fix_s128_sub(fix_s128 a, fix_s128 b);
fix_s128 fix_s128_neg(fix_s128 a);
/* Exact product of two int64. */
fix_s128 fix_s128_mul(int64_t a, int64_t b);
/* True if a < 0. */
bool fix_s128_is_neg(fix_s128 a);
/* -1, 0 or 1 as a is below, equal to or above b. */
int fix_s128_cmp(fix_s128 a, fix_s128 b);
/* a x 2^shift for shift 0..127 (bits above 127 are lost: caller keeps headroom). */
fix_s128 fix_s128_shl(fix_s128 a, unsigned shift);
/* a / 2^shift rounded to nearest, halves away from zero; shift 0..126. */
fix_s128 fix_s128_shr_round(fix_s128 a, unsigned shift);
/* a as int64; on overflow returns the saturated value and sets *overflow
 * (overflow may be NULL; it is never cleared, so one flag can collect many calls). */
int64_t fix_s128_to_s64(fix_s128 a, bool *overflow);
/* a / den rounded to nearest, halves away from zero, den != 0. A quotient that
 * does not fit int64 saturates and sets *overflow (may be NULL; never cleared). */
int64_t fix_s128_div_s64(fix_s128 a, int64_t den, bool *overflow);
/* (a * b) / den, rounded, with the exact 128-bit product: a muldiv. */
int64_t fix_muldiv_s64(int64_t a, int64_t b, int64_t den, bool *overflow);
/* (a * b) / 2^shift rounded (shift 0..126), saturated with *overflow. */
int64_t fix_mul_shr_s64(int64_t a, int64_t b, unsigned shift, bool *overflow);

/* --- normalised 32-bit arithmetic (the estimator's fast paths) ------------------- */

/* v = m · 2^e with m in [2^30, 2^31) for v > 0 (truncated): returns m, stores e. */
uint32_t fix_norm31(uint64_t v, int32_t *e);
/* ≈ 2^61 / m for m in [2^30, 2^31), in (2^30, 2^31), relative error < 2^-28: a 16-bit
 * quotient of one 32-bit division refined by one Newton step. */
int32_t fix_recip31(uint32_t m);
/* floor(v · r / 2^31) for |v| < 2^62 and any r (v times a Q31 fraction), exact,
 * from two 32x32 -> 64 products. */
int64_t fix_mul_q31(int64_t v, int32_t r);
/* floor(num / den) for den in [1, 65535]: four 32-by-16-bit division steps, exact. */
uint64_t fix_div_u64_u16(uint64_t num, uint32_t den);

/* --- angles ------------------------------------------------------------------- */

/*
 * atan2(y, x) in micro-degrees, in [-180e6, 180e6]; atan2(0, 0) is 0.
 * Any int64 inputs (their ratio is what counts). Vectoring CORDIC on 30-bit
 * normalised operands with rounding shifts: error <= 3 udeg everywhere
 * (tests/estimator/test_fixmath.c measures it against libm over a dense sweep).
 */
fix_udeg_t fix_atan2_udeg(int64_t y, int64_t x);
/* atan(t) in micro-degrees for a Q32 slope t = tan(angle) x 2^32. Within ±45°
 * (|t| < 2^32) a 65-node cubic Hermite table (about 30 instructions, error <= 1 udeg);
 * beyond it the CORDIC of fix_atan2_udeg. Odd: f(−t) == −f(t). */
fix_udeg_t fix_atan_q32_udeg(fix_q32_t t);
/* atan(t31 / 2^31) in micro-degrees for 0 <= t31 < 2^31 (0 .. 45°): the table alone. */
fix_udeg_t fix_atan_unit_q31_udeg(uint32_t t31);
/* A Q32 radian quantity (e.g. a standard deviation) in micro-degrees, rounded,
 * saturated to the int32 range. */
fix_udeg_t fix_udeg_from_rad_q32(fix_q32_t rad);

/*
 * 1σ in micro-degrees of α = atan(y/a) where y = a·tan α has variance var_mm2
 * (Q32 mm²), at the slope t (Q32), by the delta method dα/dt = 1/(1 + t²).
 * Saturates at INT32_MAX when the variance is too large to mean anything.
 */
fix_udeg_t fix_angle_sigma_udeg(fix_q32_t var_mm2, int32_t arm_um, fix_q32_t tan_q32);

#endif /* ESTIMATOR_FIXMATH_H */
