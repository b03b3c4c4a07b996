/* Fixed-point Kalman filter of Eq. 5 / Alg. 2: see estimator/kalman.h. */
#include "estimator/kalman.h"

#include <string.h>

#include "fix_inline.h"

/* 1/12 mm² in Q32: the variance of 1 mm rounding, the floor of every R. */
#define QUANT_VAR_Q32 357913941
/* Largest accepted initial R: 2^20 mm² (σ = 1024 mm). */
#define R_MAX_Q32 ((int64_t)1 << 52)
/* Bound of every state, 2^24 mm (16.8 km): far beyond any 16-bit reading, and small
 * enough that a prediction h·x and an innovation z − h·x stay far inside int64. */
#define X_LIMIT_Q32 ((int64_t)1 << 56)
/* Cap of each P_ii under process noise: 16 x the diffuse prior, far above any state worth
 * estimating, and low enough that hᵀPh + R (at most 4 x 2^60 + 2^52) stays inside int64. */
#define P_MAX_Q32 (KALMAN_P0_MM2_Q32 << 4)

/* Rows of Eq. 5 with the slopes scaled by a: A [1, −1, 0], B [1, 0, 1], C [1, 1, 0],
 * D [1, 0, −1]: h = e0 + σ e_j (update_exact, block_update). */

int kalman_init(struct kalman_state *k, const struct kalman_config *cfg) {
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        if (cfg->process_noise_mm2[i] < 0 || cfg->process_noise_mm2[i] > KALMAN_P0_MM2_Q32) {
            return KALMAN_ERR_PROCESS_NOISE;
        }
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if (cfg->initial_noise_mm2[s] <= 0 || cfg->initial_noise_mm2[s] > R_MAX_Q32) {
            return KALMAN_ERR_MEASUREMENT_NOISE;
        }
    }
    if (cfg->warmup_rows < 1u || cfg->warmup_rows > KALMAN_WARMUP_MAX) {
        return KALMAN_ERR_WARMUP;
    }
    if (cfg->noise_shift > 8u) {
        return KALMAN_ERR_NOISE_SHIFT;
    }
    (void)memset(k, 0, sizeof *k);
    k->cfg = *cfg;
    const uint64_t q2 = (uint64_t)cfg->gate_sigmas_q8 * cfg->gate_sigmas_q8;
    k->gate_s_max = q2 == 0u ? 0u : UINT64_MAX / q2;
    k->process_noise = cfg->process_noise_mm2[0] != 0 || cfg->process_noise_mm2[1] != 0 ||
                       cfg->process_noise_mm2[2] != 0;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        k->r[s] = cfg->initial_noise_mm2[s];
    }
    kalman_reset(k);
    return KALMAN_OK;
}

static void diffuse_covariance(struct kalman_state *k) {
    k->bvalid = false;
    (void)memset(k->p, 0, sizeof k->p);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        k->p[i][i] = KALMAN_P0_MM2_Q32;
    }
}

