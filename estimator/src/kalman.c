/* Fixed-point Kalman filter of Eq. 5 / Alg. 2: see estimator/kalman.h. */
#include "estimator/kalman.h"

#include <string.h>

#include "fix_inline.h"

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

/* Q > 0 runs the covariance form (when built), Q = 0 the information form. */
static bool covariance_form(const struct kalman_state *k) {
    return KALMAN_COVARIANCE_BUILT != 0 && k->process_noise;
}

static void r_changed(struct kalman_state *k);
static void info_prior(struct kalman_state *k);
static void info_solve_general(struct kalman_state *k);

int kalman_init(struct kalman_state *k, const struct kalman_config *cfg) {
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        if (cfg->process_noise_mm2[i] < 0 || cfg->process_noise_mm2[i] > KALMAN_P0_MM2_Q32 ||
            (KALMAN_COVARIANCE_BUILT == 0 && cfg->process_noise_mm2[i] != 0)) {
            return KALMAN_ERR_PROCESS_NOISE;
        }
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if (cfg->initial_noise_mm2[s] < KALMAN_R_MIN_Q32 || cfg->initial_noise_mm2[s] > R_MAX_Q32) {
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
    r_changed(k);
    kalman_reset(k);
    return KALMAN_OK;
}

static void diffuse_covariance(struct kalman_state *k) {
    k->f.cov.bvalid = false;
    (void)memset(k->f.cov.p, 0, sizeof k->f.cov.p);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        k->f.cov.p[i][i] = KALMAN_P0_MM2_Q32;
    }
}

void kalman_reset(struct kalman_state *k) {
    (void)memset(k->x, 0, sizeof k->x);
    if (covariance_form(k)) {
        diffuse_covariance(k);
    } else {
        k->f.info.x0_mm = 0;
        info_prior(k);
    }
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
            k->f.cov.p[i][j] -= d;
            k->f.cov.p[j][i] = k->f.cov.p[i][j];
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
        g[i] = minus ? k->f.cov.p[i][0] - k->f.cov.p[i][j] : k->f.cov.p[i][0] + k->f.cov.p[i][j];
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

/* R in block units, for the current exponent. */
static void block_refresh_r(struct kalman_state *k, int32_t e) {
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const int64_t r = k->r[s];
        if (e >= 0) {
            k->f.cov.rb[s] = fix_floor_shr_s64(r, (unsigned)e);
        } else if (r >= (BLOCK_R_TOO_LARGE >> (unsigned)(-e))) {
            k->f.cov.rb[s] = BLOCK_R_TOO_LARGE;
        } else {
            k->f.cov.rb[s] = r * ((int64_t)1 << (unsigned)(-e));
        }
        /* the block path's bound hᵀPh <= 4 R in block units, as an int32 (an R too large
         * for the block: −1, never) */
        const int64_t rb = k->f.cov.rb[s];
        k->f.cov.hph_max[s] =
            rb >= BLOCK_R_TOO_LARGE ? -1 : (rb >= (INT32_MAX / 4) ? INT32_MAX : (int32_t)(4 * rb));
    }
    k->f.cov.rb_pe = e;
    k->f.cov.rb_valid = true;
}

/* p_ij · 2^-e rounded, as a block mantissa (|p_ij| <= max P_ii < 2^(28 + e)). */
FIX_INLINE int32_t to_block(int64_t v, int32_t e) {
    if (e > 0) {
        return shr_to_s32(v + ((int64_t)1 << (unsigned)(e - 1)), (unsigned)e);
    }
    return (int32_t)(v * ((int64_t)1 << (unsigned)(-e)));
}

/* The block of the current p (k->f.cov.bm, k->f.cov.be); false when P is not well scaled for it. */
static bool block_from_p(struct kalman_state *k) {
    k->f.cov.bvalid = false;
    const int64_t d0 = k->f.cov.p[0][0];
    const int64_t d1 = k->f.cov.p[1][1];
    const int64_t d2 = k->f.cov.p[2][2];
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
    int32_t *m = k->f.cov.bm;
    m[0] = to_block(d0, e);
    m[3] = to_block(d1, e);
    m[5] = to_block(d2, e);
    if (m[0] < BLOCK_MIN_DIAG || m[3] < BLOCK_MIN_DIAG || m[5] < BLOCK_MIN_DIAG) {
        return false;
    }
    m[1] = to_block(k->f.cov.p[0][1], e);
    m[2] = to_block(k->f.cov.p[0][2], e);
    m[4] = to_block(k->f.cov.p[1][2], e);
    k->f.cov.be = e;
    k->f.cov.brows = 0;
    k->f.cov.bvalid = true;
    if (!k->f.cov.rb_valid || k->f.cov.rb_pe != e) {
        block_refresh_r(k, e);
    }
    return true;
}

/* The block for the next row: kept while it is fresh and its largest diagonal still has
 * 26 bits, else taken afresh from p. */
static bool block_ready(struct kalman_state *k) {
    if (k->f.cov.bvalid && k->f.cov.brows < BLOCK_MAX_ROWS) {
        const int32_t *m = k->f.cov.bm;
        const int32_t top = m[0] > m[3] ? (m[0] > m[5] ? m[0] : m[5]) : (m[3] > m[5] ? m[3] : m[5]);
        if (top >= ((int32_t)1 << (BLOCK_TOP_BITS - 1))) {
            if (!k->f.cov.rb_valid) {
                block_refresh_r(k, k->f.cov.be);
            }
            return true;
        }
    }
    return block_from_p(k);
}

/* True when the mantissas prove p positive definite (kalman.h's check) with a margin
 * for their drift from p; false means "not proven" (then p itself is checked). */
