/*
 * The facade's private parts (estimator/src only): what attitude.c, the dispatcher,
 * calls in the files below it. Calls point down only:
 *
 *   attitude.c            init, the per-row dispatch and the window end
 *   attitude_consensus.c  the product and the paper's consensus estimates
 *   attitude_mean.c       the plain mean estimate
 *   attitude_kalman.c     the Kalman policy: restarts, row outcomes, noise learning,
 *                         the comparison with the window's product estimate
 *   attitude_finish.c     the shared finishing of an estimate: status, settle, sd
 *   attitude_thermal.c    a thermal calibration's correction and its sd
 *   attitude_text.c       names and text (public API only; nothing here)
 *
 * The estimator files call attitude_finish.c; none calls attitude.c or each other.
 */
#ifndef ESTIMATOR_ATTITUDE_INTERNAL_H
#define ESTIMATOR_ATTITUDE_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/attitude.h"

/* --- attitude_thermal.c: a thermal calibration (estimator/calibration.h) -------------- */

/* At init, after st->cfg and the window: each offset's change per 0.01 °C (0 without a
 * thermal calibration). */
void attitude_thermal_prepare(struct attitude_state *st);

/* Before each row enters the window: the window's offsets at the row's temperature
 * (attitude_set_temperature), or at the calibration's without one; nothing without a
 * thermal calibration. */
void attitude_thermal_row(struct attitude_state *st);

/* Before the window's integrity: what the correction leaves in each sensor's offset, as a
 * variance (st->integrity.thermal_var_um2): the coefficient's sd times the distance from
 * the calibration temperature, the coefficient times the temperature's sd, and the step;
 * 0 when the offsets follow no measured temperature. */
void attitude_thermal_var(struct attitude_state *st);

/* --- attitude_finish.c: the shared finishing of an estimate ------------------------- */

/* Zeroes e and copies the window's flatness and per-sensor counts into it. */
void attitude_common_fields(const struct window_stats *w, struct attitude_estimate *e);

/* Sets validity, status and reason from observability; attitude_settle() adds the
 * integrity. */
void attitude_finish_status(struct attitude_estimate *e, bool alpha_ok, bool beta_ok);

/* The integrity of one estimate (docs/explanation/estimators.md "Integrity"): the why set from
 * the window's facts and the estimator's own counts and reason, the sd from the
 * estimator's white-noise 1σ (white_*) and what the window adds (drift, prior, rounding,
 * a failed parity, motion, and extra_* of the estimator's own), and the status: ok only
 * with both angles and an empty set. */
void attitude_settle(const struct attitude_state *st, struct attitude_estimate *e,
                     int32_t white_alpha_udeg, int32_t white_beta_udeg, fix_q32_t white_dist_mm2,
                     int32_t extra_alpha_udeg, int32_t extra_beta_udeg, attitude_why_t own);

/* An angle's 1σ (µdeg) from its y = a·tan variance (Q32 mm²) at the window's slope
 * (axis 0: α, 1: β). */
int32_t attitude_angle_sd(const struct attitude_state *st, fix_q32_t var_mm2, unsigned axis);

/* attitude_angle_sd() of what the window adds to an axis (drift, prior, rounding, the
 * calibration, ...): with a calibration sd (st->cal_spread) at the slope 3 of its sd
 * nearer 0, so that the tens of degrees an uncalibrated head can be off stay covered. */
int32_t attitude_extra_sd(const struct attitude_state *st, fix_q32_t var_mm2, unsigned axis);

/* White variance (Q32 mm²) of the window's least-squares distance x̄. */
fix_q32_t attitude_window_white_dist(const struct attitude_state *st);

/* Mean distance (µm): the midpoint of each complete opposite pair, averaged; false (and
 * 0) without a complete pair. */
bool attitude_pair_midpoints_um(const struct window_stats *w, int32_t *out_um);

/* Q32 mm as µm, saturating. */
int32_t attitude_q32_mm_to_um(fix_q32_t mm);

/* An estimator not selected in the configuration: invalid, reason and why `disabled`. */
void attitude_disabled(struct attitude_estimate *e, const struct window_stats *w);

/* --- the estimators: one window estimate each, from st->stats and st->iw ------------ */

/* attitude_consensus.c: the product rule (its result kept in *res for the paper's and
 * the Kalman filter's checks) and the paper's weighting, checked against it. */
void attitude_run_product(struct attitude_state *st, struct consensus_product_result *res,
                          struct attitude_estimate *e);
void attitude_run_paper(struct attitude_state *st, const struct consensus_product_result *product,
                        struct attitude_estimate *e);

/* attitude_mean.c: the plain average of the five angle estimates. */
void attitude_run_mean(struct attitude_state *st, struct attitude_estimate *e);

/* --- attitude_kalman.c: the Kalman policy -------------------------------------------- */

/* The filter's estimate for the window, compared with the window's product estimate
 * (product: that estimate, or NULL). */
void attitude_run_kalman(struct attitude_state *st, const struct consensus_product_result *product,
                         struct attitude_estimate *e);

/* The restart the last window asked for (st->kalman_restart_due), before this row. */
void attitude_kalman_restart(struct attitude_state *st);

/* Before each row: a restart the last window asked for, and the rows since the last.
 * Inline: it runs on every row, and a restart is rare. */
static inline void attitude_kalman_row_start(struct attitude_state *st) {
    if (st->kalman_restart_due) { /* the last window found the configured R wrong */
        attitude_kalman_restart(st);
    }
    if (st->kalman_rows_since_restart < UINT32_MAX) {
        st->kalman_rows_since_restart++;
    }
}

/* The row just pushed into the window (newest: its ring row) through the filter, its
 * outcomes kept in the ring rows. */
void attitude_kalman_push_row(struct attitude_state *st, const uint16_t ranges[ATTITUDE_SENSORS],
                              uint8_t valid_mask, struct window_row *newest);

/* A tumbling window's end: the rows the filter still buffers are processed now. */
void attitude_kalman_flush(struct attitude_state *st);

/* At the end of a block of N rows: R follows each sensor's noise (st->stats), and a
 * configured guess found wrong restarts a filter that outlives its windows. */
void attitude_kalman_learn_noise(struct attitude_state *st);

#endif /* ESTIMATOR_ATTITUDE_INTERNAL_H */