void kalman_reset(struct kalman_state *k) {
    (void)memset(k->x, 0, sizeof k->x);
    diffuse_covariance(k);
    k->started = false;
    k->warm_rows = 0;
    (void)memset(k->reject_run, 0, sizeof k->reject_run);
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

/* e² > max(k²·s, floor²) with e in Q32 mm and s in Q32 mm², exactly. */
static bool outside_gate(const struct kalman_state *k, fix_q32_t e, fix_q32_t s) {
    const fix_s128 e2 = fix_s128_mul(e, e); /* Q64 */
    const int64_t g = k->cfg.gate_sigmas_q8;
    /* k² s in Q64 = s · g² · 2^16 (g in Q8, s in Q32) */
    const fix_s128 ks = fix_s128_shl(fix_s128_mul(s, g * g), 16u);
    const int64_t fl = k->cfg.gate_floor_mm;
    const fix_s128 fl2 = fix_s128_shl(fix_s128_from_s64(fl * fl), 64u);
    return fix_s128_cmp(e2, ks) > 0 && fix_s128_cmp(e2, fl2) > 0;
}

/* The general update: the Joseph form P − k gᵀ − g kᵀ + s k kᵀ with the Q30 gain,
 * every entry from exact 128-bit products with one rounding. */
static void joseph_update(struct kalman_state *k, const fix_q32_t g[KALMAN_STATES], fix_q32_t s,
                          fix_q32_t e, bool *ovf) {
    fix_q30_t gain[KALMAN_STATES];
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        gain[i] = fix_muldiv_s64(g[i], FIX_Q30_ONE, s, ovf);
    }
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        /* A gain far above 1 (a direction an ill-conditioned P barely resolves) times a
         * large innovation can throw the state out of any physical range, and then the
         * predictions h·x out of int64: flagged (the covariance restarts), the state kept
         * within ±X_LIMIT_Q32. (Found by tests/fuzz.) */
        const int64_t dx = fix_mul_shr_s64(gain[i], e, FIX_Q30_SHIFT, ovf);
        if (dx > 0 ? k->x[i] > X_LIMIT_Q32 - dx : k->x[i] < -X_LIMIT_Q32 - dx) {
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
            k->p[i][j] -= d;
            k->p[j][i] = k->p[i][j];
        }
    }
}

/* Gate with 64-bit products when they cannot overflow (e in Q24, s·k² below 2^64):
 * e24² (Q48) against s·k² (Q32·Q16); else exactly in 128 bits. */
static bool gated_out(const struct kalman_state *k, fix_q32_t e, fix_q32_t s) {
    if (e < ((int64_t)1 << 39) && e > -((int64_t)1 << 39) && (uint64_t)s <= k->gate_s_max) {
        const int64_t e24 = fix_round_shr_s64(e, 8u);
        const uint64_t m = (uint64_t)(e24 < 0 ? -e24 : e24);
        const uint64_t q = k->cfg.gate_sigmas_q8;
        return m * m > (uint64_t)s * (q * q) && m > ((uint64_t)k->cfg.gate_floor_mm << 24);
    }
    return outside_gate(k, e, s);
}

/* h = e0 + σ e_j (kalman.h): A (j 1, −), B (j 2, +), C (j 1, +), D (j 2, −). */
static unsigned h_index(unsigned sensor) {
    return (sensor & 1u) != 0u ? 2u : 1u;
}
static bool h_minus(unsigned sensor) {
    return sensor == (unsigned)ANGLES_A || sensor == (unsigned)ANGLES_D;
}

/* One scalar update on the full Q32 covariance (the exact Joseph form), with the gate;
 * no definiteness check. */
