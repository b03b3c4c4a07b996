/*
 * The Kalman filter's private parts (estimator/src only): what kalman.c (init, warm-up,
 * lock-out, noise tracking, estimate) calls in the files below it, and the constants and
 * helpers they share. Calls point down only:
 *
 *   kalman.c         init, warm-up, lock-out, noise tracking, the estimate
 *   kalman_adapt.c   process_noise_auto: Q and R learnt from the readings
 *   kalman_track.c   the update: scalar and block updates, the covariance
 *   kalman_steady.c  Q > 0 settled: the kept gains' cheap rows
 *   kalman_static.c  Q = 0: each row one least-squares correction
 *   kalman_gate.c    the innovation gate
 *
 * kalman.c calls kalman_adapt.c, kalman_track.c and kalman_gate.c; kalman_track.c calls
 * kalman_steady.c, kalman_static.c and kalman_gate.c; none of these calls up or sideways.
 * Nothing outside estimator/src includes this header but the filter's own white-box tests.
 */
#ifndef ESTIMATOR_KALMAN_INTERNAL_H
#define ESTIMATOR_KALMAN_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/kalman.h"
#include "fixmath_internal.h"

/* Largest accepted R: 2^20 mm² (σ = 1024 mm). */
#define KALMAN_R_MAX_Q32 ((int64_t)1 << 52)
/* Bound of every state, 2^24 mm (16.8 km): far beyond any 16-bit reading, and small
 * enough that a prediction h·x and an innovation z − h·x stay far inside int64. */
#define KALMAN_X_LIMIT_Q32 ((int64_t)1 << 56)
/* Cap of each P_ii under process noise: 16 x the diffuse prior, far above any state worth
 * estimating, and low enough that hᵀPh + R (at most 4 x 2^60 + 2^52) stays inside int64. */
#define KALMAN_P_MAX_Q32 (KALMAN_P0_MM2_Q32 << 4)

/* h = e0 + σ e_j (kalman.h): A (j 1, −), B (j 2, +), C (j 1, +), D (j 2, −). */
FIX_INLINE unsigned kalman_h_index(unsigned sensor) {
    return (sensor & 1u) != 0u ? 2u : 1u;
}
FIX_INLINE bool kalman_h_minus(unsigned sensor) {
    return sensor == (unsigned)ANGLES_A || sensor == (unsigned)ANGLES_D;
}

/* The packed upper triangle of a symmetric 3x3 matrix, 00 01 02 11 12 22: entry i's row
 * and column (kalman_track.c's block, kalman_static.c's M⁻¹). */
FIX_INLINE unsigned kalman_packed_row(unsigned i) {
    static const uint8_t rows[6] = {0u, 0u, 0u, 1u, 1u, 2u};
    return rows[i];
}
FIX_INLINE unsigned kalman_packed_col(unsigned i) {
    static const uint8_t cols[6] = {0u, 1u, 2u, 1u, 2u, 2u};
    return cols[i];
}

/* --- the update (kalman_track.c) --- */

/* The diffuse prior. */
void kalman_track_reset(struct kalman_state *k);
/* R changed (k->r). */
void kalman_track_r_changed(struct kalman_state *k);
/* The prediction of one row: P += Q (bounded). */
void kalman_track_predict(struct kalman_state *k);
/* One row's valid readings, A..D, each a scalar update (gated when `gate`); the
 * definiteness check (a failure restarts P, counted). Returns the sensors accepted,
 * *rejected those gated out. */
uint8_t kalman_track_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                         uint8_t valid_mask, bool gate, uint8_t *rejected);
void kalman_track_covariance(const struct kalman_state *k,
                             fix_q32_t p[KALMAN_STATES][KALMAN_STATES]);

/* --- the steady state (kalman_steady.c) --- */

/* One steady row, all four readings, x += k_s e_s with the kept gains; false (x unchanged)
 * when a reading may be gated out or is 128 mm or more from its prediction. */
bool kalman_steady_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS], bool gate);
/* P settled since `before` (packed upper triangle of the row before): its gains may be kept. */
bool kalman_steady_settled(const struct kalman_state *k, const fix_q32_t before[6]);

/* --- the static run at Q = 0 (kalman_static.c) ---
 * With Q = 0 and every row since the start four accepted readings with the same R, P is
 * M⁻¹/c (M = Σ h hᵀ/R, c the rows' count), so a row is the LS correction of its own
 * readings over c. */

/* After a row of four accepted readings at Q = 0 (P in k->cov.p current): starts the
 * static run when P is M⁻¹/c within 2^-18 (else marks the run broken until the next
 * reset: the rows' information is no longer a multiple of M). */
void kalman_static_try(struct kalman_state *k);

/* One row of the static run, all four readings: true when done (x moved; P is implicit);
 * false, nothing changed, when a reading may be gated out or is 32 mm or more from its
 * prediction (the caller leaves the run and processes the row in full). */
bool kalman_static_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS], bool gate);

/* Leaves the static run: its P written to k->cov.p. */
void kalman_static_leave(struct kalman_state *k);

/* The static run's P (Q32 mm²). */
void kalman_static_covariance(const struct kalman_state *k,
                              fix_q32_t p[KALMAN_STATES][KALMAN_STATES]);

/* --- the innovation gate (kalman_gate.c) --- */

/* The gate's constants of the configuration (k->gate_s_max): after k->cfg is set. */
void kalman_gate_init(struct kalman_state *k);

/* The gate's sure-accept thresholds (k->gate_accept) for the current R: after R changed. */
void kalman_gate_refresh(struct kalman_state *k);

/* The innovation gate: e² > max(k²·s, floor²), e in Q32 mm, s in Q32 mm². */
bool kalman_gated_out(const struct kalman_state *k, fix_q32_t e, fix_q32_t s);

/* --- process_noise_auto (kalman_adapt.c) --- */

/* One row's samples of Q and R (valid_mask: the readings to use); sets k's Q at the end
 * of each block of full rows (and ends the steady state), and returns true when it set a
 * new R (the caller then updates what depends on R: the gate, the steady state). */
bool kalman_adapt_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                      uint8_t valid_mask);

#endif /* ESTIMATOR_KALMAN_INTERNAL_H */