static bool block_healthy(const struct kalman_state *k) {
    const int32_t *m = k->f.cov.bm;
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
    const int32_t sh_signed = 31 - k->f.cov.be;
    const unsigned sh = (unsigned)sh_signed; /* in [1, 61] */
    k->f.cov.p[0][0] -= fix_round_shr_s64(b->dec[0], sh);
    k->f.cov.p[0][1] -= fix_round_shr_s64(b->dec[1], sh);
    k->f.cov.p[0][2] -= fix_round_shr_s64(b->dec[2], sh);
    k->f.cov.p[1][1] -= fix_round_shr_s64(b->dec[3], sh);
    k->f.cov.p[1][2] -= fix_round_shr_s64(b->dec[4], sh);
    k->f.cov.p[2][2] -= fix_round_shr_s64(b->dec[5], sh);
    k->f.cov.p[1][0] = k->f.cov.p[0][1];
    k->f.cov.p[2][0] = k->f.cov.p[0][2];
    k->f.cov.p[2][1] = k->f.cov.p[1][2];
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
    const uint32_t mantissa = (uint32_t)k->f.cov.bm[idx] - q;
    k->f.cov.bm[idx] = (int32_t)mantissa;
}

/* One scalar update on the block: 1 accepted, 0 gated out, BLOCK_NOT_POSSIBLE when the
 * conditions above fail (nothing changed). */
static int block_update(struct kalman_state *k, struct pblock *b, unsigned sensor, fix_q32_t z_mm,
                        bool gate) {
    int32_t *m = k->f.cov.bm;
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
    if (hph < BLOCK_MIN_HPH || hph > k->f.cov.hph_max[sensor] || e_hi > 255u) {
        return BLOCK_NOT_POSSIBLE;
    }
    const int64_t r_b = k->f.cov.rb[sensor];
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
        const fix_q32_t s = (k->f.cov.be >= 0 ? (int64_t)hph * ((int64_t)1 << (unsigned)k->f.cov.be)
                                              : fix_floor_shr_s64(hph, (unsigned)(-k->f.cov.be))) +
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
    if (k->f.cov.bvalid) {
        k->f.cov.brows++;
    }
    /* The mantissas prove p only while a block unit is at least one LSB of p (be >= 0):
     * finer units leave p's own rounding (half an LSB per entry) outside the margin, and
     * a P of a few LSB (sliding windows, Q = 0, long runs) could round to singular
     * unseen. (Found by tests/fuzz.) */
    *proven = k->f.cov.bvalid && k->f.cov.be >= 0 && block_healthy(k);
    return used;
}

/* After a failed check or an overflow: forget the covariance, keep the state; counted,
 * never silent. */
static void check_covariance(struct kalman_state *k, bool ovf, bool proven) {
    if (ovf || (!proven && !covariance_healthy(k->f.cov.p))) {
        diffuse_covariance(k);
        k->numeric_restarts++;
        k->restarts++;
    }
}

/* --- the information form (Q = 0) ------------------------------------------------------
 * Without process noise the filter is recursive least squares: after any set of accepted
 * readings Y = P⁻¹ = y0·I + Σ_s a_s h_s h_sᵀ and Y(θ̂ − θ0) = Σ_s h_s ζ_s, where a_s is the
 * sum of the weights 1/R_s of sensor s's accepted readings, ζ_s the sum of those weights
 * times the readings' deviations from θ0 = (x0_mm, 0, 0), the prior mean. With the rows h_s
 * (kalman.h) Y is
 *     [ f  c  e ]      f = y0 + a_A + a_B + a_C + a_D
 *     [ c  A  0 ]      c = a_C − a_A,  A = y0 + a_A + a_C
 *     [ e  0  B ]      e = a_B − a_D,  B = y0 + a_B + a_D
 * (no row has both a·tan α and a·tan β, so Y_12 = 0 exactly). Eliminating the two slopes
 * (Schur complement on x̄), with g_α = c/A, g_β = e/B and each axis written as its sensors
 * m ("minus") and p ("plus"): α (A, C), β (D, B):
 *     d   = y0 + Σ_axes (y0(a_m + a_p) + 4 a_m a_p) / Y_jj
 *     δx̄  = Σ_axes ((y0 + 2a_p) ζ_m + (y0 + 2a_m) ζ_p) / Y_jj  /  d
 *     δθ_j = (ζ_p − ζ_m) / Y_jj − g_j δx̄
 *     P   = [ 1/d, −g_α/d, −g_β/d; ·, 1/A + g_α²/d, g_α g_β/d; ·, ·, 1/B + g_β²/d ]
 * Every term of d and of δx̄'s numerator is written without cancellation (the textbook
 * f − c²/A − e²/B and ζ1 − g_α ζα − g_β ζβ would lose the bits of a weak sensor of a pair to
 * it), and d, A, B >= y0 > 0: P is positive definite by construction, nothing to check.
 * Each quotient takes the 31-bit reciprocal of its divisor (relative error below 2^-28) and
 * the divided quantity's own 31-bit mantissa; the sums themselves are exact integers.
 *
 * Units: a weight unit is 2^-e mm⁻² (y0 = 1/P0 = 2^-24 mm⁻² is 2^(e − 24) units), chosen at
 * each start so that the largest weight of one reading is in (2^29, 2^30]; a sensor 2^12
 * times noisier in σ keeps 6 bits of weight. Deviations are whole mm (|dev| < 2^16), each
 * weight · deviation below 2^46: the sums are checked every INFO_CHECK_ROWS rows and, past
 * 2^58 (after ~2^28 readings, or ~2^12 readings 65 m from the start), halved with the
 * weights: one unit coarser, exact but for the dropped bit. */

#define INFO_SUM_CHECK                                                                             \
    ((uint64_t)1 << 58)       /* checked bound of each |sum|: below 2^59 between checks */
#define INFO_CHECK_ROWS 2048u /* 2048 rows add below 2^57 to a sum */
#define INFO_W_SHIFT    (-1)  /* largest weight = fix_recip31(m_R) / 2 */
#define INFO_KEEP_RANGE 6     /* units kept while the largest weight >= 2^24 */

