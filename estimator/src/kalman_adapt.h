/*
 * The Kalman filter's process_noise_auto (kalman_adapt.c), private to estimator/src:
 * kalman.c calls it before each row's prediction; it calls nothing of the filter's.
 */
#ifndef ESTIMATOR_KALMAN_ADAPT_H
#define ESTIMATOR_KALMAN_ADAPT_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/kalman.h"

/* One row's samples of Q and R (valid_mask: the readings to use); sets k's Q at the end
 * of each block of full rows (and ends the steady state), and returns true when it set a
 * new R (the caller then updates what depends on R: the gate, the steady state). */
bool kalman_adapt_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                      uint8_t valid_mask);

#endif /* ESTIMATOR_KALMAN_ADAPT_H */
