/*
 * The facade built with the Kalman filter's information form only (KALMAN_TRACKING_BUILT
 * = 0, KALMAN_INFORMATION_BUILT = 1; this test compiles attitude.c and the filter with
 * those definitions): any process noise or `auto` is refused with the estimator's own
 * ATTITUDE_ERR_KALMAN_PROCESS_NOISE, and a refusal leaves a running estimator exactly as it
 * was (the set-process-noise command re-initialises through attitude_init()).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "estimator/attitude.h"

_Static_assert(KALMAN_TRACKING_BUILT == 0 && KALMAN_INFORMATION_BUILT == 1,
               "compiled with the information form only");

static struct attitude_state st;
static struct attitude_state before;

static void test_process_noise_refused_and_state_kept(void **state) {
    (void)state;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    const uint16_t range[ATTITUDE_SENSORS] = {100, 101, 99, 100};
    const uint8_t status[ATTITUDE_SENSORS] = {0, 0, 0, 0};
    const bool present[ATTITUDE_SENSORS] = {true, true, true, true};
    static struct attitude_output out;
    for (unsigned row = 0; row < 30u; ++row) {
        (void)attitude_push_sample(&st, range, status, present, &out);
    }
    assert_int_equal(st.rows, 30);
    memcpy(&before, &st, sizeof before);

    struct attitude_config next = cfg;
    next.kalman_process_noise_um2[0] = 40000u; /* 2 mm²/s at 20 ms */
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_KALMAN_PROCESS_NOISE);
    next = cfg;
    next.kalman_process_noise_um2[2] = 1u; /* the smallest Q of a·tan β */
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_KALMAN_PROCESS_NOISE);
    next = cfg;
    next.kalman_process_noise_auto = true;
    assert_int_equal(attitude_init(&st, &next), ATTITUDE_ERR_KALMAN_PROCESS_NOISE);
    assert_memory_equal(&before, &st, sizeof before); /* nothing changed */

    /* Q = 0 still runs, and re-initialises as a window change does */
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    assert_int_equal(st.rows, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_process_noise_refused_and_state_kept),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
