/* Fixed-point Kalman filter of Eq. 5 / Alg. 2: see estimator/kalman.h. */
#include "estimator/kalman.h"

#include <string.h>

/* 1/12 mm² in Q32: the variance of 1 mm rounding, the floor of every R. */
#define QUANT_VAR_Q32 357913941
/* Largest accepted initial R: 2^20 mm² (σ = 1024 mm). */
#define R_MAX_Q32 ((int64_t)1 << 52)
/* Cap of each P_ii under process noise: 16 x the diffuse prior, far above any state worth
 * estimating, and low enough that hᵀPh + R (at most 4 x 2^60 + 2^52) stays inside int64. */
#define P_MAX_Q32 (KALMAN_P0_MM2_Q32 << 4)

/* Rows of Eq. 5 with the slopes scaled by a: A, B, C, D. */
static const int8_t h_rows[ANGLES_SENSORS][KALMAN_STATES] = {
    {1, -1, 0}, {1, 0, 1}, {1, 1, 0}, {1, 0, -1}};

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
    memset(k, 0, sizeof *k);
    k->cfg = *cfg;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        k->r[s] = cfg->initial_noise_mm2[s];
    }
    kalman_reset(k);
    return KALMAN_OK;
}

static void diffuse_covariance(struct kalman_state *k) {
    memset(k->p, 0, sizeof k->p);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        k->p[i][i] = KALMAN_P0_MM2_Q32;
    }
}

void kalman_reset(struct kalman_state *k) {
    memset(k->x, 0, sizeof k->x);
    diffuse_covariance(k);
    k->started = false;
    k->warm_rows = 0;
    memset(k->reject_run, 0, sizeof k->reject_run);
}

/* Necessary conditions for positive definiteness that fixed-point failures
 * break first: a positive diagonal and every correlation strictly inside ±1. */
static bool covariance_healthy(const fix_q32_t p[KALMAN_STATES][KALMAN_STATES]) {
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        if (p[i][i] <= 0) {
            return false;
        }
    }
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        for (unsigned j = i + 1u; j < KALMAN_STATES; ++j) {
            if (p[i][j] != p[j][i] ||
                fix_s128_cmp(fix_s128_mul(p[i][j], p[i][j]), fix_s128_mul(p[i][i], p[j][j])) >= 0) {
                return false;
            }
        }
    }
    return true;
}

/* e² > max(k²·s, floor²) with e in Q32 mm and s in Q32 mm². */
static bool outside_gate(const struct kalman_state *k, fix_q32_t e, fix_q32_t s) {
    const fix_s128 e2 = fix_s128_mul(e, e); /* Q64 */
    const int64_t g = k->cfg.gate_sigmas_q8;
    /* k² s in Q64 = s · g² · 2^16 (g in Q8, s in Q32) */
    const fix_s128 ks = fix_s128_shl(fix_s128_mul(s, g * g), 16u);
    const int64_t fl = k->cfg.gate_floor_mm;
    const fix_s128 fl2 = fix_s128_shl(fix_s128_from_s64(fl * fl), 64u);
    return fix_s128_cmp(e2, ks) > 0 && fix_s128_cmp(e2, fl2) > 0;
}

bool kalman_update(struct kalman_state *k, unsigned sensor, fix_q32_t z_mm, bool gate) {
    const int8_t *h = h_rows[sensor];
    fix_q32_t g[KALMAN_STATES];
    fix_q32_t hg = 0;
    fix_q32_t pred = 0;
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        g[i] = 0;
        for (unsigned j = 0; j < KALMAN_STATES; ++j) {
            g[i] += h[j] * k->p[i][j]; /* h is 0/±1: additions only */
        }
    }
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        hg += h[i] * g[i];
        pred += h[i] * k->x[i];
    }
    const fix_q32_t s = hg + k->r[sensor];
    const fix_q32_t e = z_mm - pred;
    if (gate && k->cfg.gate_sigmas_q8 != 0u && outside_gate(k, e, s)) {
        return false;
    }
    bool ovf = false;
    fix_q30_t gain[KALMAN_STATES];
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        gain[i] = fix_muldiv_s64(g[i], FIX_Q30_ONE, s, &ovf);
    }
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        k->x[i] += fix_mul_shr_s64(gain[i], e, FIX_Q30_SHIFT, &ovf);
    }
    /* Joseph form P − k gᵀ − g kᵀ + s k kᵀ, one rounding per entry */
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        const fix_q32_t sk_i = fix_mul_shr_s64(s, gain[i], FIX_Q30_SHIFT, &ovf);
        for (unsigned j = i; j < KALMAN_STATES; ++j) {
            const fix_s128 t1 =
                fix_s128_add(fix_s128_mul(gain[i], g[j]), fix_s128_mul(g[i], gain[j]));
            const fix_s128 t2 = fix_s128_mul(sk_i, gain[j]);
            const int64_t d =
                fix_s128_to_s64(fix_s128_shr_round(fix_s128_sub(t1, t2), FIX_Q30_SHIFT), &ovf);
            k->p[i][j] -= d;
            k->p[j][i] = k->p[i][j];
        }
    }
    if (ovf || !covariance_healthy(k->p)) {
        /* forget the covariance, keep the state: counted, never silent */
        diffuse_covariance(k);
        k->numeric_restarts++;
        k->restarts++;
    }
    return true;
}

static void predict(struct kalman_state *k) {
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
    bool has[ANGLES_SENSORS] = {false};
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
                (void)kalman_update(k, s, (fix_q32_t)x << FIX_Q32_SHIFT, false);
                used = (uint8_t)(used | (1u << s));
            }
        }
        out->used[r] = used;
        out->rejected[r] = rejected;
    }
    k->warm_rows = 0;
    k->started = true;
    memset(k->reject_run, 0, sizeof k->reject_run);
}

void kalman_push_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                     uint8_t valid_mask, struct kalman_rows *out) {
    out->count = 0;
    valid_mask = (uint8_t)(valid_mask & ANGLES_ALL_SENSORS);
    if (!k->started) {
        memcpy(k->warm_range[k->warm_rows], range_mm, sizeof k->warm_range[0]);
        k->warm_valid[k->warm_rows] = valid_mask;
        k->warm_rows++;
        if (k->warm_rows >= k->cfg.warmup_rows) {
            flush_warmup(k, out);
        }
        return;
    }
    predict(k);
    uint8_t used = 0;
    uint8_t rejected = 0;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if ((valid_mask & (1u << s)) == 0u) {
            continue;
        }
        if (kalman_update(k, s, (fix_q32_t)range_mm[s] << FIX_Q32_SHIFT, true)) {
            used = (uint8_t)(used | (1u << s));
        } else {
            rejected = (uint8_t)(rejected | (1u << s));
        }
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
        k->r_tracked[sensor] = true;
        return;
    }
    k->r[sensor] += fix_asr_s64(v - k->r[sensor], k->cfg.noise_shift);
}

void kalman_estimate(const struct kalman_state *k, int32_t arm_um, struct kalman_result *out) {
    memcpy(out->p_mm2, k->p, sizeof out->p_mm2);
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
