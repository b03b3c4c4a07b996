/*
 * libFuzzer target: the estimator's building blocks called directly with
 * arbitrary inputs inside each function's documented domain
 * (estimator/fixmath.h, angles.h, consensus.h, kalman.h), checked against
 * independent references: __int128 arithmetic for the fixed-point helpers,
 * long-double libm for the angles, the header's own formulas and invariants
 * for consensus and the Kalman filter.
 *
 * Input: a sequence of commands (first byte: which entry point), each reading
 * its operands from the bytes that follow, until the input ends.
 *
 * Domains (what the headers promise the callers keep to; anything outside is
 * the caller's bug and is not fed): fixmath as documented per function;
 * s128 shifts and rounding on magnitudes below 2^126; angles with valid arms;
 * consensus_product with per-sensor means of 16-bit readings (0..65535 mm),
 * any non-negative variance and count >= 1; consensus_paper with means within
 * ±90° (means of angles) and any covariances; Kalman readings of 0..65535 mm (Q = 0,
 * Q > 0 and process_noise_auto: bit 2 of the configuration's style byte) and any variance
 * for noise tracking.
 *
 * Long run: docs/explanation/reliability.md, "Fuzzing".
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "estimator/angles.h"
#include "estimator/consensus.h"
#include "estimator/fixmath.h"
#include "estimator/kalman.h"
#include "fuzz_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

typedef __int128 s128;
typedef unsigned __int128 u128;

#define S64_MAX_128 ((s128)INT64_MAX)
#define S64_MIN_128 ((s128)INT64_MIN)

static s128 to128(fix_s128 a) {
    return (s128)(((u128)a.hi << 64) | (u128)a.lo);
}

static fix_s128 from128(s128 v) {
    fix_s128 r;
    r.hi = (uint64_t)((u128)v >> 64);
    r.lo = (uint64_t)(u128)v;
    return r;
}

static bool fits_s64(s128 v) {
    return v >= S64_MIN_128 && v <= S64_MAX_128;
}

static int64_t clamp_s64(s128 v) {
    return v > S64_MAX_128 ? INT64_MAX : (v < S64_MIN_128 ? INT64_MIN : (int64_t)v);
}

static u128 abs128(s128 v) {
    return v < 0 ? (u128)0 - (u128)v : (u128)v;
}

/* n / d rounded to nearest, halves away from zero, as a (possibly wide) magnitude
 * with its sign: the one rounding rule of fixmath.h. */
static s128 div_round_ref(s128 n, s128 d, bool *fits) {
    const u128 mn = abs128(n);
    const u128 md = abs128(d);
    const u128 q = mn / md + ((mn % md) >= md - mn % md ? 1u : 0u); /* 2r >= d */
    const bool neg = (n < 0) != (d < 0);
    *fits = neg ? q <= (u128)1 << 63 : q <= (u128)INT64_MAX;
    if (!*fits) {
        return neg ? S64_MIN_128 : S64_MAX_128;
    }
    return neg ? -(s128)q : (s128)q;
}

/* a / 2^shift rounded, halves away from zero. */
static s128 shr_round_ref(s128 a, unsigned shift) {
    if (shift == 0u) {
        return a;
    }
    const u128 m = abs128(a);
    const u128 r = (m + ((u128)1 << (shift - 1u))) >> shift;
    return a < 0 ? -(s128)r : (s128)r;
}

/* A 128-bit operand below 2^126 in magnitude (the headroom callers keep). */
static s128 fuzz_s126(struct fuzz_input *in) {
    const uint64_t hi = fuzz_u64(in);
    const uint64_t lo = fuzz_u64(in);
    s128 v = (s128)(((u128)(hi & 0x3FFFFFFFFFFFFFFFu) << 64) | lo);
    return (hi >> 63) != 0u ? -v : v;
}

/* --- fixmath -------------------------------------------------------------------------- */

