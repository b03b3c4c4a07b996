/* The estimator facade's dispatcher: init, the per-row dispatch and the window end. */
/* See estimator/attitude.h; the parts it calls: estimator/src/attitude_internal.h. */
#include "estimator/attitude.h"

#include <string.h>

#include "attitude_internal.h"
#include "fixmath_internal.h"

_Static_assert((ATTITUDE_EST_BUILT) != 0u && ((ATTITUDE_EST_BUILT) & ~0x0Fu) == 0u,
               "ATTITUDE_EST_BUILT: a non-empty mask of the four estimators");

void attitude_config_default(struct attitude_config *cfg) {
    const struct attitude_config defaults = ATTITUDE_CONFIG_DEFAULT;
    *cfg = defaults;
}

/* um² (uint32) as Q32 mm²: x · 2^32 / 1e6, rounded. */
static fix_q32_t um2_to_q32_mm2(uint32_t um2) {
    return fix_muldiv_s64((int64_t)um2, FIX_Q32_ONE, 1000000, NULL);
}

/* A calibrated head's values within the bounds of estimator/calibration.h (an
 * uncalibrated head's are ignored). */
static bool calibration_valid(const struct calibration_head *c) {
    if (!c->calibrated) {
        return true;
    }
    for (unsigned k = 0; k < CALIBRATION_SENSORS; ++k) {
        const int32_t o = c->offset_um[k];
        const int32_t g = c->gain_ppm[k];
        if (o < -CALIBRATION_OFFSET_MAX_UM || o > CALIBRATION_OFFSET_MAX_UM ||
            g < -CALIBRATION_GAIN_MAX_PPM || g > CALIBRATION_GAIN_MAX_PPM ||
            c->offset_sd_um[k] > (uint32_t)CALIBRATION_OFFSET_MAX_UM ||
            c->gain_sd_ppm[k] > (uint32_t)CALIBRATION_GAIN_MAX_PPM) {
            return false;
        }
        if (c->thermal &&
            (c->temp_coeff_nm_per_c[k] < -CALIBRATION_TEMP_COEFF_MAX_NM_PER_C ||
             c->temp_coeff_nm_per_c[k] > CALIBRATION_TEMP_COEFF_MAX_NM_PER_C ||
             c->temp_coeff_sd_nm_per_c[k] > (uint32_t)CALIBRATION_TEMP_COEFF_MAX_NM_PER_C)) {
            return false;
        }
    }
    return !c->thermal || (c->cal_temp_cdeg >= CALIBRATION_TEMP_MIN_CDEG &&
                           c->cal_temp_cdeg <= CALIBRATION_TEMP_MAX_CDEG);
}

/* What the calibration gives the window (the correction) and the integrity (what it
 * leaves in the sd): an uncalibrated head takes offset 0, gain 1 and the parts' spread
 * (CALIBRATION_UNCAL_*, estimator/calibration.h); true when some sd remains. */
static bool calibration_prepare(const struct calibration_head *c, struct window_config *wcfg,
                                struct integrity_config *icfg) {
    bool spread = !c->calibrated;
    for (unsigned k = 0; k < CALIBRATION_SENSORS; ++k) {
        wcfg->offset_um[k] = c->calibrated ? c->offset_um[k] : 0;
        wcfg->gain_ppm[k] = c->calibrated ? c->gain_ppm[k] : 0;
        icfg->cal_gain_ppm[k] = wcfg->gain_ppm[k];
        icfg->cal_offset_sd_um[k] =
            c->calibrated ? c->offset_sd_um[k] : CALIBRATION_UNCAL_OFFSET_SD_UM;
        icfg->cal_gain_sd_ppm[k] =
            c->calibrated ? c->gain_sd_ppm[k] : CALIBRATION_UNCAL_GAIN_SD_PPM;
        icfg->cal_corr_q15[k] = 0; /* uncalibrated: the spread has no correlation */
        if (c->calibrated) {
            icfg->cal_corr_q15[k] = c->offset_gain_corr_q15[k];
        }
        spread = spread || icfg->cal_offset_sd_um[k] != 0u || icfg->cal_gain_sd_ppm[k] != 0u;
    }
    return spread;
}

