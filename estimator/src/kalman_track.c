/* The Kalman filter's update, the covariance form for any Q (the one filter of every build):
 * see estimator/kalman.h. */
#include <string.h>

#include "kalman_internal.h"

/* Rows of Eq. 5 with the slopes scaled by a: A [1, −1, 0], B [1, 0, 1], C [1, 1, 0],
 * D [1, 0, −1]: h = e0 + σ e_j (update_exact, block_update). */

static void diffuse_covariance(struct kalman_state *k) {
    struct kalman_cov *cv = &k->cov;
    cv->bvalid = false;
    cv->steady = false;
    cv->predict_pending = false;
    cv->still = false;
    cv->still_broken = false;
    (void)memset(cv->p, 0, sizeof cv->p);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        cv->p[i][i] = KALMAN_P0_MM2_Q32;
    }
}

/* Necessary conditions for positive definiteness that fixed-point failures
 * break first: a positive diagonal and every correlation strictly inside ±1.
 * |P_ij| < min(P_ii, P_jj) already implies P_ij² < P_ii P_jj (the common case, two
 * comparisons); only the rest needs the exact 128-bit products. */
static bool covariance_healthy(const fix_q32_t p[KALMAN_STATES][KALMAN_STATES]) {
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        if (p[i][i] <= 0) {
            return false;
        }
    }
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        for (unsigned j = i + 1u; j < KALMAN_STATES; ++j) {
            if (p[i][j] != p[j][i]) {
                return false;
            }
            const uint64_t c = fix_abs_u64(p[i][j]);
            if (c < (uint64_t)p[i][i] && c < (uint64_t)p[j][j]) {
                continue;
            }
            if (fix_s128_cmp(fix_s128_mul(p[i][j], p[i][j]), fix_s128_mul(p[i][i], p[j][j])) >= 0) {
                return false;
            }
        }
    }
    return true;
}

/* The general update: the Joseph form P − k gᵀ − g kᵀ + s k kᵀ with the Q30 gain,
 * every entry from exact 128-bit products with one rounding. */
static void joseph_update(struct kalman_state *k, const fix_q32_t g[KALMAN_STATES], fix_q32_t s,
                          fix_q32_t e, bool *ovf) {
    struct kalman_cov *cv = &k->cov;
    fix_q30_t gain[KALMAN_STATES];
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        gain[i] = fix_muldiv_s64(g[i], FIX_Q30_ONE, s, ovf);
    }
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        /* A gain far above 1 (a direction an ill-conditioned P barely resolves) times a
         * large innovation can throw the state out of any physical range, and then the
         * predictions h·x out of int64: flagged (the covariance restarts), the state kept
         * within ±KALMAN_X_LIMIT_Q32. (Found by the fuzzers.) */
        const int64_t dx = fix_mul_shr_s64(gain[i], e, FIX_Q30_SHIFT, ovf);
        if (dx > 0 ? k->x[i] > KALMAN_X_LIMIT_Q32 - dx : k->x[i] < -KALMAN_X_LIMIT_Q32 - dx) {
            *ovf = true;
        } else {
            k->x[i] += dx;
        }
    }
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        const fix_q32_t sk_i = fix_mul_shr_s64(s, gain[i], FIX_Q30_SHIFT, ovf);
        for (unsigned j = i; j < KALMAN_STATES; ++j) {
            const fix_s128 t1 =
                fix_s128_add(fix_s128_mul(gain[i], g[j]), fix_s128_mul(g[i], gain[j]));
            const fix_s128 t2 = fix_s128_mul(sk_i, gain[j]);
            const int64_t d =
                fix_s128_to_s64(fix_s128_shr_round(fix_s128_sub(t1, t2), FIX_Q30_SHIFT), ovf);
            cv->p[i][j] -= d;
            cv->p[j][i] = cv->p[i][j];
        }
    }
}

/* One scalar update on the full Q32 covariance (the exact Joseph form), with the gate;
 * no definiteness check. */