static void check_scalar(struct fuzz_input *in) {
    const uint8_t which = fuzz_u8(in);
    const int64_t a = fuzz_s64(in);
    const int64_t b = fuzz_s64(in);
    const unsigned shift = fuzz_u8(in);
    switch (which % 12u) {
    case 0:
        FUZZ_CHECK(fix_sat_s32(a) == (a > INT32_MAX ? INT32_MAX : a < INT32_MIN ? INT32_MIN : a));
        break;
    case 1: {
        const int64_t s = (int64_t)(int32_t)a + (int64_t)(int32_t)b;
        FUZZ_CHECK(fix_sat_add_s32((int32_t)a, (int32_t)b) == fix_sat_s32(s));
        break;
    }
    case 2:
        FUZZ_CHECK(fix_sat_add_s64(a, b) == clamp_s64((s128)a + b));
        FUZZ_CHECK(fix_sat_sub_s64(a, b) == clamp_s64((s128)a - b));
        break;
    case 3:
        FUZZ_CHECK(fix_sat_mul_s64(a, b) == clamp_s64((s128)a * b));
        FUZZ_CHECK(fix_abs_u64(a) == (uint64_t)abs128(a));
        break;
    case 4: { /* floor(a / 2^s): an arithmetic shift of the wide value */
        const unsigned s = shift % 64u;
        const s128 wide = a;
        FUZZ_CHECK(fix_asr_s64(a, s) == (int64_t)(wide >> s));
        break;
    }
    case 5: {
        const unsigned s = shift % 63u;
        FUZZ_CHECK(fix_shr_round_s64(a, s) == clamp_s64(shr_round_ref(a, s)));
        break;
    }
    case 6:
        if (b != 0) {
            bool fits;
            const s128 q = div_round_ref(a, b, &fits);
            FUZZ_CHECK(fix_div_round_s64(a, b) == (int64_t)q); /* saturated when !fits */
        }
        if (a != 0) {
            bool fits;
            const s128 r = div_round_ref((s128)1 << 60, a, &fits);
            FUZZ_CHECK(fix_recip_q30(a) == (int64_t)r);
        }
        break;
    case 7: {
        const uint64_t v = (uint64_t)a;
        const u128 r = fix_isqrt_u64(v);
        FUZZ_CHECK(r * r <= v && (r + 1u) * (r + 1u) > v);
        break;
    }
    case 8: { /* add, sub, neg, cmp, is_neg, from_s64, to_s64 */
        const s128 x = fuzz_s126(in);
        const s128 y = fuzz_s126(in);
        FUZZ_CHECK(to128(fix_s128_add(from128(x), from128(y))) == x + y);
        FUZZ_CHECK(to128(fix_s128_sub(from128(x), from128(y))) == x - y);
        FUZZ_CHECK(to128(fix_s128_neg(from128(x))) == -x);
        FUZZ_CHECK(fix_s128_cmp(from128(x), from128(y)) == (x < y ? -1 : (x > y ? 1 : 0)));
        FUZZ_CHECK(fix_s128_is_neg(from128(x)) == (x < 0));
        FUZZ_CHECK(to128(fix_s128_from_s64(a)) == a);
        bool ovf = false;
        FUZZ_CHECK(fix_s128_to_s64(from128(x), &ovf) == clamp_s64(x) && ovf == !fits_s64(x));
        break;
    }
    case 9: { /* mul, shl, shr_round */
        FUZZ_CHECK(to128(fix_s128_mul(a, b)) == (s128)a * b);
        const s128 x = fuzz_s126(in);
        const unsigned s = shift % 128u;
        FUZZ_CHECK((u128)to128(fix_s128_shl(from128(x), s)) == (u128)x << s);
        const unsigned r = shift % 127u;
        FUZZ_CHECK(to128(fix_s128_shr_round(from128(x), r)) == shr_round_ref(x, r));
        break;
    }
    case 10: { /* div_s64, muldiv */
        const s128 x = fuzz_s126(in);
        bool ovf = false;
        const int64_t got = fix_s128_div_s64(from128(x), b, &ovf);
        if (b == 0) {
            FUZZ_CHECK(ovf && got == 0);
        } else {
            bool fits;
            const s128 q = div_round_ref(x, b, &fits);
            FUZZ_CHECK(got == (int64_t)q && ovf == !fits);
        }
        const int64_t den = fuzz_s64(in);
        ovf = false;
        const int64_t md = fix_muldiv_s64(a, b, den, &ovf);
        if (den != 0) {
            bool fits;
            const s128 q = div_round_ref((s128)a * b, den, &fits);
            FUZZ_CHECK(md == (int64_t)q && ovf == !fits);
        }
        break;
    }
    default: { /* mul_shr */
        const unsigned s = shift % 127u;
        bool ovf = false;
        const int64_t got = fix_mul_shr_s64(a, b, s, &ovf);
        const s128 want = shr_round_ref((s128)a * b, s);
        FUZZ_CHECK(got == clamp_s64(want) && ovf == !fits_s64(want));
        break;
    }
    }
}

static long double udeg_of(long double rad) {
    return rad * 180000000.0L / 3.14159265358979323846264338327950288L;
}