/* y0 in units: 2^(e − 24); after 2+ halvings (~2^29 readings) at least 1 unit, a tighter
 * prior than P0, still negligible beside the data. */
static uint64_t info_y0(const struct kalman_info *in) {
    const int32_t sh = in->e - 24;
    return sh >= 0 ? (uint64_t)1 << (unsigned)sh : 1u;
}

/* Every sum shifted right by sh: sh units coarser. */
static void info_coarser(struct kalman_info *in, unsigned sh) {
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        in->a[s] >>= sh;
        in->z[s] = fix_floor_shr_s64(in->z[s], sh);
    }
    in->e -= (int32_t)sh;
}

/* The weights of one reading for the current R, in the units of the sums: chosen afresh
 * when the sums are empty, else kept while the largest weight stays in [2^24, 2^30] (a
 * smaller R makes the sums coarser; a larger one finer when they have the room). */
static void info_set_weights(struct kalman_state *k) {
    struct kalman_info *in = &k->f.info;
    fix_q32_t r_min = k->r[0];
    for (unsigned s = 1; s < ANGLES_SENSORS; ++s) {
        r_min = k->r[s] < r_min ? k->r[s] : r_min;
    }
    int32_t er;
    (void)fix_norm31_inline((uint64_t)r_min, &er);
    /* weight of R = m·2^er: fix_recip31(m) · 2^(e + 32 − 61 − er) */
    const int32_t want = 29 + INFO_W_SHIFT + er;
    const bool empty = (in->a[0] | in->a[1] | in->a[2] | in->a[3]) == 0u;
    if (empty) {
        in->e = want;
    } else if (want < in->e) {
        const int32_t sh = in->e - want;
        info_coarser(in, (unsigned)sh);
    } else if (want > in->e + INFO_KEEP_RANGE) {
        const int32_t finer = want - in->e;
        const unsigned sh = (unsigned)finer;
        bool room = true;
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            room = room && in->a[s] < (INFO_SUM_CHECK >> sh) &&
                   fix_abs_u64(in->z[s]) < (INFO_SUM_CHECK >> sh);
        }
        if (room) {
            for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
                in->a[s] <<= sh;
                in->z[s] *= (int64_t)1 << sh;
            }
            in->e = want;
        } /* else the weights keep fewer bits (at least 2^12 of the largest) */
    } else {
        /* the units stay */
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        int32_t e;
        const uint32_t m = fix_norm31_inline((uint64_t)k->r[s], &e);
        const uint32_t rr = (uint32_t)fix_recip31_inline(m); /* 2^61/m, in (2^30, 2^31] */
        const int32_t sh = in->e + 32 - 61 - e;              /* <= INFO_W_SHIFT */
        const uint32_t w = sh <= -32 ? 0u : rr >> (unsigned)(-sh);
        in->w[s] = w != 0u ? (int32_t)w : 1; /* <= 2^30 */
    }
}

/* |v| for |v| < 2^63 (the sums and quotients of the solve), inline. */
FIX_INLINE uint64_t info_abs(int64_t v) {
    return v < 0 ? (uint64_t)(-v) : (uint64_t)v;
}

/* (v · r) / 2^31 for v < 2^59 and r < 2^32: two 32x32 products, truncated. */
FIX_INLINE uint64_t info_mul(uint64_t v, uint32_t r) {
    const uint64_t hi = (v >> 32) * r;             /* < 2^59 */
    const uint64_t lo = (uint64_t)(uint32_t)v * r; /* < 2^64 */
    return (hi << 1) + (lo >> 31);
}

static int64_t info_mul_s(int64_t v, int32_t r) {
    const bool neg = (v < 0) != (r < 0);
    const uint64_t m = info_mul(info_abs(v), r < 0 ? (uint32_t)(-(int64_t)r) : (uint32_t)r);
    return neg ? -(int64_t)m : (int64_t)m;
}

/* v << sh for sh >= 0, v >> −sh otherwise (sh in [−63, 63]; the callers' results fit). */
FIX_INLINE uint64_t info_shift(uint64_t v, int32_t sh) {
    return sh >= 0 ? v << (unsigned)sh : (sh > -64 ? v >> (unsigned)(-sh) : 0u);
}

/* v / D in Q31 for v <= D = m · 2^e (r = fix_recip31(m) ≈ 2^61/m): at most 2^31. */
FIX_INLINE uint32_t info_ratio(uint64_t v, int32_t e, uint32_t r) {
    const uint32_t t = (uint32_t)info_shift(v, -e); /* <= m < 2^31 */
    return (uint32_t)(((uint64_t)t * r) >> 30);
}

/* z · v / D (units·mm) for v <= 2D: v's own mantissa, so a small v keeps its bits. */
static int64_t info_scaled(int64_t z, uint64_t v, int32_t e, uint32_t r) {
    if (v == 0u) {
        return 0;
    }
    int32_t ev;
    const uint32_t mv = fix_norm31_inline(v, &ev);
    const uint32_t t = (uint32_t)(((uint64_t)mv * r) >> 30); /* v/D · 2^(31 + e − ev) */
    const uint64_t q = info_shift(info_mul(info_abs(z), t), ev - e);
    return z < 0 ? -(int64_t)q : (int64_t)q;
}

/* v · 2^32 / D as Q32 (v in units·mm: mm; v = 2^e units: mm²), D = m · 2^e_d. */
static int64_t info_quotient(int64_t v, int32_t e_d, uint32_t r) {
    if (v == 0) {
        return 0;
    }
    int32_t ev;
    const uint32_t vm = fix_norm31_inline(info_abs(v), &ev);
    const uint64_t prod = (uint64_t)vm * r; /* v/D · 2^(61 + e_d − ev), < 2^62 */
    const int32_t sh = ev - e_d - 29;
    const int32_t right = -sh;
    const unsigned ur = (unsigned)right;
    const uint64_t q = sh >= 0 ? prod << (unsigned)sh
                               : (right < 63 ? (prod + ((uint64_t)1 << (ur - 1u))) >> ur : 0u);
    return v < 0 ? -(int64_t)q : (int64_t)q;
}