static bool update_exact(struct kalman_state *k, unsigned sensor, fix_q32_t z_mm, bool gate,
                         bool *ovf) {
    const unsigned j = h_index(sensor);
    const bool minus = h_minus(sensor);
    fix_q32_t g[KALMAN_STATES];
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        g[i] = minus ? k->p[i][0] - k->p[i][j] : k->p[i][0] + k->p[i][j];
    }
    const fix_q32_t hph = minus ? g[0] - g[j] : g[0] + g[j];
    const fix_q32_t pred = minus ? k->x[0] - k->x[j] : k->x[0] + k->x[j];
    const fix_q32_t s = hph + k->r[sensor];
    const fix_q32_t e = z_mm - pred;
    if (gate && k->cfg.gate_sigmas_q8 != 0u && gated_out(k, e, s)) {
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
 * so the update keeps P positive definite wherever the exact one does. tests/reference
 * compares P with double within 1e-6 relative + 64 LSB. */

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
 * that drift moves the later decreases by |k| units each (tests/reference: 16 rows keep
 * P within 6 LSB of its exact-block value, 64 rows within 26). */
#define BLOCK_MAX_ROWS 16u
/* Margin of the cheap definiteness check on the mantissas, in block units: larger than
 * that drift (4 updates x 16 rows x 1/2) plus the rounding of taking the block. */
#define BLOCK_CHECK_MARGIN ((int32_t)1 << 10)

/* floor(v / 2^sh) as int32 for sh in [1, 62] when the result fits int32 and, for
 * sh >= 32, |v| < 2^62: from the two 32-bit halves (the low word of the floor is the same
 * bits for either sign). */
FIX_INLINE int32_t shr_to_s32(int64_t v, unsigned sh) {
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

/* R in block units when it is this large or larger: it does not fit the block's s = hᵀPh + R
 * below 2^62 (R up to 2^52 scaled by up to 2^30 would overflow int64), so block_update()
 * leaves such a measurement to the exact update. (Found by tests/fuzz.) */
#define BLOCK_R_TOO_LARGE ((int64_t)1 << 61)

/* R and the gate's sure-accept threshold in block units, for the current exponent. */
static void block_refresh_r(struct kalman_state *k, int32_t e) {
    const uint64_t q2 = (uint64_t)k->cfg.gate_sigmas_q8 * k->cfg.gate_sigmas_q8;
    const uint64_t fl = (uint64_t)k->cfg.gate_floor_mm;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const int64_t r = k->r[s];
        if (e >= 0) {
            k->rb[s] = fix_floor_shr_s64(r, (unsigned)e);
        } else if (r >= (BLOCK_R_TOO_LARGE >> (unsigned)(-e))) {
            k->rb[s] = BLOCK_R_TOO_LARGE;
        } else {
            k->rb[s] = r * ((int64_t)1 << (unsigned)(-e));
        }
        /* |e24|² (Q48) below q²·R (Q32·Q16) or the floor: inside the gate for any s >= R */
        const uint64_t a = (uint64_t)r > UINT64_MAX / (q2 + 1u) ? UINT64_MAX : (uint64_t)r * q2;
        const uint64_t f = fl >= 0x8000u ? UINT64_MAX : (fl * fl) << 48;
        k->gate_accept[s] = a > f ? a : f;
        /* the block path's bound hᵀPh <= 4 R in block units, as an int32 (an R too large
         * for the block: −1, never) */
        const int64_t rb = k->rb[s];
        k->hph_max[s] =
            rb >= BLOCK_R_TOO_LARGE ? -1 : (rb >= (INT32_MAX / 4) ? INT32_MAX : (int32_t)(4 * rb));
    }
    k->rb_pe = e;
    k->rb_valid = true;
}

/* p_ij · 2^-e rounded, as a block mantissa (|p_ij| <= max P_ii < 2^(28 + e)). */
FIX_INLINE int32_t to_block(int64_t v, int32_t e) {
    if (e > 0) {
        return shr_to_s32(v + ((int64_t)1 << (unsigned)(e - 1)), (unsigned)e);
    }
    return (int32_t)(v * ((int64_t)1 << (unsigned)(-e)));
}

/* The block of the current p (k->bm, k->be); false when P is not well scaled for it. */
static bool block_from_p(struct kalman_state *k) {
    k->bvalid = false;
    const int64_t d0 = k->p[0][0];
    const int64_t d1 = k->p[1][1];
    const int64_t d2 = k->p[2][2];
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
    int32_t *m = k->bm;
    m[0] = to_block(d0, e);
    m[3] = to_block(d1, e);
    m[5] = to_block(d2, e);
    if (m[0] < BLOCK_MIN_DIAG || m[3] < BLOCK_MIN_DIAG || m[5] < BLOCK_MIN_DIAG) {
        return false;
    }
    m[1] = to_block(k->p[0][1], e);
    m[2] = to_block(k->p[0][2], e);
    m[4] = to_block(k->p[1][2], e);
    k->be = e;
    k->brows = 0;
    k->bvalid = true;
    if (!k->rb_valid || k->rb_pe != e) {
        block_refresh_r(k, e);
    }
    return true;
}

/* The block for the next row: kept while it is fresh and its largest diagonal still has
 * 26 bits, else taken afresh from p. */
static bool block_ready(struct kalman_state *k) {
    if (k->bvalid && k->brows < BLOCK_MAX_ROWS) {
        const int32_t *m = k->bm;
        const int32_t top = m[0] > m[3] ? (m[0] > m[5] ? m[0] : m[5]) : (m[3] > m[5] ? m[3] : m[5]);
        if (top >= ((int32_t)1 << (BLOCK_TOP_BITS - 1))) {
            if (!k->rb_valid) {
                block_refresh_r(k, k->be);
            }
            return true;
        }
    }
    return block_from_p(k);
}

/* True when the mantissas prove p positive definite (kalman.h's check) with a margin
 * for their drift from p; false means "not proven" (then p itself is checked). */
static bool block_healthy(const struct kalman_state *k) {
    const int32_t *m = k->bm;
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
    const int32_t sh_signed = 31 - k->be;
    const unsigned sh = (unsigned)sh_signed; /* in [1, 61] */
    k->p[0][0] -= fix_round_shr_s64(b->dec[0], sh);
    k->p[0][1] -= fix_round_shr_s64(b->dec[1], sh);
    k->p[0][2] -= fix_round_shr_s64(b->dec[2], sh);
    k->p[1][1] -= fix_round_shr_s64(b->dec[3], sh);
    k->p[1][2] -= fix_round_shr_s64(b->dec[4], sh);
    k->p[2][2] -= fix_round_shr_s64(b->dec[5], sh);
    k->p[1][0] = k->p[0][1];
    k->p[2][0] = k->p[0][2];
    k->p[2][1] = k->p[1][2];
    b->dec[0] = 0;
    b->dec[1] = 0;
    b->dec[2] = 0;
    b->dec[3] = 0;
    b->dec[4] = 0;
    b->dec[5] = 0;
}

/* The decrease t = g_i k_j of one entry: exactly into dec, rounded into the mantissa. */
FIX_INLINE void block_sub(struct kalman_state *k, struct pblock *b, unsigned idx, int64_t t) {
    b->dec[idx] += t;
    /* round(t / 2^31), |t| < 2^62: the floor is the two's complement bits (hi << 1) |
     * (lo >> 31), the rounding bit is bit 30 */
    const uint64_t u = (uint64_t)t;
    const uint32_t lo = (uint32_t)u;
    const uint32_t hi = (uint32_t)(u >> 32);
    const uint32_t q = ((hi << 1) | (lo >> 31)) + ((lo >> 30) & 1u);
    const uint32_t mantissa = (uint32_t)k->bm[idx] - q;
    k->bm[idx] = (int32_t)mantissa;
}

/* One scalar update on the block: 1 accepted, 0 gated out, BLOCK_NOT_POSSIBLE when the
 * conditions above fail (nothing changed). */
static int block_update(struct kalman_state *k, struct pblock *b, unsigned sensor, fix_q32_t z_mm,
                        bool gate) {
    int32_t *m = k->bm;
    /* The int32 sums below rely on |m| <= max P_ii < 2^28, true of a block when it is
     * taken; a nearly singular P can lose it inside a row (the updates overshoot and a
     * diagonal turns negative: found by tests/fuzz). Such a row goes on exactly, and the
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
    const fix_q32_t e = z_mm - pred;
    /* e in [−2^39, 2^39) (128 mm) exactly when its high word is in [−128, 127]; then e24
     * below fits int32 and |k e24| < 2^62 */
    const uint32_t e_hi = (uint32_t)((uint64_t)e >> 32) + 128u;
    if (hph < BLOCK_MIN_HPH || hph > k->hph_max[sensor] || e_hi > 255u) {
        return BLOCK_NOT_POSSIBLE;
    }
    const int64_t r_b = k->rb[sensor];
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
    const int32_t e24 = shr_to_s32(e + 128, 8u); /* innovation in Q24, rounded */
    const int64_t e24_sq = (int64_t)e24 * e24;
    if (gate && k->cfg.gate_sigmas_q8 != 0u && (uint64_t)e24_sq > k->gate_accept[sensor]) {
        /* not surely inside: the gate on the exact s */
        const fix_q32_t s = (k->be >= 0 ? (int64_t)hph * ((int64_t)1 << (unsigned)k->be)
                                        : fix_floor_shr_s64(hph, (unsigned)(-k->be))) +
                            k->r[sensor];
        if (gated_out(k, e, s)) {
            return 0;
        }
    }
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
    const int32_t k0 = shr_to_s32((int64_t)g[0] * rm, gain_shift);
    const int32_t k1 = shr_to_s32((int64_t)g[1] * rm, gain_shift);
    const int32_t k2 = shr_to_s32((int64_t)g[2] * rm, gain_shift);
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

/* The valid readings of one row, A..D: block updates while they apply, exact ones
 * otherwise; p is current on return. Returns the sensors accepted; *rejected gets those
 * gated out; *proven is set when the block shows P positive definite. */
static uint8_t update_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                          uint8_t valid_mask, bool gate, uint8_t *rejected, bool *ovf,
                          bool *proven) {
    struct pblock b;
    b.dec[0] = 0;
    b.dec[1] = 0;
    b.dec[2] = 0;
    b.dec[3] = 0;
    b.dec[4] = 0;
    b.dec[5] = 0;
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
    if (k->bvalid) {
        k->brows++;
    }
    /* The mantissas prove p only while a block unit is at least one LSB of p (be >= 0):
     * finer units leave p's own rounding (half an LSB per entry) outside the margin, and
     * a P of a few LSB (sliding windows, Q = 0, long runs) could round to singular
     * unseen. (Found by tests/fuzz.) */
    *proven = k->bvalid && k->be >= 0 && block_healthy(k);
    return used;
}

/* After a failed check or an overflow: forget the covariance, keep the state; counted,
 * never silent. */
static void check_covariance(struct kalman_state *k, bool ovf, bool proven) {
    if (ovf || (!proven && !covariance_healthy(k->p))) {
        diffuse_covariance(k);
        k->numeric_restarts++;
        k->restarts++;
    }
}

bool kalman_update(struct kalman_state *k, unsigned sensor, fix_q32_t z_mm, bool gate) {
    bool ovf = false;
    bool proven = false;
    bool accepted;
    if (sensor < ANGLES_SENSORS && z_mm >= 0 && z_mm <= ((int64_t)UINT16_MAX << FIX_Q32_SHIFT) &&
        (z_mm & (FIX_Q32_ONE - 1)) == 0) {
        /* an integer reading: the row path (block when it applies) */
        uint16_t range[ANGLES_SENSORS] = {0, 0, 0, 0};
        range[sensor] = (uint16_t)(z_mm >> FIX_Q32_SHIFT);
        uint8_t rejected;
        accepted =
            update_row(k, range, (uint8_t)(1u << sensor), gate, &rejected, &ovf, &proven) != 0u;
    } else {
        accepted = update_exact(k, sensor, z_mm, gate, &ovf);
        k->bvalid = false;
    }
    if (accepted) {
        check_covariance(k, ovf, proven);
    }
    return accepted;
}

static void predict(struct kalman_state *k) {
    if (!k->process_noise) {
        return;
    }
    k->bvalid = false; /* p changes outside the block */
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        if (k->p[i][i] < P_MAX_Q32) { /* a long outage saturates here, never overflows */
            const int64_t grown = k->p[i][i] + k->cfg.process_noise_mm2[i];
            k->p[i][i] = grown < P_MAX_Q32 ? grown : P_MAX_Q32;
        }
    }
}