static void check_atan(struct fuzz_input *in) {
    const uint8_t which = fuzz_u8(in);
    const int64_t y = fuzz_s64(in) >> (fuzz_u8(in) % 64u); /* small magnitudes too */
    const int64_t x = fuzz_s64(in) >> (fuzz_u8(in) % 64u);
    switch (which % 3u) {
    case 0: { /* atan2: any int64 pair, error <= 3 udeg (fixmath.h) */
        const fix_udeg_t got = fix_atan2_udeg(y, x);
        FUZZ_CHECK(got >= -FIX_UDEG_180 && got <= FIX_UDEG_180);
        if (x == 0 && y == 0) {
            FUZZ_CHECK(got == 0);
            break;
        }
        const long double want = udeg_of(atan2l((long double)y, (long double)x));
        FUZZ_CHECK(fabsl((long double)got - want) <= 3.0L);
        if (y != INT64_MIN && y != 0) {
            FUZZ_CHECK(fix_atan2_udeg(-y, x) == -got); /* odd in y */
        }
        break;
    }
    case 1: { /* atan of a Q32 slope (table within ±45°: <= 1 udeg), odd; the Q31 table */
        const fix_udeg_t got = fix_atan_q32_udeg(y);
        const long double want = udeg_of(atanl((long double)y / 4294967296.0L));
        const bool table = y > -FIX_Q32_ONE && y < FIX_Q32_ONE;
        FUZZ_CHECK(fabsl((long double)got - want) <= (table ? 1.0L : 3.0L));
        if (y != INT64_MIN) {
            FUZZ_CHECK(fix_atan_q32_udeg(-y) == -got);
        }
        const uint32_t t31 = (uint32_t)x & 0x7FFFFFFFu;
        const long double want31 = udeg_of(atanl((long double)t31 / 2147483648.0L));
        FUZZ_CHECK(fabsl((long double)fix_atan_unit_q31_udeg(t31) - want31) <= 1.0L);
        const s128 r = shr_round_ref((s128)x * FIX_UDEG_PER_RAD, FIX_Q32_SHIFT);
        FUZZ_CHECK(fix_udeg_from_rad_q32(x) == fix_sat_s32(clamp_s64(r)));
        break;
    }
    default: { /* sigma of atan(y/a) by the delta method */
        const int64_t var = y;
        const int32_t arm = (int32_t)x;
        const int64_t tan = fuzz_s64(in) >> (fuzz_u8(in) % 64u);
        const fix_udeg_t got = fix_angle_sigma_udeg(var, arm, tan);
        if (var <= 0 || arm <= 0) {
            FUZZ_CHECK(got == (var == 0 ? 0 : INT32_MAX));
            break;
        }
        const long double t = (long double)tan / 4294967296.0L;
        const long double sd_t =
            sqrtl((long double)var / 4294967296.0L) / ((long double)arm / 1e3L);
        const long double want = udeg_of(sd_t / (1.0L + t * t));
        /* Never below the truth (an understated sigma would let a wrong estimate look
         * good); above it only by rounding, or saturated at INT32_MAX. */
        if (want >= (long double)INT32_MAX) {
            FUZZ_CHECK(got == INT32_MAX); /* saturated */
            break;
        }
        FUZZ_CHECK((long double)got >= want * (1.0L - 1e-6L) - 2.0L);
        FUZZ_CHECK(got == INT32_MAX || (long double)got <= want * (1.0L + 1e-6L) + 2.0L);
        break;
    }
    }
}

/* --- angles ---------------------------------------------------------------------------- */

static int32_t fuzz_arm(struct fuzz_input *in) {
    return (int32_t)fuzz_range_u32(in, ANGLES_ARM_MIN_UM, ANGLES_ARM_MAX_UM);
}

