/* The Kalman filter of Eq. 5 / Alg. 2, its top (init, warm-up, lock-out, noise tracking,
 * estimate): see estimator/kalman.h; the update is kalman_track.c, the gate kalman_gate.c,
 * process_noise_auto kalman_adapt.c. */
#include <string.h>

#include "kalman_internal.h"

static void r_changed(struct kalman_state *k);

int kalman_config_check(const struct kalman_config *cfg) {
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        if (cfg->process_noise_mm2[i] < 0 || cfg->process_noise_mm2[i] > KALMAN_P0_MM2_Q32) {
            return KALMAN_ERR_PROCESS_NOISE;
        }
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if (cfg->initial_noise_mm2[s] < KALMAN_R_MIN_Q32 ||
            cfg->initial_noise_mm2[s] > KALMAN_R_MAX_Q32) {
            return KALMAN_ERR_MEASUREMENT_NOISE;
        }
    }
    if (cfg->warmup_rows < 1u || cfg->warmup_rows > KALMAN_WARMUP_MAX) {
        return KALMAN_ERR_WARMUP;
    }
    if (cfg->noise_shift > 8u) {
        return KALMAN_ERR_NOISE_SHIFT;
    }
    return KALMAN_OK;
}

int kalman_init(struct kalman_state *k, const struct kalman_config *cfg) {
    const int rc = kalman_config_check(cfg);
    if (rc != KALMAN_OK) {
        return rc;
    }
    (void)memset(k, 0, sizeof *k);
    k->cfg = *cfg;
    kalman_gate_init(k);
    k->process_noise = cfg->process_noise_mm2[0] != 0 || cfg->process_noise_mm2[1] != 0 ||
                       cfg->process_noise_mm2[2] != 0 || cfg->process_noise_auto;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        k->r[s] = cfg->initial_noise_mm2[s];
    }
    r_changed(k);
    kalman_reset(k);
    return KALMAN_OK;
}

void kalman_reset(struct kalman_state *k) {
    (void)memset(k->x, 0, sizeof k->x);
    kalman_track_reset(k);
    k->started = false;
    k->warm_rows = 0;
    (void)memset(k->reject_run, 0, sizeof k->reject_run);
}

/* Everything that depends on R, after R changed. */
static void r_changed(struct kalman_state *k) {
    kalman_gate_refresh(k);
    kalman_track_r_changed(k);
}

bool kalman_update(struct kalman_state *k, unsigned sensor, uint16_t range_mm, bool gate) {
    if (sensor >= ANGLES_SENSORS || !k->started) {
        return false; /* before the warm-up there is no start to update (kalman.h) */
    }
    uint16_t range[ANGLES_SENSORS] = {0, 0, 0, 0};
    range[sensor] = range_mm;
    uint8_t rejected;
    return kalman_track_row(k, range, (uint8_t)(1u << sensor), gate, &rejected) != 0u;
}

void kalman_covariance(const struct kalman_state *k, fix_q32_t p[KALMAN_STATES][KALMAN_STATES]) {
    kalman_track_covariance(k, p);
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
        kalman_track_predict(k);
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
            (void)kalman_track_row(k, k->warm_range[r], used, false, &none);
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
    if (k->cfg.process_noise_auto && kalman_adapt_row(k, range_mm, valid_mask)) {
        r_changed(k);
    }
    if (!k->started) {
        (void)memcpy(k->warm_range[k->warm_rows], range_mm, sizeof k->warm_range[0]);
        k->warm_valid[k->warm_rows] = valid_mask;
        k->warm_rows++;
        if (k->warm_rows >= k->cfg.warmup_rows) {
            flush_warmup(k, out);
        }
        return;
    }
    kalman_track_predict(k);
    uint8_t rejected = 0;
    const uint8_t used = kalman_track_row(k, range_mm, valid_mask, true, &rejected);
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
                k->r[s] = k->r[s] < KALMAN_R_MAX_Q32 / 4 ? 4 * k->r[s] : KALMAN_R_MAX_Q32;
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

bool kalman_track_noise(struct kalman_state *k, unsigned sensor, fix_q32_t var_mm2,
                        uint16_t count) {
    if (count < 2u || sensor >= ANGLES_SENSORS || k->cfg.process_noise_auto) {
        return false;
    }
    /* Bounded like a configured R: a window variance beyond σ = 1024 mm (readings 0 and
     * 65535 mm in one window give 2^31 mm²) would overflow s = hᵀPh + R. */
    const fix_q32_t v = var_mm2 < KALMAN_R_MIN_Q32
                            ? KALMAN_R_MIN_Q32
                            : (var_mm2 > KALMAN_R_MAX_Q32 ? KALMAN_R_MAX_Q32 : var_mm2);
    bool guess_off = false;
    if (!k->r_tracked[sensor]) {
        /* against the configured guess (a lock-out may have raised k->r x4 already) */
        const fix_q32_t guess = k->cfg.initial_noise_mm2[sensor];
        /* more than 2x (4x from 8 to 31 readings, whose variance scatters more; never from
         * fewer): beyond what χ² scatter gives (χ²_31/31 > 2 and χ²_7/7 > 4 each below
         * 10^-3) */
        int64_t f = 0;
        if (count >= 32u) {
            f = 2;
        } else if (count >= 8u) {
            f = 4;
        } else {
            f = 0;
        }
        guess_off = f != 0 && v > f * guess; /* v, guess < 2^53 */
        k->r[sensor] = v;                    /* the configured R was only a guess */
        k->r_tracked[sensor] = true;
    } else {
        k->r[sensor] += fix_asr_s64(v - k->r[sensor], k->cfg.noise_shift);
    }
    r_changed(k);
    return guess_off;
}

void kalman_process_noise(const struct kalman_state *k, fix_q32_t q[KALMAN_STATES]) {
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        q[i] = k->cfg.process_noise_mm2[i];
    }
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
