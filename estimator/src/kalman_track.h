/*
 * The Kalman filter's update (kalman_track.c), private to estimator/src: what kalman.c
 * (init, warm-up, lock-out, noise tracking, estimate) calls, and the constants and helpers
 * the two share. Calls point down only: kalman.c -> kalman_track.c -> kalman_gate.c.
 * Nothing outside estimator/src includes this header but the filter's own white-box tests.
 */
#ifndef ESTIMATOR_KALMAN_TRACK_H
#define ESTIMATOR_KALMAN_TRACK_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/kalman.h"
#include "fix_inline.h"

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

#endif /* ESTIMATOR_KALMAN_TRACK_H */