static void check_angles(struct fuzz_input *in) {
    uint16_t r[ANGLES_SENSORS];
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        r[k] = fuzz_u16(in);
    }
    const uint8_t mask = fuzz_u8(in);
    const int32_t arm = fuzz_arm(in);
    FUZZ_CHECK(angles_arm_valid(arm));
    struct angles_sample s;
    memset(&s, 0xA5, sizeof s);
    angles_compute(r, mask, arm, &s);
    struct angles_arm prepared;
    angles_arm_prepare(&prepared, arm);
    FUZZ_CHECK(s.alpha_valid == angles_alpha_mask(mask) && s.beta_valid == angles_beta_mask(mask));
    /* α_i = atan((x_hi − x_lo)/(span·a)) per Eq. 1, β by the mirror (angles.h). */
    static const unsigned alpha_pairs[ANGLES_PER_AXIS][3] = {{ANGLES_B, ANGLES_A, 1},
                                                             {ANGLES_D, ANGLES_A, 1},
                                                             {ANGLES_C, ANGLES_B, 1},
                                                             {ANGLES_C, ANGLES_D, 1},
                                                             {ANGLES_C, ANGLES_A, 2}};
    static const unsigned beta_pairs[ANGLES_PER_AXIS][3] = {{ANGLES_A, ANGLES_D, 1},
                                                            {ANGLES_C, ANGLES_D, 1},
                                                            {ANGLES_B, ANGLES_A, 1},
                                                            {ANGLES_B, ANGLES_C, 1},
                                                            {ANGLES_B, ANGLES_D, 2}};
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        for (unsigned axis = 0; axis < 2u; ++axis) {
            const unsigned *p = axis == 0u ? alpha_pairs[i] : beta_pairs[i];
            const bool valid = ((axis == 0u ? s.alpha_valid : s.beta_valid) >> i & 1u) != 0u;
            const fix_udeg_t got = axis == 0u ? s.alpha_udeg[i] : s.beta_udeg[i];
            FUZZ_CHECK(valid == (((mask >> p[0]) & 1u) != 0u && ((mask >> p[1]) & 1u) != 0u));
            if (!valid) {
                FUZZ_CHECK(got == 0);
                continue;
            }
            const long double want = udeg_of(
                atan2l(((long double)r[p[0]] - r[p[1]]) * 1000.0L, (long double)arm * p[2]));
            FUZZ_CHECK(fabsl((long double)got - want) <= 3.0L);
            /* the division-free primitive agrees with the reference one up to rounding */
            const fix_udeg_t pair = angles_pair_udeg(r[p[0]], r[p[1]], arm, p[2]);
            const fix_udeg_t fast = angles_pair_prepared_udeg(r[p[0]], r[p[1]], &prepared, p[2]);
            FUZZ_CHECK(fabsl((long double)pair - want) <= 3.0L);
            FUZZ_CHECK(fabsl((long double)fast - want) <= 3.0L);
        }
    }
    /* angles_compute_prepared: "identical results"; angles_compute_all: the same angles
     * when all four readings are valid (angles.h) */
    struct angles_sample fast;
    memset(&fast, 0x5A, sizeof fast);
    angles_compute_prepared(r, mask, &prepared, &fast);
    FUZZ_CHECK(memcmp(fast.alpha_udeg, s.alpha_udeg, sizeof s.alpha_udeg) == 0);
    FUZZ_CHECK(memcmp(fast.beta_udeg, s.beta_udeg, sizeof s.beta_udeg) == 0);
    FUZZ_CHECK(fast.alpha_valid == s.alpha_valid && fast.beta_valid == s.beta_valid);
    FUZZ_CHECK(fast.flatness_valid == s.flatness_valid && fast.flatness_mm == s.flatness_mm);
    if ((mask & ANGLES_ALL_SENSORS) == ANGLES_ALL_SENSORS) {
        fix_udeg_t all[ANGLES_PER_AXIS];
        fix_udeg_t beta5 = 0;
        angles_compute_all(r, &prepared, all, &beta5);
        FUZZ_CHECK(memcmp(all, s.alpha_udeg, sizeof all) == 0 && beta5 == s.beta_udeg[4]);
    }
    const bool all = (mask & ANGLES_ALL_SENSORS) == ANGLES_ALL_SENSORS;
    FUZZ_CHECK(s.flatness_valid == all);
    FUZZ_CHECK(s.flatness_mm == (all ? (int32_t)r[0] + r[2] - r[1] - r[3] : 0));
}

/* --- consensus ------------------------------------------------------------------------- */

#define QUANT_VAR_MM2 (1.0L / 12.0L)

