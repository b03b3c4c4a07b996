/*
 * The Kalman filter's innovation gate (kalman_gate.c): private to estimator/src. kalman.c
 * (init, R changes) and kalman_track.c (the updates) call it; it calls nothing of theirs.
 */
#ifndef ESTIMATOR_KALMAN_GATE_H
#define ESTIMATOR_KALMAN_GATE_H

#include <stdbool.h>

#include "estimator/kalman.h"

/* The gate's constants of the configuration (k->gate_s_max): after k->cfg is set. */
void kalman_gate_init(struct kalman_state *k);

/* The gate's sure-accept thresholds (k->gate_accept) for the current R: after R changed. */
void kalman_gate_refresh(struct kalman_state *k);

/* The innovation gate: e² > max(k²·s, floor²), e in Q32 mm, s in Q32 mm². */
bool kalman_gated_out(const struct kalman_state *k, fix_q32_t e, fix_q32_t s);

#endif /* ESTIMATOR_KALMAN_GATE_H */
