/*
 * The facade built as the flight image builds it (ATTITUDE_EST_BUILT = consensus and
 * kalman, cmake/toolchain/board-nucleo-l476rg.cmake; this test compiles attitude.c with
 * that definition): the default selects exactly the built estimators, a configuration
 * selecting one that is not built is refused, and the built ones estimate a tilted
 * plate as in the full build while the others read "disabled". Its Kalman filter (the one
 * filter of every build) runs Q = 0 and a process noise alike, and with Q > 0 follows a
 * plate that moves.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <stdlib.h>
#include <cmocka.h>

#include "estimator/attitude.h"
#include "test_calibration.h"

#define TEST_PI 3.14159265358979323846
#define FLIGHT_SET                                                                                 \
    (ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS) | ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN))

_Static_assert(ATTITUDE_EST_BUILT == FLIGHT_SET, "compiled with the flight estimator set");

static struct attitude_state st;
static struct attitude_output out;

static void test_default_selects_the_built_set(void **state) {
    (void)state;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    assert_int_equal(cfg.estimators, FLIGHT_SET);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
}

static void test_unbuilt_estimator_refused(void **state) {
    (void)state;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    const uint8_t refused[] = {ATTITUDE_EST_ALL, ATTITUDE_EST_BIT(ATTITUDE_EST_PAPER),
                               ATTITUDE_EST_BIT(ATTITUDE_EST_MEAN),
                               (uint8_t)(FLIGHT_SET | ATTITUDE_EST_BIT(ATTITUDE_EST_MEAN))};
    for (size_t i = 0; i < sizeof refused; ++i) {
        cfg.estimators = refused[i];
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_ESTIMATORS);
    }
    assert_string_equal(attitude_error_message(ATTITUDE_ERR_ESTIMATORS),
                        "estimators selects none, or one unknown or not built into this image");
    cfg.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
}

/* Noise-free plate at α = 2°, β = −1.5° (docs/explanation/architecture.md with a = 30 mm): ranges
 * in whole millimetres, so the estimates are within the quantisation of the true angles. */
static void test_built_estimators_run_others_disabled(void **state) {
    (void)state;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    const double ta = tan(2.0 * TEST_PI / 180), tb = tan(-1.5 * TEST_PI / 180);
    const double x[4] = {400 - 30 * ta, 400 + 30 * tb, 400 + 30 * ta, 400 - 30 * tb};
    const uint8_t status[4] = {0, 0, 0, 0};
    const bool present[4] = {true, true, true, true};
    bool ready = false;
    for (unsigned i = 0; i < cfg.window; ++i) {
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            /* dither between the two neighbouring millimetres in proportion */
            const double f = x[k] - floor(x[k]);
            /* in a scattered order: a dither that rose or fell along the window would be a
             * ramp of the readings, which the integrity rightly calls motion */
            r[k] = (uint16_t)(floor(x[k]) +
                              (((double)((i * 37u + 11u * k) % 100u) + 0.5) / 100.0 < f ? 1 : 0));
        }
        ready = attitude_push_sample(&st, r, status, present, &out);
        assert_int_equal(ready, i + 1u == cfg.window);
    }
    const enum attitude_estimator built[] = {ATTITUDE_EST_CONSENSUS, ATTITUDE_EST_KALMAN};
    for (size_t i = 0; i < 2; ++i) {
        const struct attitude_estimate *e = &out.est[built[i]];
        assert_int_equal(e->status, ATTITUDE_OK);
        assert_true(e->alpha_valid && e->beta_valid);
        assert_true(labs((long)e->alpha_udeg - 2000000L) < 20000L);
        assert_true(labs((long)e->beta_udeg + 1500000L) < 20000L);
    }
    const enum attitude_estimator off[] = {ATTITUDE_EST_PAPER, ATTITUDE_EST_MEAN};
    for (size_t i = 0; i < 2; ++i) {
        const struct attitude_estimate *e = &out.est[off[i]];
        assert_int_equal(e->status, ATTITUDE_INVALID);
        assert_int_equal(e->reason, ATTITUDE_REASON_DISABLED);
        assert_false(e->alpha_valid || e->beta_valid);
    }
}

/* A plate stepping from α = 0 to α = 3° halfway through a sliding run: with Q > 0 the
 * tracking form follows it within a few dozen rows. */
static void test_process_noise_tracks_a_step(void **state) {
    (void)state;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    cfg.kalman_process_noise_um2[0] = 10000u; /* 0.01 mm² per row */
    cfg.kalman_process_noise_um2[1] = 10000u;
    cfg.kalman_process_noise_um2[2] = 10000u;
    cfg.mode = ATTITUDE_SLIDING;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    const uint8_t status[4] = {0, 0, 0, 0};
    const bool present[4] = {true, true, true, true};
    int32_t last_alpha = 0;
    for (unsigned i = 0; i < 600; ++i) {
        const double ta = tan((i < 300 ? 0.0 : 3.0) * TEST_PI / 180);
        const double x[4] = {300 - 30 * ta, 300.0, 300 + 30 * ta, 300.0};
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            /* whole millimetres, dithered between the two neighbours in proportion */
            const double f = x[k] - floor(x[k]);
            const double u = ((double)((i * 37u + k * 11u) % 100u) + 0.5) / 100.0;
            r[k] = (uint16_t)(floor(x[k]) + (u < f ? 1 : 0));
        }
        if (attitude_push_sample(&st, r, status, present, &out)) {
            last_alpha = out.est[ATTITUDE_EST_KALMAN].alpha_udeg;
            if (i == 299u) {
                assert_true(labs((long)last_alpha) < 300000L);
            }
        }
    }
    print_message("alpha after the step %ld udeg\n", (long)last_alpha);
    assert_true(labs((long)last_alpha - 3000000L) < 300000L);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_process_noise_tracks_a_step),
        cmocka_unit_test(test_default_selects_the_built_set),
        cmocka_unit_test(test_unbuilt_estimator_refused),
        cmocka_unit_test(test_built_estimators_run_others_disabled),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