static void check_product(struct fuzz_input *in) {
    struct consensus_product_input pin;
    memset(&pin, 0, sizeof pin);
    const uint8_t used = fuzz_u8(in);
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        struct consensus_sensor *s = &pin.sensor[k];
        s->used = (used >> k & 1u) != 0u;
        s->count = (uint16_t)fuzz_range_u32(in, 1u, 65535u);
        s->mean_mm = (int64_t)(fuzz_u64(in) % (((uint64_t)65535u << 32) + 1u));
        s->var_mm2 = (int64_t)(fuzz_u64(in) >> (1u + fuzz_u8(in) % 63u));
    }
    pin.arm_um = fuzz_arm(in);
    pin.tolerance_udeg = (int32_t)fuzz_range_u32(in, 1u, 10000000u);
    struct consensus_product_result out;
    memset(&out, 0xA5, sizeof out);
    consensus_product(&pin, &out);

    /* axis frames (low, ref1, high, ref2) of consensus.h */
    static const unsigned frames[2][4] = {{ANGLES_A, ANGLES_B, ANGLES_C, ANGLES_D},
                                          {ANGLES_D, ANGLES_A, ANGLES_B, ANGLES_C}};
    const long double a_mm = (long double)pin.arm_um / 1000.0L;
    for (unsigned axis = 0; axis < 2u; ++axis) {
        const struct consensus_axis *ax = axis == 0u ? &out.alpha : &out.beta;
        const unsigned *f = frames[axis];
        const bool low = pin.sensor[f[0]].used;
        const bool high = pin.sensor[f[2]].used;
        const bool refs = pin.sensor[f[1]].used && pin.sensor[f[3]].used;
        uint8_t want_used;
        if (low && high && refs) {
            want_used = 0x1F;
        } else if (high && refs) {
            want_used = 0x0C;
        } else if (low && refs) {
            want_used = 0x03;
        } else if (low && high) {
            want_used = 0x10;
        } else {
            FUZZ_CHECK(ax->status == CONSENSUS_UNOBSERVABLE);
            continue;
        }
        FUZZ_CHECK(ax->status == CONSENSUS_OK); /* NO_CONVERGENCE would be a bug */
        FUZZ_CHECK(ax->used == want_used);
        FUZZ_CHECK(ax->iterations <= CONSENSUS_PRODUCT_MAX_ITERATIONS);
        /* v(0) against the header's formulas, in mm means */
        long double m[4];
        long double v_mean[4]; /* variance of each mean, floored */
        for (unsigned j = 0; j < 4u; ++j) {
            const struct consensus_sensor *s = &pin.sensor[f[j]];
            m[j] = (long double)s->mean_mm / 4294967296.0L;
            long double v = (long double)s->var_mm2 / 4294967296.0L;
            v_mean[j] = (v > QUANT_VAR_MM2 ? v : QUANT_VAR_MM2) / s->count;
        }
        const long double other = refs ? (m[1] - m[3]) / (2.0L * a_mm) : 0.0L;
        const long double v0[ANGLES_PER_AXIS] = {
            (m[1] - m[0]) / a_mm - other, (m[3] - m[0]) / a_mm + other,
            (m[2] - m[1]) / a_mm + other, (m[2] - m[3]) / a_mm - other,
            (m[2] - m[0]) / (2.0L * a_mm)};
        int64_t weight_sum = 0;
        long double lo = HUGE_VALL;
        long double hi = -HUGE_VALL;
        long double invariant = 0.0L;
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            if ((ax->used >> i & 1u) == 0u) {
                continue;
            }
            const long double got = (long double)ax->initial[i] / 4294967296.0L;
            /* each slope is |Δ| times a reciprocal of a with relative error below 2^-31
             * (consensus.c), then compensated by `other`: a few LSB plus 2^-29 of both */
            const long double scale = fabsl(v0[i]) + 2.0L * fabsl(other);
            FUZZ_CHECK(fabsl(got - v0[i]) <= 8.0L / 4294967296.0L + scale * 0x1p-29L);
            FUZZ_CHECK(ax->weight[i] >= 0);
            weight_sum += ax->weight[i];
            lo = fminl(lo, (long double)ax->initial[i]);
            hi = fmaxl(hi, (long double)ax->initial[i]);
            invariant += (long double)ax->weight[i] * (long double)ax->initial[i];
        }
        FUZZ_CHECK(weight_sum == FIX_Q30_ONE);
        if (want_used == 0x1F) { /* the BLUE split of consensus.h, fact 3 */
            const long double mm = (v_mean[1] + v_mean[3]) / 4.0L;
            const long double w_low = 2.0L * mm + v_mean[2];
            const long double w_high = 2.0L * mm + v_mean[0];
            const long double pi_low = w_low / (w_low + w_high);
            const long double got_low =
                (long double)(ax->weight[0] + ax->weight[1] + ax->weight[4] / 2) / FIX_Q30_ONE;
            FUZZ_CHECK(fabsl(got_low - pi_low) <= 1e-3L);
        }
        /* the fused slope is π·v(0) (invariant of P), up to the rounding of each step */
        invariant /= (long double)FIX_Q30_ONE;
        const long double slack = 2.0L * (ax->iterations + 2u);
        FUZZ_CHECK(fabsl((long double)ax->tan_q32 - invariant) <= slack);
        FUZZ_CHECK((long double)ax->tan_q32 >= lo - slack &&
                   (long double)ax->tan_q32 <= hi + slack);
        FUZZ_CHECK(ax->angle_udeg == fix_atan_q32_udeg(ax->tan_q32));
        FUZZ_CHECK(ax->sigma_udeg >= 0);
    }
    const bool ac = pin.sensor[ANGLES_A].used && pin.sensor[ANGLES_C].used;
    const bool bd = pin.sensor[ANGLES_B].used && pin.sensor[ANGLES_D].used;
    FUZZ_CHECK(out.distance_valid == (ac || bd));
    if (out.distance_valid) {
        int64_t lo = INT64_MAX;
        int64_t hi = INT64_MIN;
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            if ((ac && (k == ANGLES_A || k == ANGLES_C)) ||
                (bd && (k == ANGLES_B || k == ANGLES_D))) {
                lo = pin.sensor[k].mean_mm < lo ? pin.sensor[k].mean_mm : lo;
                hi = pin.sensor[k].mean_mm > hi ? pin.sensor[k].mean_mm : hi;
            }
        }
        FUZZ_CHECK(out.distance_mm >= lo - 1 && out.distance_mm <= hi + 1);
    }
}

