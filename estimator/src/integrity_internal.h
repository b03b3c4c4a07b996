/*
 * The window integrity's private parts (estimator/src only): what integrity.c, which
 * orchestrates integrity_assess(), calls in the files below it. Calls point down only:
 *
 *   integrity.c         config, the ring pass (each reading's reasons, the ramp sums),
 *                       the slopes, each axis' extra variance, integrity_assess()
 *   integrity_noise.c   each sensor's noise budget: white, drift, prior, rounding
 *   integrity_parity.c  the parity test and the drift it teaches
 *   integrity_motion.c  motion: ramps, late steps, the steady-motion lag and its history
 *   integrity_oscillation.c  motion whatever its shape: the angle combinations' scatter
 *                       against the parity's (integrity.c's ring pass feeds its sums,
 *                       integrity_motion.c asks for its verdict)
 *   integrity_axes.c    the axes' least-squares combinations over a sensor set
 *   integrity_math.c    the shared significance test and square (every file above)
 *
 * Units as estimator/integrity.h: Q32 mm and Q32 mm².
 */
#ifndef ESTIMATOR_INTEGRITY_INTERNAL_H
#define ESTIMATOR_INTEGRITY_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/integrity.h"

/* 1/12 mm² (the variance of 1 mm rounding) and 1/4 mm² in Q32. */
#define Q32_TWELFTH ((fix_q32_t)357913941)
#define Q32_QUARTER ((fix_q32_t)1073741824)

/* v² > k²·var for v in Q32 mm, var in Q32 mm², k in Q8: exact in 128 bits
 * (integrity_math.c: one copy for every file of the family). */
bool integrity_beyond(fix_q32_t v, fix_q32_t var, uint16_t k_q8);

/* v² in Q32 mm² from Q32 mm, saturating (integrity_math.c). */
fix_q32_t integrity_square_q32(fix_q32_t v);

/* (v µm)² in Q32 mm²: v² · 2^32 / 10^6 as v² · round(2^52 / 10^6) / 2^20 (relative error
 * below 10^-10, and no division at the window end). */
static inline fix_q32_t integrity_um2_to_q32(uint16_t v) {
    return fix_mul_shr_s64((int64_t)v * (int64_t)v, (int64_t)4503599627, 20u, NULL);
}

/* v / d for v >= 0 and d in [1, 65535]: the cheap divider (no 64-bit division). */
static inline fix_q32_t integrity_div_small(fix_q32_t v, int32_t d) {
    return (fix_q32_t)fix_div_u64_u16((uint64_t)v, (uint32_t)d);
}

/* integrity_drift_var() (estimator/integrity.h): the state the parity test (integrity_parity.c)
 * learns, read by the noise budget (integrity_noise.c) without calling its neighbour. */
static inline fix_q32_t integrity_drift_var_of(const struct integrity_state *st) {
    fix_q32_t v = st->drift_mm2 > st->drift_long_mm2 ? st->drift_mm2 : st->drift_long_mm2;
    v = v > st->walk_mm2 ? v : st->walk_mm2;
    return v > 0 ? v : 0;
}

/* --- integrity_axes.c ----------------------------------------------------------------- */

/* Least-squares coefficients of an axis over a sensor set, in units of 1/2 (α, β: y =
 * Σ c_k m_k / 2) or 1/4 (x̄: Σ c_k m_k / 4); returns the log2 of that unit, or -1 when
 * the set does not observe the axis. */
int integrity_axis_coeffs(enum integrity_axis axis, uint8_t used, int8_t c[ANGLES_SENSORS]);

/* The three axes' coefficients over one window's sensor set, found once per window. */
struct integrity_axes_coeffs {
    int8_t c[INTEGRITY_AXES][ANGLES_SENSORS];
    int unit[INTEGRITY_AXES]; /* < 0: the set does not observe the axis */
};
void integrity_axes_coeffs(uint8_t used, struct integrity_axes_coeffs *ac);

/* --- integrity_noise.c ------------------------------------------------------------------ */

/* Sums over the used sensors of the variance of their window means. */
struct integrity_noise_sums {
    fix_q32_t base;  /* white noise plus what is not learnt: the prior and the rounding */
    fix_q32_t total; /* ... plus the learnt drift: the parity residual's variance */
};

/* Each used sensor's noise budget: out->used, out->white_mm2 (what the window sees) and
 * out->extra_mm2 (drift, prior, rounding: what it cannot see), and their sums. */
void integrity_noise_budget(const struct integrity_state *st, const struct integrity_config *cfg,
                            const struct window_state *w, const struct window_stats *s,
                            struct integrity_window *out, struct integrity_noise_sums *sums);

/* --- integrity_parity.c ------------------------------------------------------------------ */

/* The parity test of a window with all four sensors (out->parity_mm, parity_failed), the
 * drift it teaches when learn, and the `parity` and `drift` bits of out->why. */
/* The prior walk's variance (Q32 mm², saturating) at `rows` since the start, the
 * calibration's age at the start included. */
fix_q32_t integrity_prior_walk(const struct integrity_config *cfg, uint32_t rows);

void integrity_parity(struct integrity_state *st, const struct integrity_config *cfg,
                      const struct window_stats *s, const struct integrity_noise_sums *sums,
                      bool learn, struct integrity_window *out);

/* What a failed parity (its residual squared: parity2_mm2) adds to an axis with
 * coefficients c (unit: their log2 unit): the disagreement may sit in any one sensor, so
 * the worst one's share. */
fix_q32_t integrity_parity_cover(fix_q32_t parity2_mm2, const int8_t c[ANGLES_SENSORS], int unit);

/* --- integrity_motion.c ------------------------------------------------------------------ */

/* Each used sensor's motion statistics from the ramp sums of out->ramp: the ramp lag and
 * the newest N/8 and N/4 rows' step (out->motion_mm, motion_var_mm2). */
void integrity_motion_sensors(const struct window_state *w, const struct window_stats *s,
                              struct integrity_window *out);

/* Per axis the window observes (ac: the axes' coefficients): its lag (out->lag_mm,
 * lag_var_mm2, moved, the `motion` bit), the steady-motion lag learnt when learn, and in
 * lag2_mm2[axis] the lag² it adds to the axis' variance (0 for an axis not observed). */
void integrity_motion_axes(struct integrity_state *st, const struct integrity_config *cfg,
                           const struct window_state *w, const struct window_stats *s, bool learn,
                           const struct integrity_axes_coeffs *ac, struct integrity_window *out,
                           fix_q32_t lag2_mm2[INTEGRITY_AXES]);

/* At the end of a block: this block's sensor set and means join the history. */
void integrity_motion_remember(struct integrity_state *st, const struct window_stats *s,
                               const struct integrity_window *out);

/* --- integrity_oscillation.c --------------------------------------------------------- */

/* One row with all four readings valid into the sums, in the window's order (oldest first;
 * out->osc zeroed before the first). */
void integrity_oscillation_row(struct integrity_osc_sums *o,
                               const uint16_t range_mm[ANGLES_SENSORS]);

/* Motion whatever its shape, from out->osc: the lag² (Q32 mm²) an excess scatter of the
 * angle combinations over the parity's adds to each angle axis (the motion may be all in
 * one; 0 when no excess is beyond INTEGRITY_MOTION_ALLOW), and out->moved of both angle
 * axes when one is beyond motion_sigmas. */
fix_q32_t integrity_oscillation(const struct integrity_config *cfg, struct integrity_window *out);

#endif /* ESTIMATOR_INTEGRITY_INTERNAL_H */