/* (v · r) / 2^(31 − fine), truncated, for fine <= 31 and v < 2^(44 − fine), or fine = 0 and
 * v < 2^59 (the solve's finer units, info_factors). */
FIX_INLINE uint64_t info_mul_fine(uint64_t v, uint32_t r, unsigned fine) {
    const uint64_t hi = (v >> 32) * r;
    const uint64_t lo = (uint64_t)(uint32_t)v * r;
    return (hi << (1u + fine)) + (lo >> (31u - fine));
}

/* One axis of the general solve (sensors m and p of its rows, kalman.h): its divisor
 * Y_jj = m · 2^e with r = fix_recip31(m), g = Y_0j/Y_jj, its terms of d and of d·δx̄, and
 * δθ_j before − g_j δx̄. */
struct info_axis {
    uint32_t r;
    int32_t e;
    int32_t g;     /* Q31 */
    uint64_t q;    /* (y0(a_m + a_p) + 4 a_m a_p) / Y_jj, units · 2^-fine */
    int64_t n;     /* ((y0 + 2a_p) ζ_m + (y0 + 2a_m) ζ_p) / Y_jj, units·mm */
    int64_t slope; /* (ζ_p − ζ_m) / Y_jj, Q32 mm */
    bool empty;    /* no reading: Y_jj = y0, nothing couples the axis to x̄ */
};

static void info_axis_solve(const uint64_t a[ANGLES_SENSORS], const int64_t z[ANGLES_SENSORS],
                            unsigned sm, unsigned sp, uint64_t y0, unsigned fine,
                            struct info_axis *ax) {
    const uint64_t am = a[sm];
    const uint64_t ap = a[sp];
    const int64_t zm = z[sm];
    const int64_t zp = z[sp];
    const uint64_t sum = am + ap;
    ax->empty = sum == 0u;
    if (ax->empty) {
        ax->r = 0u;
        ax->e = 0;
        ax->g = 0;
        ax->q = 0u;
        ax->n = 0;
        ax->slope = 0;
        return;
    }
    const uint32_t m = fix_norm31_inline(sum + y0, &ax->e);
    const uint32_t r = (uint32_t)fix_recip31_inline(m);
    const int32_t e = ax->e;
    ax->r = r;
    const uint32_t rm = info_ratio(am, e, r);
    const uint32_t rp = info_ratio(ap, e, r);
    ax->g = (int32_t)((int64_t)rp - (int64_t)rm);
    /* 4 a_m a_p / Y_jj as 4 · min · (max / Y_jj): the ratio at least about 1/2 */
    const uint64_t lo = am < ap ? am : ap;
    const uint32_t r_hi = am < ap ? rp : rm;
    ax->q = info_mul_fine(4u * lo, r_hi, fine) + info_mul_fine(y0, rm + rp, fine);
    ax->n = info_scaled(zm, y0 + 2u * ap, e, r) + info_scaled(zp, y0 + 2u * am, e, r);
    ax->slope = info_quotient(zp - zm, e, r);
}

/* The general solve's factors: both axes and d = m · 2^ed (units) with rd = fix_recip31(m). */
struct info_solution {
    struct info_axis al;
    struct info_axis be;
    uint32_t rd;
    int32_t ed;
};

/* The sums: those stored, or during a uniform run (which stores only its rows and the
 * deviation sums) a_s = n·w_s and ζ_s = w_s·D_s, exact. */
static void info_sums(const struct kalman_info *in, uint64_t a[ANGLES_SENSORS],
                      int64_t z[ANGLES_SENSORS]) {
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        a[s] = in->uniform ? (uint64_t)in->n * (uint32_t)in->w[s] : in->a[s];
        z[s] = in->uniform ? in->dsum[s] * in->w[s] : in->z[s];
    }
}

/* The end of a uniform run: its sums stored. */
static void info_end_run(struct kalman_info *in) {
    if (in->uniform) {
        info_sums(in, in->a, in->z);
        in->uniform = false;
    }
}

static void info_factors(const struct kalman_info *in, struct info_solution *sol) {
    uint64_t a[ANGLES_SENSORS];
    int64_t z[ANGLES_SENSORS];
    info_sums(in, a, z);
    /* d in finer units (2^-fine) while the sums are small (the first rows: each weight sum
     * below 2^(42 − fine)): its terms' integer parts then keep their bits whatever a weak
     * sensor weighs. */
    const uint64_t y0 = info_y0(in);
    const uint64_t top = a[0] | a[1] | a[2] | a[3] | y0;
    const int32_t fine_bits = 42 - (int32_t)fix_bitlen_u64(top);
    const unsigned fine = fine_bits > 0 ? (fine_bits < 31 ? (unsigned)fine_bits : 31u) : 0u;
    info_axis_solve(a, z, ANGLES_A, ANGLES_C, y0, fine, &sol->al);
    info_axis_solve(a, z, ANGLES_D, ANGLES_B, y0, fine, &sol->be);
    const uint32_t md = fix_norm31_inline((y0 << fine) + sol->al.q + sol->be.q, &sol->ed);
    sol->rd = (uint32_t)fix_recip31_inline(md);
    sol->ed -= (int32_t)fine; /* d in units */
}

/* x from the sums, any rows. */
static void info_solve_general(struct kalman_state *k) {
    const struct kalman_info *in = &k->f.info;
    struct info_solution sol;
    info_factors(in, &sol);
    const int64_t dx = info_quotient(sol.al.n + sol.be.n, sol.ed, sol.rd);
    k->x[0] = ((int64_t)in->x0_mm << FIX_Q32_SHIFT) + dx;
    k->x[1] = sol.al.slope - info_mul_s(dx, sol.al.g);
    k->x[2] = sol.be.slope - info_mul_s(dx, sol.be.g);
}