static void check_paper(struct fuzz_input *in) {
    fix_udeg_q16_t mean[ANGLES_PER_AXIS];
    int64_t cov[ANGLES_PER_AXIS][ANGLES_PER_AXIS];
    const int64_t limit = (int64_t)FIX_UDEG_90 << FIX_UDEG_Q_SHIFT; /* means of angles */
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        mean[i] = (int64_t)(fuzz_u64(in) % (uint64_t)(2 * limit + 1)) - limit;
    }
    const uint8_t style = fuzz_u8(in);
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        for (unsigned j = 0; j < ANGLES_PER_AXIS; ++j) {
            /* symmetric (as a window's) or not, any magnitude */
            cov[i][j] =
                (style & 1u) != 0u && j < i ? cov[j][i] : fuzz_s64(in) >> (fuzz_u8(in) % 64u);
        }
    }
    const uint16_t complete = fuzz_u16(in);
    struct consensus_paper_config cfg = {(int32_t)fuzz_range_u32(in, 1u, 10000000u),
                                         (uint16_t)fuzz_range_u32(in, 0u, 4096u)};
    struct consensus_paper_result out;
    memset(&out, 0xA5, sizeof out);
    consensus_paper(mean, (const int64_t(*)[ANGLES_PER_AXIS])cov, complete, &cfg, &out);
    FUZZ_CHECK(out.iterations <= cfg.max_iterations);
    bool nonpositive = false;
    bool zero = false;
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        nonpositive = nonpositive || cov[i][i] <= 0;
        for (unsigned j = 0; j < ANGLES_PER_AXIS; ++j) {
            zero = zero || cov[i][j] == 0;
        }
    }
    if (complete < 2u) {
        FUZZ_CHECK(out.status == CONSENSUS_TOO_FEW_ROWS);
    } else if (nonpositive) {
        FUZZ_CHECK(out.status == CONSENSUS_NONPOSITIVE_VARIANCE);
    } else if (zero) {
        FUZZ_CHECK(out.status == CONSENSUS_ZERO_COVARIANCE);
    }
    switch (out.status) {
    case CONSENSUS_OK: {
        int64_t lo = INT64_MAX;
        int64_t hi = INT64_MIN;
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            lo = mean[i] < lo ? mean[i] : lo;
            hi = mean[i] > hi ? mean[i] : hi;
        }
        const int64_t tol = (int64_t)cfg.tolerance_udeg << FIX_UDEG_Q_SHIFT;
        const int64_t got = (int64_t)out.angle_udeg * (1 << FIX_UDEG_Q_SHIFT);
        const int64_t half = (int64_t)1 << (FIX_UDEG_Q_SHIFT - 1u); /* output rounding */
        FUZZ_CHECK(got >= lo - tol - half && got <= hi + tol + half);
        FUZZ_CHECK(out.angle_udeg >= -FIX_UDEG_90 && out.angle_udeg <= FIX_UDEG_90);
        /* rows of P sum to one (Eq. 4), up to one rounding per entry */
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            int64_t row = 0;
            for (unsigned k = 0; k < ANGLES_PER_AXIS; ++k) {
                row += out.matrix[i][k];
            }
            FUZZ_CHECK(row >= FIX_Q30_ONE - 3 && row <= FIX_Q30_ONE + 3);
        }
        break;
    }
    case CONSENSUS_TOO_FEW_ROWS:
    case CONSENSUS_NONPOSITIVE_VARIANCE:
    case CONSENSUS_ZERO_COVARIANCE:
    case CONSENSUS_ZERO_ROW_SUM:
    case CONSENSUS_NEGATIVE_ROW_SUM:
    case CONSENSUS_OVERFLOW:
    case CONSENSUS_DIVERGED:
    case CONSENSUS_NO_CONVERGENCE:
    case CONSENSUS_OUTSIDE_HULL:
        FUZZ_CHECK(out.angle_udeg == 0);
        break;
    default:
        FUZZ_CHECK(out.status <= CONSENSUS_OUTSIDE_HULL); /* a status outside the enum */
    }
}

