/* The estimator facade's dispatcher: init, the per-row dispatch and the window end. */
/* See estimator/attitude.h; the parts it calls: estimator/src/attitude_internal.h. */
#include "estimator/attitude.h"

#include <string.h>

#include "attitude_internal.h"
#include "fix_inline.h"

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
    const struct integrity_config icfg = {.arm_um = cfg->arm_um,
                                          .range_max_mm = cfg->range_max_mm,
                                          .parity_sigmas_q8 = cfg->parity_sigmas_q8,
                                          .motion_sigmas_q8 = cfg->motion_sigmas_q8,
                                          .offset_stability_um = cfg->offset_stability_um,
                                          .drift_flag_um = cfg->drift_flag_um,
                                          .drift_shift = cfg->drift_shift,
                                          .period_us = cfg->period_us,
                                          .offset_walk_um2_h = cfg->offset_walk_um2_h};
    if (!integrity_config_valid(&icfg)) {
        return ATTITUDE_ERR_INTEGRITY;
    }
    struct kalman_config kcfg;
    (void)memset(&kcfg, 0, sizeof kcfg);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        kcfg.process_noise_mm2[i] = um2_to_q32_mm2(cfg->kalman_process_noise_um2[i]);
    }
    for (unsigned s = 0; s < ATTITUDE_SENSORS; ++s) {
        kcfg.initial_noise_mm2[s] = um2_to_q32_mm2(cfg->kalman_initial_noise_um2[s]);
    }
    kcfg.gate_sigmas_q8 = cfg->kalman_gate_sigmas_q8;
    kcfg.gate_floor_mm = cfg->gate_floor_mm;
    kcfg.warmup_rows = cfg->kalman_warmup_rows;
    kcfg.noise_shift = cfg->kalman_noise_shift;
    kcfg.process_noise_auto = cfg->kalman_process_noise_auto;
    /* every check before the state is touched: a refusal changes nothing (a run-time
     * command re-initialising with a new setting keeps the old one) */
    switch (kalman_config_check(&kcfg)) {
    case KALMAN_OK:
        break;
    case KALMAN_ERR_PROCESS_NOISE:
        return ATTITUDE_ERR_KALMAN_PROCESS_NOISE;
    case KALMAN_ERR_MEASUREMENT_NOISE:
        return ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE;
    case KALMAN_ERR_WARMUP:
        return ATTITUDE_ERR_KALMAN_WARMUP;
    default:
        return ATTITUDE_ERR_KALMAN_NOISE_SHIFT;
    }
    (void)memset(st, 0, sizeof *st);
    st->cfg = *cfg;
    st->icfg = icfg;
    integrity_init(&st->integrity);
    st->kalman_rows_since_restart = UINT32_MAX;
    const struct window_config wcfg = {.arm_um = cfg->arm_um,
                                       .length = cfg->window,
                                       .gate_sigmas_q8 = cfg->gate_sigmas_q8,
                                       .gate_floor_mm = cfg->gate_floor_mm};
    if (window_init(&st->window, &wcfg) != WINDOW_OK) {
        return ATTITUDE_ERR_WINDOW; /* unreachable: checked above */
    }
    (void)kalman_init(&st->kalman, &kcfg); /* checked above */
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
    integrity_assess(&st->integrity, &st->icfg, &st->window, w, st->rows,
                     st->rows % cfg->window == 0u, &st->iw);
    /* what the window adds to every estimator's angles, as 1σ: computed once */
    st->extra_udeg[0] = attitude_angle_sd(st, st->iw.extra_var_mm2[INTEGRITY_ALPHA], 0u);
    st->extra_udeg[1] = attitude_angle_sd(st, st->iw.extra_var_mm2[INTEGRITY_BETA], 1u);
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
    struct window_row *newest = window_push(&st->window, ranges, present_mask, valid_mask);
    if (kalman_on) {
        attitude_kalman_push_row(st, ranges, valid_mask, newest);
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
