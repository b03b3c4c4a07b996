/* Fixed-point helpers of the estimator: see estimator/fixmath.h for the contracts. */
#include "estimator/fixmath.h"

#include "fixmath_internal.h"

#define U64_SIGN_BIT ((uint64_t)1 << 63)

/* --- saturation and rounding ---------------------------------------------------- */

int32_t fix_sat_s32(int64_t v) {
    if (v > INT32_MAX) {
        return INT32_MAX;
    }
    if (v < INT32_MIN) {
        return INT32_MIN;
    }
    return (int32_t)v;
}

int32_t fix_sat_add_s32(int32_t a, int32_t b) {
    return fix_sat_s32((int64_t)a + (int64_t)b);
}

int64_t fix_sat_add_s64(int64_t a, int64_t b) {
    if (b > 0 && a > INT64_MAX - b) {
        return INT64_MAX;
    }
    if (b < 0 && a < INT64_MIN - b) {
        return INT64_MIN;
    }
    return a + b;
}

int64_t fix_sat_sub_s64(int64_t a, int64_t b) {
    if (b < 0 && a > INT64_MAX + b) {
        return INT64_MAX;
    }
    if (b > 0 && a < INT64_MIN + b) {
        return INT64_MIN;
    }
    return a - b;
}

uint64_t fix_abs_u64(int64_t v) {
    if (v >= 0) {
        return (uint64_t)v;
    }
    /* -(v + 1) cannot overflow, then add the 1 back in unsigned arithmetic. */
    return (uint64_t)(-(v + 1)) + 1u;
}

/* Signed value of magnitude m with sign neg; saturates (and flags) what int64 cannot hold. */
static int64_t from_sign_magnitude(bool neg, uint64_t m, bool *overflow) {
    if (!neg) {
        if (m > (uint64_t)INT64_MAX) {
            if (overflow != NULL) {
                *overflow = true;
            }
            return INT64_MAX;
        }
        return (int64_t)m;
    }
    if (m > U64_SIGN_BIT) {
        if (overflow != NULL) {
            *overflow = true;
        }
        return INT64_MIN;
    }
    if (m == U64_SIGN_BIT) {
        return INT64_MIN;
    }
    return -(int64_t)m;
}

int64_t fix_sat_mul_s64(int64_t a, int64_t b) {
    return fix_s128_to_s64(fix_s128_mul(a, b), NULL);
}

int64_t fix_asr_s64(int64_t v, unsigned shift) {
    if (shift == 0u) {
        return v;
    }
    if (v >= 0) {
        const uint64_t q = (uint64_t)v >> shift;
        return (int64_t)q;
    }
    /* floor(v / 2^s) = -(((-v - 1) >> s)) - 1 for v < 0. */
    const int64_t m = -(v + 1);
    const uint64_t q = (uint64_t)m >> shift;
    return -(int64_t)q - 1;
}

int64_t fix_shr_round_s64(int64_t v, unsigned shift) {
    if (shift == 0u) {
        return v;
    }
    const uint64_t m = fix_abs_u64(v);
    const uint64_t r = (m + ((uint64_t)1 << (shift - 1u))) >> shift;
    return from_sign_magnitude(v < 0, r, NULL);
}

int64_t fix_div_round_s64(int64_t num, int64_t den) {
    if (den == 0) {
        return 0; /* contract violation; defined result instead of a trap */
    }
    const uint64_t mn = fix_abs_u64(num);
    const uint64_t md = fix_abs_u64(den);
    /* mn <= 2^63 and md / 2 <= 2^62: the sum cannot wrap. */
    const uint64_t q = (mn + md / 2u) / md;
    return from_sign_magnitude((num < 0) != (den < 0), q, NULL);
}

int64_t fix_div_trunc_s64(int64_t num, int64_t den) {
    if (den == 0) {
        return 0; /* contract violation; defined result instead of a trap */
    }
    return from_sign_magnitude((num < 0) != (den < 0), fix_abs_u64(num) / fix_abs_u64(den), NULL);
}

fix_q30_t fix_recip_q30(fix_q30_t den) {
    return fix_div_round_s64((int64_t)1 << 60, den);
}