static bool update_exact(struct kalman_state *k, unsigned sensor, fix_q32_t z_mm, bool gate,
                         bool *ovf) {
    struct kalman_cov *cv = &k->cov;
    const unsigned j = kalman_h_index(sensor);
    const bool minus = kalman_h_minus(sensor);
    fix_q32_t g[KALMAN_STATES];
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        g[i] = minus ? cv->p[i][0] - cv->p[i][j] : cv->p[i][0] + cv->p[i][j];
    }
    const fix_q32_t hph = minus ? g[0] - g[j] : g[0] + g[j];
    const fix_q32_t pred = minus ? k->x[0] - k->x[j] : k->x[0] + k->x[j];
    const fix_q32_t s = hph + k->r[sensor];
    const fix_q32_t e = z_mm - pred;
    if (gate && k->cfg.gate_sigmas_q8 != 0u && kalman_gated_out(k, e, s)) {
        return false;
    }
    joseph_update(k, g, s, e, ovf);
    return true;
}

/* --- the block update ------------------------------------------------------------------
 * Once every state is observed, P is well scaled and the Joseph form's 128-bit products
 * are wasted. P is then also held as 32-bit mantissas sharing one exponent, bm · 2^be
 * (taken from p with the largest diagonal in [2^27, 2^28), afresh every 16 rows, when
 * that diagonal has shrunk below 2^27, and after anything else changed p). The updates
 * run on the mantissas with 32x32 -> 64 products; the exact products they subtract are
 * summed in 64 bits and applied to the Q32 covariance at the end of the row, one rounding
 * per entry, so p keeps its full precision. Conditions (else the exact update on p):
 * every diagonal at least 2^-10 of the largest, the measurement's prior variance hᵀPh
 * between 2^-6 of the largest diagonal and 4 R (the directions the update touches are
 * resolved by the mantissas: this excludes the diffuse start), every gain |k_i| below 1,
 * |e| below 128 mm.
 *
 * Precision: the gain k = g/s in Q31 (Newton reciprocal of s, relative error < 2^-28)
 * and P' = P − g kᵀ (upper triangle, mirrored). Its difference from the Joseph form with
 * the same gain, P − g kᵀ − k gᵀ + s k kᵀ, is (g − s k)kᵀ = −s d kᵀ with d = k − g/s the
 * gain error: at most 2^-27 |g||k| per entry, below 2^-27 of the entry's own decrease.
 * g comes from the mantissas, within a few units (2^-27 of the largest diagonal each) of
 * p, which moves each decrease by a few units times |k|. Along h the posterior variance
 * R (s − R)/s is at least 2^-9 of the largest diagonal (hᵀPh >= 2^-6 of it, s <= 5 R),
 * so the update keeps P positive definite wherever the exact one does.
 * tests/estimator/ref_tracking.cpp compares P with double within 1e-6 relative + 64 LSB. */

#define BLOCK_TOP_BITS     28                 /* largest diagonal mantissa in [2^27, 2^28) */
#define BLOCK_MIN_DIAG     ((int32_t)1 << 17) /* every diagonal >= 2^-10 of the largest */
#define BLOCK_MIN_HPH      ((int32_t)1 << 21) /* hᵀPh >= 2^-6 of the largest diagonal */
#define BLOCK_NOT_POSSIBLE 2

/* The exact sum of what a row's block updates subtracted from each entry (packed
 * upper triangle 00 01 02 11 12 22), in units of 2^(e − 31). */
struct pblock {
    int64_t dec[6];
};

/* Rows a block may live before it is taken afresh from p: its mantissas drift from p by
 * up to one half unit of rounding per update (p itself receives the exact sums), and
 * that drift moves the later decreases by |k| units each (tests/estimator/ref_tracking.cpp: 16 rows
 * keep P within 6 LSB of its exact-block value, 64 rows within 26). */
#define BLOCK_MAX_ROWS 16u
/* Margin of the cheap definiteness check on the mantissas, in block units: larger than
 * that drift (4 updates x 16 rows x 1/2) plus the rounding of taking the block. */
#define BLOCK_CHECK_MARGIN ((int32_t)1 << 10)