/* The state after no reading: the prior, a uniform run of no rows. */
static void info_prior(struct kalman_state *k) {
    struct kalman_info *in = &k->f.info;
    (void)memset(in->a, 0, sizeof in->a);
    (void)memset(in->z, 0, sizeof in->z);
    (void)memset(in->dsum, 0, sizeof in->dsum);
    in->rows_to_check = INFO_CHECK_ROWS;
    in->uniform = true;
    in->fast_ready = false;
    in->n = 0;
    info_set_weights(k);
    info_solve_general(k); /* x = θ0 */
}

/* --- the fast solve of a uniform run ----------------------------------------------------
 * While every row since the start accepted all four readings with the same weights w_s,
 * a_s = n·w_s and ζ_s = w_s·D_s (D_s the sum of sensor s's deviations): Y = n·(M0 + εI)
 * with M0 = Σ w_s h_s h_sᵀ constant and ε = y0/n, and Y δ = n·Σ h_s w_s μ_s with the means
 * μ_s = D_s/n. So δ = (M0 + εI)⁻¹ b = δ0 − ε·G·δ0 + O(ε²‖G‖²), G = M0⁻¹, δ0 = G b. From
 * the Schur formulas with y0 = 0, δ0 is a fixed mix of the four means:
 *     δx̄  = κ (μ_A + μ_C) + (1/2 − κ)(μ_D + μ_B),   κ = q_α/(2 d0)
 *     δθ_j = π_p μ_p − π_m μ_m − g_j δx̄,            π_s = w_s/W_j, g_j = π_p − π_m
 * (q_j = 4 w_m w_p / W_j, d0 = q_α + q_β), and G δ0 follows from 1/d0, 1/W_α, 1/W_β:
 * (Gδ)_0 = (δ0 − g_α δα − g_β δβ)/d0, (Gδ)_j = δ_j/W_j − g_j (Gδ)_0. The coefficients are
 * set once per run; a row costs one reciprocal of n and a dozen 32x32 products. The
 * prior's term is first order: the run uses it from the row n_fast on, where
 * ε‖G‖ < 2^-16 (its square, the neglected term, below 2^-32); before that, and whenever
 * a mean is 128 mm or more from x0, the general solve. P always comes from the sums. */

/* 2^(e + 16) / den (mm² Q16 for den in units), or −1 from 256 mm² on (the fast solve's
 * products stay below 2^62 with that bound). */
static int32_t info_inv_q16(uint64_t den, int32_t e) {
    const int32_t sh = e + 16;
    if (den == 0u || sh > 62) {
        return -1;
    }
    const uint64_t v = (sh >= 0 ? (uint64_t)1 << (unsigned)sh : 0u) / den;
    return v < ((uint64_t)1 << 24) ? (int32_t)v : -1;
}

/* The run's coefficients from its weights (once per run; exact 64-bit divisions). A run
 * they do not suit (noise beyond 256 mm²) never takes the fast solve (n_fast: never). */
static void info_fast_prepare(struct kalman_info *in) {
    in->fast_ready = true;
    in->n_fast = UINT32_MAX;
    const uint64_t w[ANGLES_SENSORS] = {(uint64_t)in->w[0], (uint64_t)in->w[1], (uint64_t)in->w[2],
                                        (uint64_t)in->w[3]};
    const uint64_t w_al = w[ANGLES_A] + w[ANGLES_C]; /* <= 2^31 */
    const uint64_t w_be = w[ANGLES_B] + w[ANGLES_D];
    const uint64_t pi_a = (w[ANGLES_A] << 31) / w_al; /* < 2^31: w_C >= 1 */
    const uint64_t pi_c = (w[ANGLES_C] << 31) / w_al;
    const uint64_t pi_b = (w[ANGLES_B] << 31) / w_be;
    const uint64_t pi_d = (w[ANGLES_D] << 31) / w_be;
    in->pi[ANGLES_A] = (int32_t)pi_a;
    in->pi[ANGLES_C] = (int32_t)pi_c;
    in->pi[ANGLES_B] = (int32_t)pi_b;
    in->pi[ANGLES_D] = (int32_t)pi_d;
    /* q_j = 4 w_lo w_hi / W_j with 29 fraction bits: w_lo · π_hi (below 2^61), so the
     * weaker pair's share keeps its bits (whole units would cost κ up to 2^-19: review) */
    const uint64_t qh_al = w[ANGLES_A] < w[ANGLES_C] ? w[ANGLES_A] * pi_c : w[ANGLES_C] * pi_a;
    const uint64_t qh_be = w[ANGLES_D] < w[ANGLES_B] ? w[ANGLES_D] * pi_b : w[ANGLES_B] * pi_d;
    const uint64_t qh_sum = qh_al + qh_be; /* below 2^63 */
    if (qh_sum == 0u) {
        return; /* unreachable: every weight >= 1, so q_α > 0 */
    }
    const int32_t drop_exp = (int32_t)fix_bitlen_u64(qh_sum) - 33;
    const unsigned drop = drop_exp > 0 ? (unsigned)drop_exp : 0u;
    const uint64_t kappa = ((qh_al >> drop) << 30) / (qh_sum >> drop); /* q_α/(2 d0), Q31 */
    in->kappa = (int32_t)kappa;
    const uint64_t d0 = qh_sum >> 29; /* q_α + q_β in units */
    in->inv_q16[0] = info_inv_q16(d0, in->e);
    in->inv_q16[1] = info_inv_q16(w_al, in->e);
    in->inv_q16[2] = info_inv_q16(w_be, in->e);
    int32_t top = 0;
    for (unsigned j = 0; j < KALMAN_STATES; ++j) {
        if (in->inv_q16[j] < 0) {
            return;
        }
        top = in->inv_q16[j] > top ? in->inv_q16[j] : top;
    }
    /* ε‖G‖ <= 2^-24 · 3 · 2 · max(1/d0, 1/W) / n < 2^-16: n > 6 · top (Q16) / 2^24 */
    in->n_fast = 1u + (uint32_t)(((uint64_t)top * 6u) >> 24);
}

