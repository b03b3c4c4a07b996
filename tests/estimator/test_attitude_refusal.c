/*
 * attitude_init() refusing a Kalman configuration (formerly test_attitude_information.c,
 * the information-form-only build, which refused any process noise): a refusal leaves a
 * running estimator exactly as it was (the set-process-noise command re-initialises
 * through attitude_init()), and any process noise or `auto` is accepted (the one filter
 * runs any Q >= 0 in every build).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "estimator/attitude.h"

static struct attitude_state st;
static struct attitude_state before;

/* A running estimator: the default configuration, 30 rows of a static plate. */
static void run_30_rows(struct attitude_config *cfg) {
    attitude_config_default(cfg);
    cfg->calibration.calibrated = true; /* an exact calibration */
    assert_int_equal(attitude_init(&st, cfg), ATTITUDE_ERR_NONE);
    const uint16_t range[ATTITUDE_SENSORS] = {100, 101, 99, 100};
    const uint8_t status[ATTITUDE_SENSORS] = {0, 0, 0, 0};
    const bool present[ATTITUDE_SENSORS] = {true, true, true, true};
    static struct attitude_output out;
    for (unsigned row = 0; row < 30u; ++row) {
        (void)attitude_push_sample(&st, range, status, present, &out);
    }
    assert_int_equal(st.rows, 30);
}

static void test_refusal_keeps_state(void **state) {
    (void)state;
    struct attitude_config cfg;
    run_30_rows(&cfg);
    memcpy(&before, &st, sizeof before);

    struct attitude_config next = cfg;
    next.kalman_warmup_rows = 0u;
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_KALMAN_WARMUP);
    next = cfg;
    next.kalman_noise_shift = 9u;
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_KALMAN_NOISE_SHIFT);
    next = cfg;
    next.kalman_initial_noise_um2[1] = 83333u; /* below 1/12 mm² */
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE);
    assert_memory_equal(&before, &st, sizeof before); /* nothing changed */

    /* Q = 0 still runs, and re-initialises as a window change does */
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    assert_int_equal(st.rows, 0);
}

static void test_any_process_noise_accepted(void **state) {
    (void)state;
    struct attitude_config cfg;
    run_30_rows(&cfg);
    struct attitude_config next = cfg;
    next.kalman_process_noise_um2[0] = 40000u; /* 2 mm²/s at 20 ms */
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_NONE);
    next = cfg;
    next.kalman_process_noise_um2[2] = 1u; /* the smallest Q of a·tan β */
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_NONE);
    next = cfg;
    next.kalman_process_noise_um2[1] = UINT32_MAX; /* the largest, far below P0 */
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_NONE);
    next = cfg;
    next.kalman_process_noise_auto = true;
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_NONE);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_refusal_keeps_state),
        cmocka_unit_test(test_any_process_noise_accepted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
