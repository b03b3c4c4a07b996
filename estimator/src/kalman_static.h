/*
 * The Kalman filter's static run (kalman_static.c), private to estimator/src: with Q = 0
 * and every row since the start four accepted readings with the same R, P is M⁻¹/c
 * (M = Σ h hᵀ/R, c the rows' count), so a row is the LS correction of its own readings
 * over c. kalman_track.c calls it; it calls nothing of the filter's.
 */
#ifndef ESTIMATOR_KALMAN_STATIC_H
#define ESTIMATOR_KALMAN_STATIC_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/kalman.h"

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

#endif /* ESTIMATOR_KALMAN_STATIC_H */