/* x from the run's means; false (nothing changed) when the run does not allow it. The
 * products are 32x32 -> 64 and every shift takes the 32-bit result from the two halves
 * (shr_to_s32): the solve costs about 200 instructions on a Cortex-M4. */
static bool info_fast_solve(struct kalman_state *k) {
    struct kalman_info *in = &k->f.info;
    if (in->n < in->n_fast) {
        return false;
    }
    int32_t en;
    const uint32_t mn = fix_norm31_inline(in->n, &en); /* en <= 0 below 2^31 rows */
    const int32_t rn = fix_recip31_inline(mn);         /* 1/n = rn · 2^(−61 − en) */
    const int32_t mean_exp = 37 + en;                  /* μ (Q24) = D · rn / 2^(37 + en) */
    const unsigned mean_shift = (unsigned)mean_exp;
    /* every |μ| = |D|/n below 128 mm (Q24 in an int32), so |D| < 2^31 below 2^24 rows */
    if (in->n >= ((uint32_t)1 << 24)) {
        return false;
    }
    const int64_t lim = (int64_t)in->n << 7;
    int32_t mu[ANGLES_SENSORS];
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const int64_t dsum = in->dsum[s];
        if (dsum >= lim || dsum <= -lim) {
            return false;
        }
        mu[s] = shr_to_s32((int64_t)(int32_t)dsum * rn, mean_shift);
    }
    /* δ0 in Q55 (Q31 × Q24), then Q24 */
    const int32_t kb = (int32_t)0x40000000 - in->kappa;
    const int64_t dx55 = (int64_t)in->kappa * mu[ANGLES_A] + (int64_t)in->kappa * mu[ANGLES_C] +
                         (int64_t)kb * mu[ANGLES_D] + (int64_t)kb * mu[ANGLES_B];
    const int32_t dx = shr_to_s32(dx55, 31u); /* |δx̄| < 128 mm */
    const int32_t ga = in->pi[ANGLES_C] - in->pi[ANGLES_A];
    const int32_t gb = in->pi[ANGLES_B] - in->pi[ANGLES_D];
    const int64_t ta55 = (int64_t)in->pi[ANGLES_C] * mu[ANGLES_C] -
                         (int64_t)in->pi[ANGLES_A] * mu[ANGLES_A] - (int64_t)ga * dx;
    const int64_t tb55 = (int64_t)in->pi[ANGLES_B] * mu[ANGLES_B] -
                         (int64_t)in->pi[ANGLES_D] * mu[ANGLES_D] - (int64_t)gb * dx;
    /* |δθ| below 128 mm as well (Q24 in an int32): data far from the model (A + C far from
     * B + D, a pair of unequal weights) can reach 256 mm with every mean below 128 mm
     * (found by review); those rows take the general solve */
    const int64_t theta_limit = (int64_t)1 << 62;
    if (ta55 >= theta_limit || ta55 <= -theta_limit || tb55 >= theta_limit ||
        tb55 <= -theta_limit) {
        return false;
    }
    const int32_t ta = shr_to_s32(ta55, 31u);
    const int32_t tb = shr_to_s32(tb55, 31u);
    /* The prior: − ε G δ0 with ε = 2^-24/n mm⁻², at most 2^-16 of δ0 (n >= n_fast): ten bits
     * of it are enough, so δ in Q16 and G δ in Q8 (mm³), 32-bit. */
    const int32_t dx16 = shr_to_s32(dx, 8u);
    const int32_t ta16 = shr_to_s32(ta, 8u);
    const int32_t tb16 = shr_to_s32(tb, 8u);
    const int32_t c0 = dx16 - shr_to_s32((int64_t)ga * ta16 + (int64_t)gb * tb16, 31u); /* Q16 */
    const int32_t g0 = shr_to_s32((int64_t)c0 * in->inv_q16[0], 24u); /* (Gδ)_0, Q8 */
    const int32_t g1 =
        shr_to_s32((int64_t)ta16 * in->inv_q16[1], 24u) - shr_to_s32((int64_t)ga * g0, 31u);
    const int32_t g2 =
        shr_to_s32((int64_t)tb16 * in->inv_q16[2], 24u) - shr_to_s32((int64_t)gb * g0, 31u);
    /* ε (Gδ) in Q32 = (Gδ)_Q8 · 2^24 · 2^-24 / n = (Gδ)_Q8 · rn / 2^(61 + en) */
    const int32_t corr_exp = 61 + en;
    const unsigned corr_shift = (unsigned)corr_exp;
    k->x[0] = ((int64_t)in->x0_mm << FIX_Q32_SHIFT) + (int64_t)dx * 256 -
              shr_to_s32((int64_t)g0 * rn, corr_shift);
    k->x[1] = (int64_t)ta * 256 - shr_to_s32((int64_t)g1 * rn, corr_shift);
    k->x[2] = (int64_t)tb * 256 - shr_to_s32((int64_t)g2 * rn, corr_shift);
    return true;
}

/* One accepted reading of sensor s (the sums' headroom: info_check_sums). */
FIX_INLINE void info_add(struct kalman_info *in, unsigned s, uint16_t range_mm) {
    const int32_t dev = (int32_t)range_mm - in->x0_mm; /* |dev| < 2^17 */
    in->a[s] += (uint32_t)in->w[s];
    in->z[s] += (int64_t)in->w[s] * dev;
}

/* Before a row: every INFO_CHECK_ROWS rows the sums' headroom, halved past INFO_SUM_CHECK
 * (the weights change: the uniform run ends). */