/* R in block units when it is this large or larger: it does not fit the block's s = hᵀPh + R
 * below 2^62 (R up to 2^52 scaled by up to 2^30 would overflow int64), so block_update()
 * leaves such a measurement to the exact update. (Found by the fuzzers.) */
#define BLOCK_R_TOO_LARGE ((int64_t)1 << 61)

/* R of `sensor` in block units (exponent e), at most BLOCK_R_TOO_LARGE. */
static int64_t block_r(const struct kalman_state *k, unsigned sensor, int32_t e) {
    const int64_t r = k->r[sensor];
    if (e >= 0) {
        return fix_floor_shr_s64(r, (unsigned)e);
    }
    if (r >= (BLOCK_R_TOO_LARGE >> (unsigned)(-e))) {
        return BLOCK_R_TOO_LARGE;
    }
    return r * ((int64_t)1 << (unsigned)(-e));
}

/* p_ij · 2^-e rounded, as a block mantissa (|p_ij| <= max P_ii < 2^(28 + e)). */
FIX_INLINE int32_t to_block(int64_t v, int32_t e) {
    if (e > 0) {
        return fix_shr_to_s32(v + ((int64_t)1 << (unsigned)(e - 1)), (unsigned)e);
    }
    return (int32_t)(v * ((int64_t)1 << (unsigned)(-e)));
}

/* The block of the current p (cv->bm, cv->be); false when P is not well scaled for it. */
static bool block_from_p(struct kalman_state *k) {
    struct kalman_cov *cv = &k->cov;
    cv->bvalid = false;
    const int64_t d0 = cv->p[0][0];
    const int64_t d1 = cv->p[1][1];
    const int64_t d2 = cv->p[2][2];
    if (d0 <= 0 || d1 <= 0 || d2 <= 0) {
        return false;
    }
    const int64_t hi = d0 > d1 ? (d0 > d2 ? d0 : d2) : (d1 > d2 ? d1 : d2);
    const int32_t e = (int32_t)fix_bitlen_u64((uint64_t)hi) - BLOCK_TOP_BITS;
    if (e < -30 || e > 30) {
        return false; /* diffuse (P above 2^26 mm²) or below 2^-30 mm² */
    }
    /* |P_ij| <= max P_ii (the last check), so every mantissa fits; the diagonal floor
     * keeps every state resolved */
    int32_t *m = cv->bm;
    m[0] = to_block(d0, e);
    m[3] = to_block(d1, e);
    m[5] = to_block(d2, e);
    if (m[0] < BLOCK_MIN_DIAG || m[3] < BLOCK_MIN_DIAG || m[5] < BLOCK_MIN_DIAG) {
        return false;
    }
    m[1] = to_block(cv->p[0][1], e);
    m[2] = to_block(cv->p[0][2], e);
    m[4] = to_block(cv->p[1][2], e);
    cv->be = e;
    cv->brows = 0;
    cv->bvalid = true;
    return true;
}

/* The block for the next row: kept while it is fresh and its largest diagonal still has
 * 26 bits, else taken afresh from p. */
static bool block_ready(struct kalman_state *k) {
    struct kalman_cov *cv = &k->cov;
    if (cv->bvalid && cv->brows < BLOCK_MAX_ROWS) {
        const int32_t *m = cv->bm;
        const int32_t top = m[0] > m[3] ? (m[0] > m[5] ? m[0] : m[5]) : (m[3] > m[5] ? m[3] : m[5]);
        if (top >= ((int32_t)1 << (BLOCK_TOP_BITS - 1))) {
            return true;
        }
    }
    return block_from_p(k);
}

/* True when the mantissas prove p positive definite (kalman.h's check) with a margin
 * for their drift from p; false means "not proven" (then p itself is checked). */
