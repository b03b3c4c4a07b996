/*
 * A head calibration stated exact (issue 23): calibrated, offsets 0, gains 1, every sd 0.
 * The estimator's default configuration is an uncalibrated head, never `ok`; a test
 * about `ok` rows of ideal sensors sets this one.
 */
#ifndef TESTS_COMMON_TEST_CALIBRATION_H
#define TESTS_COMMON_TEST_CALIBRATION_H

#include <string.h>

#include "estimator/calibration.h"

static inline void test_calibration_exact(struct calibration_head *c) {
    (void)memset(c, 0, sizeof *c);
    c->calibrated = true;
}

#endif /* TESTS_COMMON_TEST_CALIBRATION_H */
