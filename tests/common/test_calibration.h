/*
 * Head calibrations for tests. Exact: calibrated, offsets 0, gains 1, every sd 0
 * (the estimator's default configuration is an uncalibrated head, never `ok`; a test about
 * `ok` rows of ideal sensors sets this one). Fitted: a realistic head with every field set.
 */
#ifndef TESTS_COMMON_TEST_CALIBRATION_H
#define TESTS_COMMON_TEST_CALIBRATION_H

#include <string.h>

#include "estimator/calibration.h"

static inline void test_calibration_exact(struct calibration_head *c) {
    (void)memset(c, 0, sizeof *c);
    c->calibrated = true;
}

/* A head as `host_sim calibrate` writes one: offsets of up to 12 mm, gains of up to 1.2 %, sds
 * of about 30 µm and 200 ppm, a strong negative correlation of offset and gain errors. */
static inline void test_calibration_fitted(struct calibration_head *c) {
    const struct calibration_head head = {
        .calibrated = true,
        .offset_um = {-3105, 7882, 516, -12340},
        .gain_ppm = {4100, -8130, 12020, -3450},
        .offset_sd_um = {28, 29, 28, 30},
        .gain_sd_ppm = {190, 200, 190, 210},
        .offset_gain_corr_q15 = {-30474, -30500, -30000, -32768},
    };
    *c = head;
}

#endif /* TESTS_COMMON_TEST_CALIBRATION_H */