/* The warm-up: per-sensor median of the buffered rows, gate, then updates. */
static void flush_warmup(struct kalman_state *k, struct kalman_rows *out) {
    int32_t median_x2[ANGLES_SENSORS] = {0};
    bool has[ANGLES_SENSORS] = {false, false, false, false};
    int64_t start_sum = 0;
    int64_t start_n = 0;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        uint16_t v[KALMAN_WARMUP_MAX];
        unsigned n = 0;
        for (unsigned r = 0; r < k->warm_rows; ++r) {
            if ((k->warm_valid[r] & (1u << s)) == 0u) {
                continue;
            }
            /* insertion into the sorted prefix (at most 8 values) */
            unsigned i = n;
            const uint16_t x = k->warm_range[r][s];
            while (i > 0u && v[i - 1u] > x) {
                v[i] = v[i - 1u];
                --i;
            }
            v[i] = x;
            n++;
        }
        if (n == 0u) {
            continue;
        }
        has[s] = true;
        median_x2[s] = (int32_t)v[(n - 1u) / 2u] + (int32_t)v[n / 2u];
        start_sum += median_x2[s];
        start_n += 2;
    }
    /* start from the robust mean distance; the diffuse prior makes it matter
     * only to the first innovation, never to the estimate */
    k->x[0] = start_n > 0 ? fix_div_round_s64(start_sum * FIX_Q32_ONE, start_n) : 0;
    k->x[1] = 0;
    k->x[2] = 0;

    out->count = k->warm_rows;
    for (unsigned r = 0; r < k->warm_rows; ++r) {
        predict(k);
        uint8_t used = 0;
        uint8_t rejected = 0;
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            if ((k->warm_valid[r] & (1u << s)) == 0u || !has[s]) {
                continue;
            }
            const int32_t x = k->warm_range[r][s];
            int64_t dev_x2 = 2 * (int64_t)x - median_x2[s];
            dev_x2 = dev_x2 < 0 ? -dev_x2 : dev_x2;
            bool reject = false;
            if (k->cfg.gate_sigmas_q8 != 0u) {
                /* half-width in 2·mm, Q16: 2·k·sqrt(R) vs 2·floor */
                const int64_t sd_q16 = fix_isqrt_u64((uint64_t)k->r[s]);
                const int64_t thr = (2 * (int64_t)k->cfg.gate_sigmas_q8 * sd_q16) >> 8;
                const int64_t fl = (2 * (int64_t)k->cfg.gate_floor_mm) << 16;
                reject = (dev_x2 << 16) > (thr > fl ? thr : fl);
            }
            if (reject) {
                rejected = (uint8_t)(rejected | (1u << s));
            } else {
                used = (uint8_t)(used | (1u << s));
            }
        }
        if (used != 0u) {
            bool ovf = false;
            uint8_t none;
            bool proven;
            (void)update_row(k, k->warm_range[r], used, false, &none, &ovf, &proven);
            check_covariance(k, ovf, proven);
        }
        out->used[r] = used;
        out->rejected[r] = rejected;
    }
    k->warm_rows = 0;
    k->started = true;
    (void)memset(k->reject_run, 0, sizeof k->reject_run);
}