/* --- Kalman ------------------------------------------------------------------------------ */

static struct kalman_state kf;

/* Positive diagonal, symmetric, every correlation strictly inside ±1 (kalman.h: any
 * failure restarts the filter, so no public call may leave P otherwise). */
/* P of either form: positive diagonal, symmetric, every correlation inside ±1. */
static void check_covariance(const struct kalman_state *k) {
    fix_q32_t p[KALMAN_STATES][KALMAN_STATES];
    kalman_covariance(k, p);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        FUZZ_CHECK(p[i][i] > 0);
        for (unsigned j = i + 1u; j < KALMAN_STATES; ++j) {
            FUZZ_CHECK(p[i][j] == p[j][i]);
            FUZZ_CHECK((s128)p[i][j] * p[i][j] < (s128)p[i][i] * p[j][j]);
        }
    }
}

static void trace_covariance(const struct kalman_state *k) {
    fix_q32_t p[KALMAN_STATES][KALMAN_STATES];
    kalman_covariance(k, p);
    fprintf(stderr, "P = [%lld %lld %lld; %lld %lld; %lld]", (long long)p[0][0], (long long)p[0][1],
            (long long)p[0][2], (long long)p[1][1], (long long)p[1][2], (long long)p[2][2]);
}

static void check_rows(const struct kalman_rows *rows, uint8_t valid) {
    FUZZ_CHECK(rows->count <= KALMAN_WARMUP_MAX);
    for (unsigned r = 0; r < rows->count; ++r) {
        FUZZ_CHECK((rows->used[r] & rows->rejected[r]) == 0u);
        FUZZ_CHECK(((rows->used[r] | rows->rejected[r]) & ~ANGLES_ALL_SENSORS) == 0u);
        if (rows->count == 1u && valid != 0xFFu) {
            FUZZ_CHECK(((rows->used[r] | rows->rejected[r]) & ~valid) == 0u);
        }
    }
}