static void info_check_sums(struct kalman_info *in) {
    if (--in->rows_to_check != 0u) {
        return;
    }
    in->rows_to_check = INFO_CHECK_ROWS;
    if (in->uniform) {
        /* its derived sums below 2^58 until the next check: n·w < 2^54 and |D| < 2^28
         * (w <= 2^30; the next 2048 rows add below 2^28 to |D|) */
        bool room = in->n < ((uint32_t)1 << 24);
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            room = room && info_abs(in->dsum[s]) < ((uint64_t)1 << 28);
        }
        if (room) {
            return;
        }
        info_end_run(in);
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if (in->a[s] >= INFO_SUM_CHECK || info_abs(in->z[s]) >= INFO_SUM_CHECK) {
            info_coarser(in, 1u);
            for (unsigned t = 0; t < ANGLES_SENSORS; ++t) {
                in->w[t] = in->w[t] > 1 ? in->w[t] / 2 : 1;
            }
            return;
        }
    }
}

/* P from the sums (either solve). */
static void info_covariance(const struct kalman_state *k,
                            fix_q32_t p[KALMAN_STATES][KALMAN_STATES]) {
    const struct kalman_info *in = &k->f.info;
    struct info_solution sol;
    info_factors(in, &sol);
    const int64_t one = (int64_t)1 << (unsigned)in->e; /* 1 mm⁻² in units */
    const fix_q32_t inv_d = info_quotient(one, sol.ed, sol.rd);
    const fix_q32_t inv_a =
        sol.al.empty ? KALMAN_P0_MM2_Q32 : info_quotient(one, sol.al.e, sol.al.r);
    const fix_q32_t inv_b =
        sol.be.empty ? KALMAN_P0_MM2_Q32 : info_quotient(one, sol.be.e, sol.be.r);
    const fix_q32_t ga = info_mul_s(inv_d, sol.al.g); /* g_α/d */
    const fix_q32_t gb = info_mul_s(inv_d, sol.be.g);
    p[0][0] = inv_d;
    p[0][1] = -ga;
    p[0][2] = -gb;
    p[1][1] = inv_a + info_mul_s(ga, sol.al.g);
    p[1][2] = info_mul_s(ga, sol.be.g);
    p[2][2] = inv_b + info_mul_s(gb, sol.be.g);
    p[1][0] = p[0][1];
    p[2][0] = p[0][2];
    p[2][1] = p[1][2];
}

/* The gate's sure-accept threshold per sensor: |e24|² (Q48) below q²·R (Q32·Q16) or the
 * floor is inside the gate for any s >= R. */
static void gate_refresh_accept(struct kalman_state *k) {
    const uint64_t q2 = (uint64_t)k->cfg.gate_sigmas_q8 * k->cfg.gate_sigmas_q8;
    const uint64_t fl = (uint64_t)k->cfg.gate_floor_mm;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const uint64_t r = (uint64_t)k->r[s];
        const uint64_t a = r > UINT64_MAX / (q2 + 1u) ? UINT64_MAX : r * q2;
        const uint64_t f = fl >= 256u ? UINT64_MAX : (fl * fl) << 48; /* 2^64 from 256 mm */
        k->gate_accept[s] = a > f ? a : f;
    }
}

/* Everything that depends on R, after R changed. */
static void r_changed(struct kalman_state *k) {
    gate_refresh_accept(k);
    if (covariance_form(k)) {
        k->f.cov.rb_valid = false;
    } else {
        struct kalman_info *in = &k->f.info;
        if (in->n != 0u) {
            info_end_run(in); /* past readings keep their weights */
        }
        info_set_weights(k); /* may change the units: x again from the sums */
        in->fast_ready = false;
        info_solve_general(k);
    }
}

/* The gate of the information form for a reading outside the sure-accept test (info_row):
 * against s = hᵀPh + R with P of the rows before. */
static bool info_gated_out(const struct kalman_state *k, unsigned sensor, fix_q32_t e) {
    const unsigned j = h_index(sensor);
    const bool minus = h_minus(sensor);
    fix_q32_t p[KALMAN_STATES][KALMAN_STATES];
    info_covariance(k, p);
    const fix_q32_t hph = minus ? p[0][0] - 2 * p[0][j] + p[j][j] : p[0][0] + 2 * p[0][j] + p[j][j];
    return gated_out(k, e, hph + k->r[sensor]);
}

/* One row of the information form: every valid reading gated against the state before
 * the row, the accepted ones added, one solve (the fast one while the run allows it).
 * Returns the sensors accepted. */
static uint8_t info_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                        uint8_t valid_mask, bool gate, uint8_t *rejected) {
    uint8_t used = valid_mask;
    if (gate && k->cfg.gate_sigmas_q8 != 0u) {
        /* predictions h·x: A x̄ − θα, B x̄ + θβ, C x̄ + θα, D x̄ − θβ */
        const fix_q32_t pred[ANGLES_SENSORS] = {k->x[0] - k->x[1], k->x[0] + k->x[2],
                                                k->x[0] + k->x[1], k->x[0] - k->x[2]};
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            if ((valid_mask & (1u << s)) == 0u) {
                continue;
            }
            const fix_q32_t e = ((fix_q32_t)range_mm[s] << FIX_Q32_SHIFT) - pred[s];
            /* |e| < 128 mm (the high word in [−128, 127]) and e24² <= q²R or the floor:
             * inside the gate for any s >= R, P not needed */
            const uint32_t e_hi = (uint32_t)((uint64_t)e >> 32) + 128u;
            if (e_hi <= 255u) {
                const int32_t e24 = shr_to_s32(e + 128, 8u);
                const int64_t e24_sq = (int64_t)e24 * e24;
                if ((uint64_t)e24_sq <= k->gate_accept[s]) {
                    continue;
                }
            }
            if (info_gated_out(k, s, e)) {
                used = (uint8_t)(used & ~(1u << s));
            }
        }
    }
    *rejected = (uint8_t)(valid_mask ^ used); /* used is a subset of valid_mask */
    if (used == 0u) {
        return 0u;
    }
    struct kalman_info *in = &k->f.info;
    if (used != ANGLES_ALL_SENSORS) {
        info_end_run(in);
    }
    info_check_sums(in);
    bool solved = false;
    if (in->uniform) {
        /* the run's rows and deviation sums (each below 2^17 per row) */
        in->dsum[0] += (int32_t)range_mm[0] - in->x0_mm;
        in->dsum[1] += (int32_t)range_mm[1] - in->x0_mm;
        in->dsum[2] += (int32_t)range_mm[2] - in->x0_mm;
        in->dsum[3] += (int32_t)range_mm[3] - in->x0_mm;
        in->n++;
        if (!in->fast_ready) {
            info_fast_prepare(in);
        }
        solved = info_fast_solve(k);
    }
    if (!in->uniform) {
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            if ((used & (1u << s)) != 0u) {
                info_add(in, s, range_mm[s]);
            }
        }
    }
    if (!solved) {
        info_solve_general(k);
    }
    return used;
}