static bool block_healthy(const struct kalman_state *k) {
    const struct kalman_cov *cv = &k->cov;
    const int32_t *m = cv->bm;
    const int32_t mg = BLOCK_CHECK_MARGIN;
    const int32_t d0 = m[0] - mg;
    const int32_t d1 = m[3] - mg;
    const int32_t d2 = m[5] - mg;
    const int32_t a01 = m[1] < 0 ? -m[1] : m[1];
    const int32_t a02 = m[2] < 0 ? -m[2] : m[2];
    const int32_t a12 = m[4] < 0 ? -m[4] : m[4];
    return d0 > 0 && d1 > 0 && d2 > 0 && a01 + mg < d0 && a01 + mg < d1 && a02 + mg < d0 &&
           a02 + mg < d2 && a12 + mg < d1 && a12 + mg < d2;
}

/* P −= dec · 2^(e − 31), one rounding per entry; dec starts again from 0. */
static void block_apply(struct kalman_state *k, struct pblock *b) {
    /* a loop over the packed upper triangle: cold code, half the bytes */
    struct kalman_cov *cv = &k->cov;
    const int32_t sh_signed = 31 - cv->be;
    const unsigned sh = (unsigned)sh_signed; /* in [1, 61] */
    for (unsigned i = 0; i < 6u; ++i) {
        const unsigned r = kalman_packed_row(i);
        const unsigned c = kalman_packed_col(i);
        cv->p[r][c] -= fix_round_shr_s64(b->dec[i], sh);
        cv->p[c][r] = cv->p[r][c];
        b->dec[i] = 0;
    }
}

/* The decrease t = g_i k_j of one entry: exactly into dec, rounded into the mantissa. */
FIX_INLINE void block_sub(struct kalman_state *k, struct pblock *b, unsigned idx, int64_t t) {
    struct kalman_cov *cv = &k->cov;
    b->dec[idx] += t;
    /* round(t / 2^31), |t| < 2^62: the floor is the two's complement bits (hi << 1) |
     * (lo >> 31), the rounding bit is bit 30 */
    const uint64_t u = (uint64_t)t;
    const uint32_t lo = (uint32_t)u;
    const uint32_t hi = (uint32_t)(u >> 32);
    const uint32_t q = ((hi << 1) | (lo >> 31)) + ((lo >> 30) & 1u);
    const uint32_t mantissa = (uint32_t)cv->bm[idx] - q;
    cv->bm[idx] = (int32_t)mantissa;
}

/* g = P h and hᵀPh of sensor's row h (Eq. 5: A [1, −1, 0], B [1, 0, 1], C [1, 1, 0],
 * D [1, 0, −1]) on the block's mantissas m, and the prediction h x. */
FIX_INLINE int32_t block_ph(const struct kalman_state *k, const int32_t *m, unsigned sensor,
                            int32_t g[KALMAN_STATES], fix_q32_t *pred_out) {
    int32_t hph;
    fix_q32_t pred;
    switch (sensor) {
    case ANGLES_A: /* h = [1, −1, 0] */
        g[0] = m[0] - m[1];
        g[1] = m[1] - m[3];
        g[2] = m[2] - m[4];
        hph = g[0] - g[1];
        pred = k->x[0] - k->x[1];
        break;
    case ANGLES_B: /* h = [1, 0, 1] */
        g[0] = m[0] + m[2];
        g[1] = m[1] + m[4];
        g[2] = m[2] + m[5];
        hph = g[0] + g[2];
        pred = k->x[0] + k->x[2];
        break;
    case ANGLES_C: /* h = [1, 1, 0] */
        g[0] = m[0] + m[1];
        g[1] = m[1] + m[3];
        g[2] = m[2] + m[4];
        hph = g[0] + g[1];
        pred = k->x[0] + k->x[1];
        break;
    default: /* D: h = [1, 0, −1] */
        g[0] = m[0] - m[2];
        g[1] = m[1] - m[4];
        g[2] = m[2] - m[5];
        hph = g[0] - g[2];
        pred = k->x[0] - k->x[2];
        break;
    }
    *pred_out = pred;
    return hph;
}

/* The accepted update itself: gains g / s_b in Q31 (kept for the steady state), x += k e,
 * P −= g kᵀ on the block. Returns 1, or BLOCK_NOT_POSSIBLE (nothing changed) when s_b is
 * outside the range the normalisation covers. */