static void check_kalman(struct fuzz_input *in) {
    struct kalman_config cfg;
    memset(&cfg, 0, sizeof cfg);
    const uint8_t style = fuzz_u8(in);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        cfg.process_noise_mm2[i] = fuzz_s64(in) >> (fuzz_u8(in) % 64u);
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        cfg.initial_noise_mm2[s] = fuzz_s64(in) >> (fuzz_u8(in) % 64u);
    }
    cfg.gate_sigmas_q8 = fuzz_u16(in);
    cfg.gate_floor_mm = fuzz_u16(in);
    cfg.warmup_rows = fuzz_u8(in);
    cfg.noise_shift = fuzz_u8(in);
    cfg.process_noise_auto = (style & 4u) != 0u; /* Q and R learnt from the rows */
    if ((style & 1u) != 0u) {                    /* guided: a valid configuration */
        for (unsigned i = 0; i < KALMAN_STATES; ++i) {
            /* half of them Q = 0, the paper's static protocol */
            cfg.process_noise_mm2[i] = (style & 2u) != 0u
                                           ? 0
                                           : (int64_t)((uint64_t)cfg.process_noise_mm2[i] %
                                                       ((uint64_t)KALMAN_P0_MM2_Q32 + 1u));
        }
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            cfg.initial_noise_mm2[s] =
                KALMAN_R_MIN_Q32 +
                (int64_t)((uint64_t)cfg.initial_noise_mm2[s] %
                          (((uint64_t)1 << 52) - (uint64_t)KALMAN_R_MIN_Q32 + 1u));
        }
        cfg.warmup_rows = (uint8_t)(1u + cfg.warmup_rows % KALMAN_WARMUP_MAX);
        cfg.noise_shift = (uint8_t)(cfg.noise_shift % 9u);
    }
    bool q_ok = true;
    bool r_ok = true;
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        q_ok =
            q_ok && cfg.process_noise_mm2[i] >= 0 && cfg.process_noise_mm2[i] <= KALMAN_P0_MM2_Q32;
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        r_ok = r_ok && cfg.initial_noise_mm2[s] >= KALMAN_R_MIN_Q32 &&
               cfg.initial_noise_mm2[s] <= ((int64_t)1 << 52);
    }
    const bool w_ok = cfg.warmup_rows >= 1u && cfg.warmup_rows <= KALMAN_WARMUP_MAX;
    const bool n_ok = cfg.noise_shift <= 8u;
    memset(&kf, 0x5A, sizeof kf);
    const int err = kalman_init(&kf, &cfg);
    if (q_ok && r_ok && w_ok && n_ok) {
        FUZZ_CHECK(err == KALMAN_OK);
    } else {
        FUZZ_CHECK((err == KALMAN_ERR_PROCESS_NOISE && !q_ok) ||
                   (err == KALMAN_ERR_MEASUREMENT_NOISE && !r_ok) ||
                   (err == KALMAN_ERR_WARMUP && !w_ok) || (err == KALMAN_ERR_NOISE_SHIFT && !n_ok));
        return;
    }
    check_covariance(&kf);
    /* FUZZ_TRACE=1 fuzz_estimator_math crash-...: each Kalman call and the P it left */
    const bool trace = getenv("FUZZ_TRACE") != NULL;
    /* A run of filter calls; a repeat count lets few bytes drive long outages. */
    for (unsigned step = 0; step < 64u && !fuzz_input_done(in); ++step) {
        const uint8_t op = fuzz_u8(in);
        if (trace) {
            fprintf(stderr, "kalman op %u: ", op % 6u);
            trace_covariance(&kf);
            fprintf(stderr, " started %d\n", (int)kf.started);
        }
        struct kalman_rows rows;
        switch (op % 6u) {
        case 0:
        case 1: {
            uint16_t r[ANGLES_SENSORS];
            for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
                r[s] = fuzz_u16(in);
            }
            const uint8_t valid = fuzz_u8(in);
            const unsigned repeat = op % 6u == 1u ? 1u + fuzz_u8(in) : 1u;
            for (unsigned i = 0; i < repeat; ++i) {
                memset(&rows, 0xA5, sizeof rows);
                kalman_push_row(&kf, r, valid, &rows);
                if (trace) {
                    fprintf(stderr, "  row [%u %u %u %u] valid %x: used %x rejected %x, ", r[0],
                            r[1], r[2], r[3], valid, rows.count ? rows.used[0] : 0u,
                            rows.count ? rows.rejected[0] : 0u);
                    trace_covariance(&kf);
                    fprintf(stderr, ", restarts %u\n", kf.restarts);
                }
                check_rows(&rows, (uint8_t)(valid & ANGLES_ALL_SENSORS));
                check_covariance(&kf);
            }
            break;
        }
        case 2:
            memset(&rows, 0xA5, sizeof rows);
            kalman_flush(&kf, &rows);
            check_rows(&rows, 0xFFu);
            FUZZ_CHECK(kf.started || kf.warm_rows == 0u);
            break;
        case 3: {
            const unsigned sensor = fuzz_u8(in) % ANGLES_SENSORS;
            (void)kalman_update(&kf, sensor, fuzz_u16(in), (op & 0x80u) != 0u);
            check_covariance(&kf);
            break;
        }
        case 4: {
            const unsigned sensor = fuzz_u8(in) % (ANGLES_SENSORS + 1u); /* 4: ignored */
            const int64_t var = (int64_t)(fuzz_u64(in) >> (1u + fuzz_u8(in) % 63u));
            kalman_track_noise(&kf, sensor, var, fuzz_u16(in));
            break;
        }
        default: {
            struct kalman_result res;
            memset(&res, 0xA5, sizeof res);
            kalman_estimate(&kf, fuzz_arm(in), &res);
            FUZZ_CHECK(res.alpha_udeg >= -FIX_UDEG_90 && res.alpha_udeg <= FIX_UDEG_90);
            FUZZ_CHECK(res.beta_udeg >= -FIX_UDEG_90 && res.beta_udeg <= FIX_UDEG_90);
            FUZZ_CHECK(res.alpha_sigma_udeg >= 0 && res.beta_sigma_udeg >= 0);
            FUZZ_CHECK(!res.alpha_observable || kf.started);
            fix_q32_t p[KALMAN_STATES][KALMAN_STATES];
            kalman_covariance(&kf, p);
            FUZZ_CHECK(memcmp(res.p_mm2, p, sizeof res.p_mm2) == 0);
            if ((op & 0x80u) != 0u) {
                kalman_reset(&kf);
                FUZZ_CHECK(!kf.started && kf.warm_rows == 0u);
            }
            break;
        }
        }
        check_covariance(&kf);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    struct fuzz_input in = fuzz_input_make(data, size);
    for (unsigned cmd = 0; cmd < 256u && !fuzz_input_done(&in); ++cmd) {
        switch (fuzz_u8(&in) % 6u) {
        case 0:
            check_scalar(&in);
            break;
        case 1:
            check_atan(&in);
            break;
        case 2:
            check_angles(&in);
            break;
        case 3:
            check_product(&in);
            break;
        case 4:
            check_paper(&in);
            break;
        default:
            check_kalman(&in);
            break;
        }
    }
    return 0;
}