/* The Kalman filter's configuration from cfg, checked: ATTITUDE_ERR_NONE or the attitude
 * error of the refused field. */
static int kalman_config_from(const struct attitude_config *cfg, struct kalman_config *kcfg) {
    (void)memset(kcfg, 0, sizeof *kcfg);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        kcfg->process_noise_mm2[i] = um2_to_q32_mm2(cfg->kalman_process_noise_um2[i]);
    }
    for (unsigned s = 0; s < ATTITUDE_SENSORS; ++s) {
        kcfg->initial_noise_mm2[s] = um2_to_q32_mm2(cfg->kalman_initial_noise_um2[s]);
    }
    kcfg->gate_sigmas_q8 = cfg->kalman_gate_sigmas_q8;
    kcfg->gate_floor_mm = cfg->gate_floor_mm;
    kcfg->warmup_rows = cfg->kalman_warmup_rows;
    kcfg->noise_shift = cfg->kalman_noise_shift;
    kcfg->process_noise_auto = cfg->kalman_process_noise_auto;
    switch (kalman_config_check(kcfg)) {
    case KALMAN_OK:
        return ATTITUDE_ERR_NONE;
    case KALMAN_ERR_PROCESS_NOISE:
        return ATTITUDE_ERR_KALMAN_PROCESS_NOISE;
    case KALMAN_ERR_MEASUREMENT_NOISE:
        return ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE;
    case KALMAN_ERR_WARMUP:
        return ATTITUDE_ERR_KALMAN_WARMUP;
    default:
        return ATTITUDE_ERR_KALMAN_NOISE_SHIFT;
    }
}

int attitude_init(struct attitude_state *st, const struct attitude_config *cfg) {
    if (st == NULL || cfg == NULL) {
        return ATTITUDE_ERR_NULL;
    }
    if (!angles_arm_valid(cfg->arm_um)) {
        return ATTITUDE_ERR_ARM;
    }
    if (cfg->window < WINDOW_MIN_SAMPLES || cfg->window > ATTITUDE_WINDOW_MAX) {
        return ATTITUDE_ERR_WINDOW;
    }
    if (cfg->mode != ATTITUDE_TUMBLING && cfg->mode != ATTITUDE_SLIDING) {
        return ATTITUDE_ERR_MODE;
    }
    if (cfg->estimators == 0u || (cfg->estimators | ATTITUDE_EST_BUILT) != ATTITUDE_EST_BUILT) {
        return ATTITUDE_ERR_ESTIMATORS;
    }
    if (cfg->consensus_tolerance_udeg < 1 || cfg->consensus_tolerance_udeg > 10000000) {
        return ATTITUDE_ERR_TOLERANCE;
    }
    if (cfg->paper_max_iterations == 0u) {
        return ATTITUDE_ERR_PAPER_ITERATIONS;
    }
    if (!calibration_valid(&cfg->calibration) || cfg->temp_sd_cdeg > 10000u) {
        return ATTITUDE_ERR_CALIBRATION;
    }
    /* every check before the state is touched: a refusal changes nothing (a run-time
     * command re-initialising with a new setting keeps the old one) */
    struct integrity_config icfg = {.arm_um = cfg->arm_um,
                                    .range_max_mm = cfg->range_max_mm,
                                    .parity_sigmas_q8 = cfg->parity_sigmas_q8,
                                    .motion_sigmas_q8 = cfg->motion_sigmas_q8,
                                    .offset_stability_um = cfg->offset_stability_um,
                                    .drift_flag_um = cfg->drift_flag_um,
                                    .drift_shift = cfg->drift_shift,
                                    .period_us = cfg->period_us,
                                    .offset_walk_um2_h = cfg->offset_walk_um2_h,
                                    .max_rate_mdeg_s = cfg->max_rate_mdeg_s,
                                    .calibration_age_s = cfg->calibration_age_s};
    if (!integrity_config_valid(&icfg)) {
        return ATTITUDE_ERR_INTEGRITY;
    }
    struct kalman_config kcfg;
    const int kerr = kalman_config_from(cfg, &kcfg);
    if (kerr != ATTITUDE_ERR_NONE) {
        return kerr;
    }
    struct window_config wcfg = {.arm_um = cfg->arm_um,
                                 .length = cfg->window,
                                 .gate_sigmas_q8 = cfg->gate_sigmas_q8,
                                 .gate_floor_mm = cfg->gate_floor_mm};
    const bool spread = calibration_prepare(&cfg->calibration, &wcfg, &icfg);
    (void)memset(st, 0, sizeof *st);
    st->cfg = *cfg;
    st->icfg = icfg;
    st->cal_spread = spread;
    integrity_init(&st->integrity);
    st->kalman_rows_since_restart = UINT32_MAX;
    if (window_init(&st->window, &wcfg) != WINDOW_OK) {
        return ATTITUDE_ERR_WINDOW; /* unreachable: checked above */
    }
    (void)kalman_init(&st->kalman, &kcfg); /* checked above */
    attitude_thermal_prepare(st);
    return ATTITUDE_ERR_NONE;
}