uint32_t fix_isqrt_u64(uint64_t v) {
    uint64_t rem = v;
    uint64_t root = 0;
    uint64_t bit = (uint64_t)1 << 62;
    for (unsigned i = 0; i < 32u && bit > rem; ++i) {
        bit >>= 2;
    }
    for (unsigned i = 0; i < 32u && bit != 0u; ++i) {
        if (rem >= root + bit) {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    return (uint32_t)root;
}

/* --- 128-bit ------------------------------------------------------------------ */

fix_s128 fix_s128_from_s64(int64_t v) {
    fix_s128 r;
    r.lo = (uint64_t)v; /* two's complement bits (C11 6.3.1.3: modulo 2^64) */
    r.hi = v < 0 ? UINT64_MAX : 0u;
    return r;
}

fix_s128 fix_s128_add(fix_s128 a, fix_s128 b) {
    fix_s128 r;
    r.lo = a.lo + b.lo;
    r.hi = a.hi + b.hi + (r.lo < a.lo ? 1u : 0u);
    return r;
}

fix_s128 fix_s128_neg(fix_s128 a) {
    fix_s128 inverted; /* two's complement: ~a + 1 */
    inverted.hi = ~a.hi;
    inverted.lo = ~a.lo;
    return fix_s128_add(inverted, fix_s128_from_s64(1));
}

fix_s128 fix_s128_sub(fix_s128 a, fix_s128 b) {
    return fix_s128_add(a, fix_s128_neg(b));
}

bool fix_s128_is_neg(fix_s128 a) {
    return (a.hi & U64_SIGN_BIT) != 0u;
}

int fix_s128_cmp(fix_s128 a, fix_s128 b) {
    const uint64_t ah = a.hi ^ U64_SIGN_BIT; /* order signed values as unsigned ones */
    const uint64_t bh = b.hi ^ U64_SIGN_BIT;
    if (ah != bh) {
        return ah < bh ? -1 : 1;
    }
    if (a.lo != b.lo) {
        return a.lo < b.lo ? -1 : 1;
    }
    return 0;
}

/* Unsigned 64 x 64 -> 128 from four 32 x 32 -> 64 partial products. */
static fix_s128 mul_u64(uint64_t a, uint64_t b) {
    const uint64_t a_lo = a & 0xFFFFFFFFu;
    const uint64_t a_hi = a >> 32;
    const uint64_t b_lo = b & 0xFFFFFFFFu;
    const uint64_t b_hi = b >> 32;
    const uint64_t p0 = a_lo * b_lo;
    const uint64_t p1 = a_lo * b_hi;
    const uint64_t p2 = a_hi * b_lo;
    const uint64_t p3 = a_hi * b_hi;
    const uint64_t mid = (p0 >> 32) + (p1 & 0xFFFFFFFFu) + (p2 & 0xFFFFFFFFu);
    fix_s128 r;
    r.lo = (mid << 32) | (p0 & 0xFFFFFFFFu);
    r.hi = p3 + (p1 >> 32) + (p2 >> 32) + (mid >> 32);
    return r;
}

fix_s128 fix_s128_mul(int64_t a, int64_t b) {
    const fix_s128 m = mul_u64(fix_abs_u64(a), fix_abs_u64(b));
    return ((a < 0) != (b < 0)) ? fix_s128_neg(m) : m;
}

fix_s128 fix_s128_shl(fix_s128 a, unsigned shift) {
    fix_s128 r = a;
    if (shift == 0u) {
        return r;
    }
    if (shift < 64u) {
        r.hi = (a.hi << shift) | (a.lo >> (64u - shift));
        r.lo = a.lo << shift;
    } else {
        r.hi = shift < 128u ? a.lo << (shift - 64u) : 0u;
        r.lo = 0u;
    }
    return r;
}

/* Logical right shift of a 128-bit magnitude. */
static fix_s128 shr_u128(fix_s128 a, unsigned shift) {
    fix_s128 r = a;
    if (shift == 0u) {
        return r;
    }
    if (shift < 64u) {
        r.lo = (a.lo >> shift) | (a.hi << (64u - shift));
        r.hi = a.hi >> shift;
    } else {
        r.lo = shift < 128u ? a.hi >> (shift - 64u) : 0u;
        r.hi = 0u;
    }
    return r;
}

fix_s128 fix_s128_shr_round(fix_s128 a, unsigned shift) {
    if (shift == 0u) {
        return a;
    }
    const bool neg = fix_s128_is_neg(a);
    fix_s128 m = neg ? fix_s128_neg(a) : a;
    const fix_s128 half = fix_s128_shl(fix_s128_from_s64(1), shift - 1u);
    m = shr_u128(fix_s128_add(m, half), shift);
    return neg ? fix_s128_neg(m) : m;
}

int64_t fix_s128_to_s64(fix_s128 a, bool *overflow) {
    if (a.hi == 0u && a.lo <= (uint64_t)INT64_MAX) {
        return (int64_t)a.lo;
    }
    if (a.hi == UINT64_MAX && a.lo >= U64_SIGN_BIT) {
        return from_sign_magnitude(true, ~a.lo + 1u, overflow);
    }
    if (overflow != NULL) {
        *overflow = true;
    }
    return fix_s128_is_neg(a) ? INT64_MIN : INT64_MAX;
}

/* One quotient digit (base 2^32) of Knuth's Algorithm D (TAOCP vol. 2, 4.3.1) for the
 * normalised divisor dn = d1 2^32 + d0 (d1 >= 2^31): the digit of (top 2^32 + next) / dn
 * for top < dn, estimated from top / d1 and corrected at most twice; *rest receives the
 * remainder, < dn. */
FIX_INLINE uint64_t knuth_digit(uint64_t top, uint32_t next, uint64_t dn, uint64_t *rest) {
    const uint64_t d1 = dn >> 32;
    const uint64_t d0 = dn & 0xFFFFFFFFu;
    uint64_t qhat = top / d1;
    uint64_t rhat = top - qhat * d1;
    bool done = false;
    for (unsigned fix = 0; fix < 2u && !done; ++fix) { /* the estimate exceeds the digit by <= 2 */
        if (qhat <= 0xFFFFFFFFu && qhat * d0 <= ((rhat << 32) | next)) {
            done = true;
        } else {
            --qhat;
            rhat += d1;
            done = rhat > 0xFFFFFFFFu;
        }
    }
    /* modulo 2^64: the true remainder lies in [0, dn) */
    *rest = ((top << 32) | next) - qhat * dn;
    return qhat;
}

/* (hi 2^64 + lo) / d for 2^32 < d and hi < d (the quotient fits 64 bits): two digits of
 * Algorithm D on the divisor shifted to its top bit; *rem receives the remainder. */
FIX_INLINE uint64_t divu_128_64(uint64_t hi, uint64_t lo, uint64_t d, uint64_t *rem) {
    const unsigned s = 64u - fix_bitlen_u64(d); /* 0..31 */
    const uint64_t dn = d << s;
    const uint64_t u1 = s == 0u ? hi : (hi << s) | (lo >> (64u - s)); /* < dn */
    const uint64_t u0 = lo << s;
    uint64_t mid;
    const uint64_t q1 = knuth_digit(u1, (uint32_t)(u0 >> 32), dn, &mid);
    uint64_t low;
    const uint64_t q0 = knuth_digit(mid, (uint32_t)u0, dn, &low);
    *rem = low >> s;
    return (q1 << 32) | q0;
}

int64_t fix_s128_div_s64(fix_s128 a, int64_t den, bool *overflow) {
    if (den == 0) {
        if (overflow != NULL) {
            *overflow = true;
        }
        return 0;
    }
    const bool neg = fix_s128_is_neg(a) != (den < 0);
    const fix_s128 m = fix_s128_is_neg(a) ? fix_s128_neg(a) : a;
    const uint64_t d = fix_abs_u64(den);
    uint64_t q;
    uint64_t r;
    if (m.hi == 0u) {
        q = m.lo / d;
        r = m.lo % d;
    } else if (m.hi >= d) {
        if (overflow != NULL) {
            *overflow = true; /* quotient >= 2^64 */
        }
        return neg ? INT64_MIN : INT64_MAX;
    } else if (d <= UINT32_MAX) {
        /* A 32-bit divisor: schoolbook on 32-bit digits (m < 2^96 since m.hi < d), each
         * a 64-by-32 step whose quotient digit fits 32 bits (the remainder stays < d). */
        const uint64_t c2 = (m.hi << 32) | (m.lo >> 32);
        const uint64_t q2 = c2 / d;
        const uint64_t c1 = ((c2 - q2 * d) << 32) | (m.lo & 0xFFFFFFFFu);
        const uint64_t q1 = c1 / d;
        r = c1 - q1 * d;
        q = (q2 << 32) | q1;
    } else {
        q = divu_128_64(m.hi, m.lo, d, &r);
    }
    if (r >= d - r) { /* 2r >= d: round half away from zero */
        if (q == UINT64_MAX) {
            if (overflow != NULL) {
                *overflow = true;
            }
            return neg ? INT64_MIN : INT64_MAX;
        }
        ++q;
    }
    return from_sign_magnitude(neg, q, overflow);
}

int64_t fix_muldiv_s64(int64_t a, int64_t b, int64_t den, bool *overflow) {
    return fix_s128_div_s64(fix_s128_mul(a, b), den, overflow);
}

int64_t fix_mul_shr_s64(int64_t a, int64_t b, unsigned shift, bool *overflow) {
    return fix_s128_to_s64(fix_s128_shr_round(fix_s128_mul(a, b), shift), overflow);
}

/* --- normalised 32-bit helpers (contracts in fixmath.h) -------------------------- */

uint32_t fix_norm31(uint64_t v, int32_t *e) {
    return fix_norm31_inline(v, e);
}

int32_t fix_recip31(uint32_t m) {
    return fix_recip31_inline(m);
}

int64_t fix_mul_q31(int64_t v, int32_t r) {
    return fix_mul_q31_inline(v, r);
}

uint64_t fix_div_u64_u16(uint64_t num, uint32_t den) {
    uint64_t q = 0;
    uint32_t rem = 0;
    for (unsigned i = 4u; i > 0u; --i) {
        const uint32_t chunk = (uint32_t)(num >> (16u * (i - 1u))) & 0xFFFFu;
        const uint32_t cur = (rem << 16) | chunk;
        const uint32_t qd = cur / den;
        rem = cur - qd * den;
        q = (q << 16) | qd;
    }
    return q;
}

/* --- atan2: vectoring CORDIC -------------------------------------------------- */

/* atan(2^-i) for i = 1..30 in micro-degrees x 32 (Q5), rounded. */
static const int32_t cordic_atan_udeg_q5[30] = {
    850081638, 449159791, 228000523, 114442700, 57277139, 28645559, 14323653, 7161936,
    3580982,   1790493,   895246,    447623,    223812,   111906,   55953,    27976,
    13988,     6994,      3497,      1749,      874,      437,      219,      109,
    55,        27,        14,        7,         3,        2};

/* Index of the most significant set bit of v != 0 (binary search, 6 steps). */
static unsigned msb_u64(uint64_t value) {
    uint64_t v = value;
    unsigned n = 0;
    static const unsigned widths[6] = {32u, 16u, 8u, 4u, 2u, 1u};
    for (unsigned i = 0; i < 6u; ++i) {
        if ((v >> widths[i]) != 0u) {
            v >>= widths[i];
            n += widths[i];
        }
    }
    return n;
}

/* v / 2^shift rounded, halves away from zero, on int32 (|v| < 2^31). */
static int32_t shr_round_s32(int32_t v, unsigned shift) {
    const uint32_t half = (uint32_t)1 << (shift - 1u);
    if (v >= 0) {
        const uint32_t q = ((uint32_t)v + half) >> shift;
        return (int32_t)q;
    }
    const int32_t m = -v;
    const uint32_t q = ((uint32_t)m + half) >> shift;
    return -(int32_t)q;
}

/* u / 2^shift rounded (shift 1..63). */
static uint64_t shr_round_u64(uint64_t u, unsigned shift) {
    return (u >> shift) + ((u >> (shift - 1u)) & 1u);
}

fix_udeg_t fix_atan2_udeg(int64_t y, int64_t x) {
    if (y == 0 && x == 0) {
        return 0;
    }
    const uint64_t ay = fix_abs_u64(y);
    const uint64_t ax = fix_abs_u64(x);
    const bool swapped = ay > ax; /* reduce to the first octant: angle in [0, 45] deg */
    uint64_t big = swapped ? ay : ax;
    uint64_t small = swapped ? ax : ay;

    /* Normalise big into [2^29, 2^30]: CORDIC gain 1.1644 (from i = 1) times
     * sqrt(2) keeps |x| below 2^31, and 29 bits give 1.9e-9 rad resolution. */
    const unsigned msb = msb_u64(big);
    if (msb < 29u) {
        big <<= 29u - msb;
        small <<= 29u - msb;
    } else if (msb > 29u) {
        big = shr_round_u64(big, msb - 29u);
        small = shr_round_u64(small, msb - 29u);
    } else {
        /* already normalised */
    }

    int32_t xs = (int32_t)big;
    int32_t ys = (int32_t)small;
    int32_t z = 0; /* micro-degrees x 32 */
    /* Starting at i = 1 covers |angle| <= 54.9 deg, enough for the octant. */
    for (unsigned i = 1; i <= 30u; ++i) {
        const int32_t dx = shr_round_s32(ys, i);
        const int32_t dy = shr_round_s32(xs, i);
        if (ys >= 0) {
            xs += dx;
            ys -= dy;
            z += cordic_atan_udeg_q5[i - 1u];
        } else {
            xs -= dx;
            ys += dy;
            z -= cordic_atan_udeg_q5[i - 1u];
        }
    }
    int32_t theta = shr_round_s32(z, 5u);
    if (swapped) {
        theta = FIX_UDEG_90 - theta;
    }
    if (x < 0) {
        theta = FIX_UDEG_180 - theta;
    }
    return y < 0 ? -theta : theta;
}

/* --- atan of a slope within ±1: cubic Hermite table (fixmath_internal.h) ---------- */

/* atan at t_k = k/64 and its tangent (1/64)/(1 + t_k²), both in udeg x 16, rounded:
 * generated by tools/gen_atan_table.py, recomputed in double and checked by
 * tests/estimator/test_fixmath.c. */
const int32_t fix_atan_nodes[FIX_ATAN_SEGMENTS + 1u][2] = {
    {0, 14323945},         {14322779, 14320449},  {28638570, 14309970},  {42940403, 14292540},
    {57221350, 14268210},  {71474545, 14237049},  {85693201, 14199148},  {99870630, 14154615},
    {114000262, 14103576}, {128075662, 14046176}, {142090546, 13982573}, {156038799, 13912942},
    {169914484, 13837471}, {183711862, 13756361}, {197425396, 13669823}, {211049771, 13578079},
    {224579895, 13481360}, {238010912, 13379904}, {251338205, 13273954}, {264557406, 13163760},
    {277664394, 13049573}, {290655304, 12931646}, {303526525, 12810235}, {316274699, 12685595},
    {328896724, 12557979}, {341389749, 12427638}, {353751174, 12294819}, {365978643, 12159768},
    {378070044, 12022721}, {390023498, 11883913}, {401837358, 11743571}, {413510201, 11601914},
    {425040819, 11459156}, {436428214, 11315502}, {447671590, 11171150}, {458770344, 11026288},
    {469724057, 10881098}, {480532487, 10735751}, {491195561, 10590411}, {501713364, 10445234},
    {512086131, 10300365}, {522314242, 10155942}, {532398208, 10012095}, {542338665, 9868945},
    {552136368, 9726604},  {561792179, 9585179},  {571307062, 9444765},  {580682076, 9305453},
    {589918362, 9167325},  {599017145, 9030457},  {607979719, 8894918},  {616807445, 8760770},
    {625501742, 8628070},  {634064085, 8496869},  {642495994, 8367210},  {650799033, 8239135},
    {658974803, 8112677},  {667024936, 7987866},  {674951093, 7864729},  {682754959, 7743286},
    {690438236, 7623555},  {698002644, 7505549},  {705449913, 7389279},  {712781783, 7274752},
    {720000000, 7161972},
};

fix_udeg_t fix_atan_unit_q31_udeg(uint32_t t31) {
    return fix_atan_q31_inline(t31);
}

fix_udeg_t fix_atan_q32_udeg(fix_q32_t t) {
    const uint64_t m = fix_abs_u64(t);
    if (m >= (uint64_t)FIX_Q32_ONE) {
        return fix_atan2_udeg(t, FIX_Q32_ONE); /* beyond ±45°: the CORDIC */
    }
    const fix_udeg_t a = fix_atan_q31_inline((uint32_t)(m >> 1));
    return t < 0 ? -a : a;
}

fix_udeg_t fix_udeg_from_rad_q32(fix_q32_t rad) {
    return fix_sat_s32(fix_mul_shr_s64(rad, FIX_UDEG_PER_RAD, FIX_Q32_SHIFT, NULL));
}

/* sqrt(v) for v in [2^62, 2^64), in [2^31, 2^32), relative error < 2^-27: the 16-bit
 * integer root of the top word (16 exact steps), then one Newton step y + v/y with the
 * quotient from the reciprocal of y (fix_recip31), multiplications only. */
static uint32_t sqrt_top(uint64_t v) {
    const uint32_t top = (uint32_t)(v >> 32); /* >= 2^30 */
    uint32_t rem = top;
    uint32_t root = 0;
    uint32_t bit = (uint32_t)1 << 30;
    for (unsigned i = 0; i < 16u; ++i) {
        if (rem >= root + bit) {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    /* y = root · 2^16 in [2^31, 2^32), y <= sqrt(v) < y + 2^17; with rm = 2^61 / (y / 2)
     * = 2^46 / root: v / y ≈ (v / 2^32) · 2^16 / root = top · rm / 2^30 (the low word of v
     * is below 2^-30 of it) */
    const uint32_t y_half = root << 15; /* y / 2 in [2^30, 2^31) */
    const int32_t rm = fix_recip31(y_half);
    const uint64_t q = ((uint64_t)top * (uint32_t)rm) >> 30; /* ≈ v / y, < 2^33 */
    const uint64_t y2 = ((uint64_t)root << 16) + q;          /* y + v/y */
    const uint64_t r = y2 >> 1;
    return r > UINT32_MAX ? UINT32_MAX : (uint32_t)r;
}

fix_udeg_t fix_angle_sigma_udeg(fix_q32_t var_mm2, int32_t arm_um, fix_q32_t tan_q32) {
    if (var_mm2 <= 0 || arm_um <= 0) {
        return var_mm2 == 0 ? 0 : INT32_MAX;
    }
    /* σ(a·t) in mm: var = v · 4^-h with v in [2^62, 2^64), sqrt(var) = sqrt(v) · 2^-h, Q16 */
    const unsigned h = (64u - fix_bitlen_u64((uint64_t)var_mm2)) / 2u;
    const uint64_t root = sqrt_top((uint64_t)var_mm2 << (2u * h)); /* σ mm · 2^(16 + h) */
    /* σ(t) in Q32 = σ mm · 1000 / a_um: root · 1000 · 2^(16 − h) / a_um */
    const uint64_t num = root * 1000u; /* < 2^42 */
    uint64_t sd_t_q32;
    if (h <= 16u) {
        sd_t_q32 = (num << (16u - h)) / (uint64_t)arm_um; /* < 2^58 / 1000 */
    } else {
        sd_t_q32 = num / ((uint64_t)arm_um << (h - 16u)); /* divisor < 2^36 */
    }
    /* dα = dt / (1 + t²): den = (1 + t²) · 2^32; within 89.1° (|t| < 64) t² from |t| in
     * Q24 (to 2^-32 of den), den = dm · 2^es with dm in [2^30, 2^31) (es >= 2);
     * beyond, the exact 128-bit quotient */
    const uint64_t at = fix_abs_u64(tan_q32);
    int64_t sd_rad_q32;
    if (at < ((uint64_t)1 << 38)) {
        const uint64_t t24 = at >> 8;
        const uint64_t den = ((uint64_t)1 << 32) + ((t24 * t24) >> 16);
        int32_t es;
        const uint32_t dm = fix_norm31(den, &es);
        /* σ(α) in Q32 rad = σ(t) · 2^32 / den = σ(t) · rm / 2^(29 + es) */
        const int64_t part = fix_mul_q31((int64_t)sd_t_q32, fix_recip31(dm));
        sd_rad_q32 = fix_floor_shr_s64(part, (unsigned)(es >= 2 ? es - 2 : 0));
    } else {
        bool ovf = false;
        const int64_t den =
            fix_sat_add_s64(FIX_Q32_ONE, fix_mul_shr_s64(tan_q32, tan_q32, FIX_Q32_SHIFT, &ovf));
        sd_rad_q32 = fix_muldiv_s64((int64_t)sd_t_q32, FIX_Q32_ONE, den, &ovf);
        if (ovf) {
            return INT32_MAX; /* t² beyond 2^31 (89.998°): as before, no meaningful value */
        }
    }
    /* udeg · 2^6 = rad (Q32) · 57295779.513 / 2^26: times 57295779.513 · 2^5 in Q31 */
    const int64_t udeg_x64 = fix_mul_q31(sd_rad_q32, 1833464944);
    const int64_t udeg = fix_floor_shr_s64(udeg_x64 + 32, 6u);
    return udeg > INT32_MAX ? INT32_MAX : (fix_udeg_t)udeg;
}