void kalman_push_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                     uint8_t valid_in, struct kalman_rows *out) {
    out->count = 0;
    const uint8_t valid_mask = (uint8_t)(valid_in & ANGLES_ALL_SENSORS);
    if (!k->started) {
        (void)memcpy(k->warm_range[k->warm_rows], range_mm, sizeof k->warm_range[0]);
        k->warm_valid[k->warm_rows] = valid_mask;
        k->warm_rows++;
        if (k->warm_rows >= k->cfg.warmup_rows) {
            flush_warmup(k, out);
        }
        return;
    }
    predict(k);
    uint8_t rejected = 0;
    bool ovf = false;
    bool proven;
    const uint8_t used = update_row(k, range_mm, valid_mask, true, &rejected, &ovf, &proven);
    if (used != 0u) {
        check_covariance(k, ovf,
                         proven); /* once per row: a failure restarts P before the next row */
    }
    out->count = 1;
    out->used[0] = used;
    out->rejected[0] = rejected;
    bool locked_out = false;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if ((rejected & (1u << s)) != 0u) {
            k->reject_run[s]++;
            locked_out = locked_out || k->reject_run[s] >= KALMAN_LOCKOUT_ROWS;
        } else if ((used & (1u << s)) != 0u) {
            k->reject_run[s] = 0;
        } else {
            /* not read this row: its run neither grows nor ends */
        }
    }
    if (locked_out) {
        /* The gate no longer matches the data: start again. A sensor whose R is
         * still the configured guess was probably rejected for being noisier
         * than guessed, so its R is also raised (x4, bounded) for the restart. */
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            if (k->reject_run[s] >= KALMAN_LOCKOUT_ROWS && !k->r_tracked[s]) {
                k->r[s] = k->r[s] < R_MAX_Q32 / 4 ? 4 * k->r[s] : R_MAX_Q32;
                k->rb_valid = false;
            }
        }
        kalman_reset(k);
        k->restarts++;
    }
}