/* The window-end work: statistics and the four estimators. Not inlined, so that its
 * large frame (consensus results, the paper's matrices) does not sit under the per-row
 * Kalman path's stack. */
FIX_NOINLINE void window_end(struct attitude_state *st, struct attitude_output *out) {
    const struct attitude_config *cfg = &st->cfg;
    const bool kalman_on =
        (cfg->estimators & ATTITUDE_EST_BUILT & ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN)) != 0u;
    window_compute(&st->window, &st->stats);
    const struct window_stats *w = &st->stats;
    /* the drift learning takes one window per block of N rows (every window when tumbling) */
    attitude_thermal_var(st);
    integrity_assess(&st->integrity, &st->icfg, &st->window, w, st->rows,
                     st->rows % cfg->window == 0u, &st->iw);
    if (!cfg->calibration.calibrated) {
        /* never ok: every estimate says why; no drift since a calibration it never had and
         * nothing to recalibrate (its parity reads the parts' spread): only `uncalibrated` */
        const attitude_why_t calibration_bits = ATTITUDE_WHY_RECALIBRATE | ATTITUDE_WHY_DRIFT;
        st->iw.why = (st->iw.why & ~calibration_bits) | ATTITUDE_WHY_UNCALIBRATED;
    }
    /* what the window adds to every estimator's angles, as 1σ: computed once */
    st->extra_udeg[0] = attitude_extra_sd(st, st->iw.extra_var_mm2[INTEGRITY_ALPHA], 0u);
    st->extra_udeg[1] = attitude_extra_sd(st, st->iw.extra_var_mm2[INTEGRITY_BETA], 1u);
    out->last_row = st->rows - 1u;
    out->first_row = st->rows - cfg->window;
    out->rows = cfg->window;

    struct consensus_product_result product;
    (void)memset(&product, 0, sizeof product);
    /* masked with the build's set, so the compiler drops what is not built */
    const uint8_t want = cfg->estimators & ATTITUDE_EST_BUILT;
    /* the Kalman filter is checked against the product's window estimate */
    const bool need_product = (want & (ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS) |
                                       ATTITUDE_EST_BIT(ATTITUDE_EST_PAPER))) != 0u ||
                              kalman_on;
    struct attitude_estimate scratch;
    (void)memset(&scratch, 0, sizeof scratch);
    if (need_product) {
        attitude_run_product(st, &product, &scratch);
    }
    if ((want & ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS)) != 0u) {
        out->est[ATTITUDE_EST_CONSENSUS] = scratch;
    } else {
        attitude_disabled(&out->est[ATTITUDE_EST_CONSENSUS], w);
    }
    if ((want & ATTITUDE_EST_BIT(ATTITUDE_EST_PAPER)) != 0u) {
        attitude_run_paper(st, &product, &out->est[ATTITUDE_EST_PAPER]);
    } else {
        attitude_disabled(&out->est[ATTITUDE_EST_PAPER], w);
    }
    if (kalman_on) {
        attitude_run_kalman(st, &product, &out->est[ATTITUDE_EST_KALMAN]); /* need_product holds */
    } else {
        attitude_disabled(&out->est[ATTITUDE_EST_KALMAN], w);
    }
    if ((want & ATTITUDE_EST_BIT(ATTITUDE_EST_MEAN)) != 0u) {
        attitude_run_mean(st, &out->est[ATTITUDE_EST_MEAN]);
    } else {
        attitude_disabled(&out->est[ATTITUDE_EST_MEAN], w);
    }

    /* R follows each sensor's noise: once per block of N rows */
    if (kalman_on && st->rows % cfg->window == 0u) {
        attitude_kalman_learn_noise(st);
    }
}