FIX_INLINE int block_accept(struct kalman_state *k, struct pblock *b, unsigned sensor,
                            const int32_t g[KALMAN_STATES], int64_t s_b, int32_t e24) {
    struct kalman_cov *cv = &k->cov;
    /* s_b = sm · 2^es, sm in [2^30, 2^31); rm ≈ 2^61 / sm (relative error < 2^-28) */
    int32_t es;
    const uint32_t sm = fix_norm31_inline((uint64_t)s_b, &es);
    if (es < -9 || es > 31) {
        return BLOCK_NOT_POSSIBLE; /* unreachable: 2^21 <= s_b < 2^62 */
    }
    const int32_t rm = fix_recip31_inline(sm);
    /* gains in Q31: k = g · 2^31 / s_b = g · rm / 2^(30 + es), |k| < 1 */
    const int32_t gain_shift_signed = 30 + es;
    const unsigned gain_shift = (unsigned)gain_shift_signed; /* in [20, 61] */
    const int32_t k0 = fix_shr_to_s32((int64_t)g[0] * rm, gain_shift);
    const int32_t k1 = fix_shr_to_s32((int64_t)g[1] * rm, gain_shift);
    const int32_t k2 = fix_shr_to_s32((int64_t)g[2] * rm, gain_shift);
    cv->gain[sensor][0] = k0; /* for the steady state (kalman_track_row) */
    cv->gain[sensor][1] = k1;
    cv->gain[sensor][2] = k2;
    /* x += k e: Q31 x Q24 = Q55 -> Q32 */
    k->x[0] += fix_round_shr_s64((int64_t)k0 * e24, 23u);
    k->x[1] += fix_round_shr_s64((int64_t)k1 * e24, 23u);
    k->x[2] += fix_round_shr_s64((int64_t)k2 * e24, 23u);
    /* P −= g kᵀ: exactly into dec, rounded to the block unit for the row's next update */
    block_sub(k, b, 0u, (int64_t)g[0] * k0);
    block_sub(k, b, 1u, (int64_t)g[0] * k1);
    block_sub(k, b, 2u, (int64_t)g[0] * k2);
    block_sub(k, b, 3u, (int64_t)g[1] * k1);
    block_sub(k, b, 4u, (int64_t)g[1] * k2);
    block_sub(k, b, 5u, (int64_t)g[2] * k2);
    return 1;
}

/* One scalar update on the block: 1 accepted, 0 gated out, BLOCK_NOT_POSSIBLE when the
 * conditions above fail (nothing changed). */