void kalman_flush(struct kalman_state *k, struct kalman_rows *out) {
    out->count = 0;
    if (!k->started && k->warm_rows > 0u) {
        flush_warmup(k, out);
    }
}

void kalman_track_noise(struct kalman_state *k, unsigned sensor, fix_q32_t var_mm2,
                        uint16_t count) {
    if (count < 2u || sensor >= ANGLES_SENSORS) {
        return;
    }
    /* Bounded like a configured R: a window variance beyond σ = 1024 mm (readings 0 and
     * 65535 mm in one window give 2^31 mm²) would overflow s = hᵀPh + R. */
    const fix_q32_t v =
        var_mm2 < QUANT_VAR_Q32 ? QUANT_VAR_Q32 : (var_mm2 > R_MAX_Q32 ? R_MAX_Q32 : var_mm2);
    if (!k->r_tracked[sensor]) {
        k->r[sensor] = v; /* the configured R was only a guess */
        k->rb_valid = false;
        k->r_tracked[sensor] = true;
        return;
    }
    k->r[sensor] += fix_asr_s64(v - k->r[sensor], k->cfg.noise_shift);
    k->rb_valid = false;
}

void kalman_estimate(const struct kalman_state *k, int32_t arm_um, struct kalman_result *out) {
    (void)memcpy(out->p_mm2, k->p, sizeof out->p_mm2);
    const int64_t observable_below = KALMAN_P0_MM2_Q32 >> 6;
    out->alpha_observable = k->started && k->p[1][1] < observable_below;
    out->beta_observable = k->started && k->p[2][2] < observable_below;
    out->distance_mm = k->x[0];
    /* α = atan(θ1 / a): θ1 in mm Q32, a in um → both as um Q32 */
    const int64_t a_q32 = (int64_t)arm_um << FIX_Q32_SHIFT;
    out->alpha_udeg = fix_atan2_udeg(fix_sat_mul_s64(k->x[1], 1000), a_q32);
    out->beta_udeg = fix_atan2_udeg(fix_sat_mul_s64(k->x[2], 1000), a_q32);
    const fix_q32_t ta = fix_div_round_s64(fix_sat_mul_s64(k->x[1], 1000), arm_um);
    const fix_q32_t tb = fix_div_round_s64(fix_sat_mul_s64(k->x[2], 1000), arm_um);
    out->alpha_sigma_udeg = fix_angle_sigma_udeg(k->p[1][1], arm_um, ta);
    out->beta_sigma_udeg = fix_angle_sigma_udeg(k->p[2][2], arm_um, tb);
}