void attitude_set_temperature(struct attitude_state *st, bool known, int16_t temp_cdeg) {
    st->temp_known = known;
    st->temp_cdeg = (int16_t)(known ? temp_cdeg : 0);
}

bool attitude_push_sample(struct attitude_state *st, const uint16_t range_mm[ATTITUDE_SENSORS],
                          const uint8_t range_status[ATTITUDE_SENSORS],
                          const bool present[ATTITUDE_SENSORS], struct attitude_output *out) {
    const struct attitude_config *cfg = &st->cfg;
    const bool kalman_on =
        (cfg->estimators & ATTITUDE_EST_BUILT & ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN)) != 0u;
    uint8_t present_mask = 0;
    uint8_t valid_mask = 0;
    uint16_t ranges[ATTITUDE_SENSORS];
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        ranges[k] = present[k] ? range_mm[k] : 0u; /* an absent reading carries nothing */
        if (present[k]) {
            present_mask = (uint8_t)(present_mask | (1u << k));
            if (range_status[k] == 0u) {
                valid_mask = (uint8_t)(valid_mask | (1u << k));
            }
        }
    }
    /* 0, no-target values and readings beyond the mode's range are never used, whatever
     * their status: the window answers from the other sensors */
    valid_mask &= (uint8_t)~integrity_implausible(ranges, present_mask, cfg->range_max_mm);
    if (kalman_on) { /* a restart due, the rows since the last: read by the filter only */
        attitude_kalman_row_start(st);
    }
    if (cfg->mode == ATTITUDE_TUMBLING && st->rows % cfg->window == 0u) {
        window_clear(&st->window);
        if (!st->kalman.process_noise) { /* with Q > 0 the filter tracks across windows */
            kalman_reset(&st->kalman);
        }
    }
    /* the window corrects the readings by the calibration (its offsets at the row's
     * temperature); the filter takes them corrected, in whole mm */
    attitude_thermal_row(st);
    struct window_row *newest = window_push(&st->window, ranges, present_mask, valid_mask);
    if (kalman_on) {
        attitude_kalman_push_row(st, st->window.newest_mm, valid_mask, newest);
    }
    st->rows++;
    const bool ready = cfg->mode == ATTITUDE_TUMBLING ? st->rows % cfg->window == 0u
                                                      : window_fill(&st->window) == cfg->window;
    if (!ready) {
        return false;
    }
    if (kalman_on && cfg->mode == ATTITUDE_TUMBLING) {
        /* a static window ends here: rows still buffered (a restart late in the
         * window, or N below the warm-up) are processed now */
        attitude_kalman_flush(st);
    }
    window_end(st, out);
    return true;
}