static int block_update(struct kalman_state *k, struct pblock *b, unsigned sensor, fix_q32_t z_mm,
                        bool gate) {
    struct kalman_cov *cv = &k->cov;
    int32_t *m = cv->bm;
    /* The int32 sums below rely on |m| <= max P_ii < 2^28, true of a block when it is
     * taken; a nearly singular P can lose it inside a row (the updates overshoot and a
     * diagonal turns negative: found by the fuzzers). Such a row goes on exactly, and the
     * definiteness check at its end sees what happened. Each m + 2^28 is below 2^29
     * exactly when its bits from 29 up are clear, so one test of their OR checks all six
     * (a sixth of a row's cost as a loop of compares). */
    const uint32_t bias = (uint32_t)1 << BLOCK_TOP_BITS;
    const uint32_t any_high = ((uint32_t)m[0] + bias) | ((uint32_t)m[1] + bias) |
                              ((uint32_t)m[2] + bias) | ((uint32_t)m[3] + bias) |
                              ((uint32_t)m[4] + bias) | ((uint32_t)m[5] + bias);
    if ((any_high >> (BLOCK_TOP_BITS + 1)) != 0u) {
        return BLOCK_NOT_POSSIBLE;
    }
    int32_t g[KALMAN_STATES]; /* |g_i| <= 2 max P_ii < 2^29 */
    fix_q32_t pred;
    const int32_t hph = block_ph(k, m, sensor, g, &pred);
    const fix_q32_t e = z_mm - pred;
    /* e in [−2^39, 2^39) (128 mm) exactly when its high word is in [−128, 127]; then e24
     * below fits int32 and |k e24| < 2^62 */
    const uint32_t e_hi = (uint32_t)((uint64_t)e >> 32) + 128u;
    const int64_t r_b = block_r(k, sensor, cv->be);
    /* hᵀPh <= 4 R (hph >= 1 here: hph > 4 r_b exactly when (hph − 1)/4 >= r_b); an R too
     * large for the block units never takes this path */
    if (hph < BLOCK_MIN_HPH || ((hph - 1) >> 2) >= r_b || r_b >= BLOCK_R_TOO_LARGE || e_hi > 255u) {
        return BLOCK_NOT_POSSIBLE;
    }
    const int64_t s_b = hph + r_b; /* in [2^21, 2^62) */
    if (s_b < ((int64_t)1 << 30)) {
        /* small s: check |g_i| < s (1 − 2^-8), so every gain is below 1 (for s >= 2^30
         * it holds already: |g_i| < 2^29) */
        const int32_t limit = (int32_t)(s_b - (s_b >> 8));
        for (unsigned i = 0; i < KALMAN_STATES; ++i) {
            if (g[i] >= limit || g[i] <= -limit) {
                return BLOCK_NOT_POSSIBLE;
            }
        }
    }
    const int32_t e24 = fix_shr_to_s32(e + 128, 8u); /* innovation in Q24, rounded */
    const int64_t e24_sq = (int64_t)e24 * e24;
    if (gate && k->cfg.gate_sigmas_q8 != 0u && (uint64_t)e24_sq > k->gate_accept[sensor]) {
        /* not surely inside: the gate on the exact s */
        const fix_q32_t s = (cv->be >= 0 ? (int64_t)hph * ((int64_t)1 << (unsigned)cv->be)
                                         : fix_floor_shr_s64(hph, (unsigned)(-cv->be))) +
                            k->r[sensor];
        if (kalman_gated_out(k, e, s)) {
            return 0;
        }
    }
    return block_accept(k, b, sensor, g, s_b, e24);
}

/* The valid readings of one row, A..D: block updates while they apply, exact ones
 * otherwise; p is current on return. Returns the sensors accepted; *rejected gets those
 * gated out; *proven is set when the block shows P positive definite. */
static uint8_t update_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                          uint8_t valid_mask, bool gate, uint8_t *rejected, bool *ovf, bool *proven,
                          uint8_t *by_block) {
    struct kalman_cov *cv = &k->cov;
    struct pblock b = {{0, 0, 0, 0, 0, 0}};
    bool have = block_ready(k);
    bool dirty = false;
    uint8_t used = 0;
    *rejected = 0;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if ((valid_mask & (1u << s)) == 0u) {
            continue;
        }
        const fix_q32_t z = (fix_q32_t)range_mm[s] << FIX_Q32_SHIFT;
        int res = have ? block_update(k, &b, s, z, gate) : BLOCK_NOT_POSSIBLE;
        if (res == BLOCK_NOT_POSSIBLE) {
            if (dirty) {
                block_apply(k, &b);
                dirty = false;
            }
            res = update_exact(k, s, z, gate, ovf) ? 1 : 0;
            if (res != 0) {
                have = block_from_p(k);
            }
        } else {
            dirty = dirty || res != 0;
            *by_block = (uint8_t)(*by_block | (1u << s));
        }
        if (res != 0) {
            used = (uint8_t)(used | (1u << s));
        } else {
            *rejected = (uint8_t)(*rejected | (1u << s));
        }
    }
    if (dirty) {
        block_apply(k, &b);
    }
    if (cv->bvalid) {
        cv->brows++;
    }
    /* The mantissas prove p only while a block unit is at least one LSB of p (be >= 0):
     * finer units leave p's own rounding (half an LSB per entry) outside the margin, and
     * a P of a few LSB (sliding windows, Q = 0, long runs) could round to singular
     * unseen. (Found by the fuzzers.) */
    *proven = cv->bvalid && cv->be >= 0 && block_healthy(k);
    return used;
}

/* After a failed check or an overflow: forget the covariance, keep the state; counted,
 * never silent. */