/* One row of either form (no prediction): returns the sensors accepted. */
static uint8_t update_any(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                          uint8_t valid_mask, bool gate, uint8_t *rejected) {
    if (!covariance_form(k)) {
        return info_row(k, range_mm, valid_mask, gate, rejected);
    }
    bool ovf = false;
    bool proven;
    const uint8_t used = update_row(k, range_mm, valid_mask, gate, rejected, &ovf, &proven);
    if (used != 0u) {
        check_covariance(k, ovf, proven); /* once per row: a failure restarts P before the next */
    }
    return used;
}

bool kalman_update(struct kalman_state *k, unsigned sensor, uint16_t range_mm, bool gate) {
    if (sensor >= ANGLES_SENSORS || !k->started) {
        return false; /* before the warm-up there is no start to update (kalman.h) */
    }
    uint16_t range[ANGLES_SENSORS] = {0, 0, 0, 0};
    range[sensor] = range_mm;
    uint8_t rejected;
    return update_any(k, range, (uint8_t)(1u << sensor), gate, &rejected) != 0u;
}

void kalman_covariance(const struct kalman_state *k, fix_q32_t p[KALMAN_STATES][KALMAN_STATES]) {
    if (covariance_form(k)) {
        (void)memcpy(p, k->f.cov.p, sizeof k->f.cov.p);
    } else {
        info_covariance(k, p);
    }
}

static void predict(struct kalman_state *k) {
    if (!covariance_form(k)) {
        return;
    }
    k->f.cov.bvalid = false; /* p changes outside the block */
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        if (k->f.cov.p[i][i] < P_MAX_Q32) { /* a long outage saturates here, never overflows */
            const int64_t grown = k->f.cov.p[i][i] + k->cfg.process_noise_mm2[i];
            k->f.cov.p[i][i] = grown < P_MAX_Q32 ? grown : P_MAX_Q32;
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
    if (!covariance_form(k)) {
        /* the information form's prior mean, whole mm: its deviations are integers */
        k->f.info.x0_mm = (int32_t)fix_round_shr_s64(k->x[0], FIX_Q32_SHIFT);
        k->x[0] = (fix_q32_t)k->f.info.x0_mm << FIX_Q32_SHIFT;
    }

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
            uint8_t none;
            (void)update_any(k, k->warm_range[r], used, false, &none);
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
    const uint8_t used = update_any(k, range_mm, valid_mask, true, &rejected);
    out->count = 1;
    out->used[0] = used;
    out->rejected[0] = rejected;
    bool locked_out = false;
    const bool all_used = rejected == 0u && used == ANGLES_ALL_SENSORS; /* the common row */
    if (all_used) {
        (void)memset(k->reject_run, 0, sizeof k->reject_run);
    }
    for (unsigned s = 0; s < ANGLES_SENSORS && !all_used; ++s) {
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
            }
        }
        r_changed(k);
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
        var_mm2 < KALMAN_R_MIN_Q32 ? KALMAN_R_MIN_Q32 : (var_mm2 > R_MAX_Q32 ? R_MAX_Q32 : var_mm2);
    if (!k->r_tracked[sensor]) {
        k->r[sensor] = v; /* the configured R was only a guess */
        k->r_tracked[sensor] = true;
    } else {
        k->r[sensor] += fix_asr_s64(v - k->r[sensor], k->cfg.noise_shift);
    }
    r_changed(k);
}

void kalman_estimate(const struct kalman_state *k, int32_t arm_um, struct kalman_result *out) {
    kalman_covariance(k, out->p_mm2);
    const int64_t observable_below = KALMAN_P0_MM2_Q32 >> 6;
    out->alpha_observable = k->started && out->p_mm2[1][1] < observable_below;
    out->beta_observable = k->started && out->p_mm2[2][2] < observable_below;
    out->distance_mm = k->x[0];
    /* α = atan(θ1 / a): θ1 in mm Q32, a in um → both as um Q32 */
    const int64_t a_q32 = (int64_t)arm_um << FIX_Q32_SHIFT;
    out->alpha_udeg = fix_atan2_udeg(fix_sat_mul_s64(k->x[1], 1000), a_q32);
    out->beta_udeg = fix_atan2_udeg(fix_sat_mul_s64(k->x[2], 1000), a_q32);
    const fix_q32_t ta = fix_div_round_s64(fix_sat_mul_s64(k->x[1], 1000), arm_um);
    const fix_q32_t tb = fix_div_round_s64(fix_sat_mul_s64(k->x[2], 1000), arm_um);
    out->alpha_sigma_udeg = fix_angle_sigma_udeg(out->p_mm2[1][1], arm_um, ta);
    out->beta_sigma_udeg = fix_angle_sigma_udeg(out->p_mm2[2][2], arm_um, tb);
}