static void check_covariance(struct kalman_state *k, bool ovf, bool proven) {
    struct kalman_cov *cv = &k->cov;
    if (ovf || (!proven && !covariance_healthy(cv->p))) {
        diffuse_covariance(k);
        k->numeric_restarts++;
        k->restarts++;
    }
}

/* P += Q, each diagonal bounded. */
static void add_process_noise(struct kalman_state *k) {
    struct kalman_cov *cv = &k->cov;
    cv->bvalid = false; /* p changes outside the block */
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        if (cv->p[i][i] < KALMAN_P_MAX_Q32) { /* a long outage saturates here, never overflows */
            const int64_t grown = cv->p[i][i] + k->cfg.process_noise_mm2[i];
            cv->p[i][i] = grown < KALMAN_P_MAX_Q32 ? grown : KALMAN_P_MAX_Q32;
        }
    }
}

/* The prediction is applied by the row that follows it (kalman_track_row): a steady row
 * leaves P at its fixed point, so it needs none. */
void kalman_track_predict(struct kalman_state *k) {
    struct kalman_cov *cv = &k->cov;
    if (cv->predict_pending) {
        add_process_noise(k); /* the previous one, whose row had no reading */
    }
    cv->predict_pending = true;
}

void kalman_track_reset(struct kalman_state *k) {
    diffuse_covariance(k);
}

void kalman_track_r_changed(struct kalman_state *k) {
    k->cov.steady = false; /* the fixed point moved */
    if (k->cov.still) {
        kalman_static_leave(k); /* P of the old R */
    }
    k->cov.still_broken = true; /* the rows so far were weighed with the old R */
}

uint8_t kalman_track_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                         uint8_t valid_mask, bool gate, uint8_t *rejected) {
    struct kalman_cov *cv = &k->cov;
    if (cv->steady && valid_mask == ANGLES_ALL_SENSORS && kalman_steady_row(k, range_mm, gate)) {
        cv->predict_pending = false;
        *rejected = 0;
        return ANGLES_ALL_SENSORS;
    }
    if (cv->still) {
        if (valid_mask == ANGLES_ALL_SENSORS && kalman_static_row(k, range_mm, gate)) {
            cv->predict_pending = false; /* Q = 0: nothing to add */
            *rejected = 0;
            return ANGLES_ALL_SENSORS;
        }
        kalman_static_leave(k); /* this row in full, from P */
    }
    cv->steady = false;
    const fix_q32_t before[6] = {cv->p[0][0], cv->p[0][1], cv->p[0][2],
                                 cv->p[1][1], cv->p[1][2], cv->p[2][2]};
    if (cv->predict_pending) {
        add_process_noise(k);
        cv->predict_pending = false;
    }
    bool ovf = false;
    bool proven;
    uint8_t by_block = 0;
    const uint8_t used =
        update_row(k, range_mm, valid_mask, gate, rejected, &ovf, &proven, &by_block);
    if (used != 0u) {
        const uint32_t restarts = k->numeric_restarts;
        check_covariance(k, ovf, proven); /* once per row: a failure restarts P before the next */
        const fix_q32_t *q = k->cfg.process_noise_mm2;
        cv->steady = by_block == ANGLES_ALL_SENSORS && used == ANGLES_ALL_SENSORS &&
                     k->numeric_restarts == restarts && (q[0] | q[1] | q[2]) != 0 &&
                     kalman_steady_settled(k, before);
        if (k->process_noise || cv->still_broken) {
            /* Q > 0 (or auto), or P no longer M⁻¹/c: no static run */
        } else if (used == ANGLES_ALL_SENSORS && k->numeric_restarts == restarts) {
            kalman_static_try(k);
        } else {
            cv->still_broken = true; /* part of a row: the information is not a multiple of M */
        }
    }
    return used;
}

void kalman_track_covariance(const struct kalman_state *k,
                             fix_q32_t p[KALMAN_STATES][KALMAN_STATES]) {
    if (k->cov.still) {
        kalman_static_covariance(k, p);
    } else {
        (void)memcpy(p, k->cov.p, sizeof k->cov.p);
    }
}
