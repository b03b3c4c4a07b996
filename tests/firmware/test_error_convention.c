/* The one error convention (docs/reference/errors.md): disjoint blocks, and a counter slot for
 * every hal code. */
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "estimator/attitude.h"
#include "estimator/kalman.h"
#include "estimator/window_stats.h"
#include "firmware/app.h"
#include "hal/hal_err.h"

/* The blocks of hal/include/hal/hal_err.h and docs/reference/errors.md. */
#define WINDOW_BLOCK_FIRST         (-32)
#define WINDOW_BLOCK_END           (-47)
#define KALMAN_BLOCK_FIRST         (-48)
#define KALMAN_BLOCK_END           (-63)
#define ATTITUDE_BLOCK_FIRST       (-64)
#define ATTITUDE_BLOCK_END         (-79)
#define IN_BLOCK(code, first, end) ((code) <= (first) && (code) >= (end))

#define SLOTS_OF(type, field) (sizeof(((type *)0)->field) / sizeof(((type *)0)->field[0]))

/* errors_by_code is sized from the hal codes: one slot each, plus the "other" slot. */
_Static_assert(TOF_ERROR_SLOTS == (unsigned)HAL_ERR_COUNT + 1u, "a slot per hal code + other");
_Static_assert(SLOTS_OF(struct tof_app_counters, errors_by_code) == TOF_ERROR_SLOTS,
               "the counters have a slot for every hal code");
_Static_assert(SLOTS_OF(struct tof_app_health, errors_by_code) == TOF_ERROR_SLOTS,
               "the health report has a slot for every hal code");
_Static_assert(HAL_ERR_LAST < 0 && HAL_ERR_LAST >= HAL_ERR_BLOCK_END, "hal codes in -1..-31");
_Static_assert(HAL_ERR_BLOCK_END == WINDOW_BLOCK_FIRST + 1, "the blocks meet, none overlap");

/* Each estimator code inside its own block. */
_Static_assert(IN_BLOCK(WINDOW_ERR_ARM, WINDOW_BLOCK_FIRST, WINDOW_BLOCK_END) &&
                   IN_BLOCK(WINDOW_ERR_LENGTH, WINDOW_BLOCK_FIRST, WINDOW_BLOCK_END),
               "window_error in -32..-47");
_Static_assert(IN_BLOCK(KALMAN_ERR_PROCESS_NOISE, KALMAN_BLOCK_FIRST, KALMAN_BLOCK_END) &&
                   IN_BLOCK(KALMAN_ERR_MEASUREMENT_NOISE, KALMAN_BLOCK_FIRST, KALMAN_BLOCK_END) &&
                   IN_BLOCK(KALMAN_ERR_WARMUP, KALMAN_BLOCK_FIRST, KALMAN_BLOCK_END) &&
                   IN_BLOCK(KALMAN_ERR_NOISE_SHIFT, KALMAN_BLOCK_FIRST, KALMAN_BLOCK_END),
               "kalman_error in -48..-63");
_Static_assert(IN_BLOCK(ATTITUDE_ERR_ARM, ATTITUDE_BLOCK_FIRST, ATTITUDE_BLOCK_END) &&
                   IN_BLOCK(ATTITUDE_ERR_BUFFER, ATTITUDE_BLOCK_FIRST, ATTITUDE_BLOCK_END),
               "attitude_error in -64..-79");
_Static_assert(ATTITUDE_BLOCK_END >= -128, "a nack carries the code in an i8");

static const char *const unknown_attitude = "unknown attitude error";

/* Every hal code -1..HAL_ERR_LAST is named and has a slot of its own, in range; a code
 * added below HAL_ERR_LAST without moving the marker is caught by the name after it. */
static void test_every_hal_code_has_a_slot(void **state) {
    (void)state;
    bool taken[TOF_ERROR_SLOTS];
    memset(taken, 0, sizeof taken);
    for (int code = -1; code >= HAL_ERR_LAST; --code) {
        assert_string_not_equal(hal_err_name(code), "UNKNOWN");
        const unsigned slot = tof_app_error_slot(code);
        assert_true(slot != TOF_ERROR_SLOT_OTHER);
        assert_true(slot < TOF_ERROR_SLOTS);
        assert_false(taken[slot]);
        taken[slot] = true;
    }
    assert_string_equal(hal_err_name(HAL_ERR_LAST - 1), "UNKNOWN");
    assert_int_equal(tof_app_error_slot(HAL_ERR_DEVICE), (unsigned)-HAL_ERR_DEVICE);
}

/* Codes of other blocks, and numbers no module uses, land in the "other" slot. */
static void test_other_codes_count_as_other(void **state) {
    (void)state;
    const int others[] = {HAL_ERR_LAST - 1,
                          HAL_ERR_BLOCK_END,
                          WINDOW_ERR_ARM,
                          WINDOW_ERR_LENGTH,
                          KALMAN_ERR_WARMUP,
                          ATTITUDE_ERR_ARM,
                          ATTITUDE_ERR_WINDOW,
                          ATTITUDE_ERR_BUFFER,
                          -128,
                          1};
    for (size_t i = 0; i < sizeof others / sizeof others[0]; ++i) {
        assert_int_equal(tof_app_error_slot(others[i]), TOF_ERROR_SLOT_OTHER);
    }
}

/* No number means two things: each module's names know only its own codes. */
static void test_blocks_are_disjoint(void **state) {
    (void)state;
    for (int code = -1; code >= HAL_ERR_LAST; --code) {
        assert_string_equal(attitude_error_message(code), unknown_attitude);
    }
    for (int code = ATTITUDE_ERR_ARM; code >= ATTITUDE_ERR_CALIBRATION; --code) {
        assert_string_not_equal(attitude_error_message(code), unknown_attitude);
        assert_string_equal(hal_err_name(code), "UNKNOWN");
    }
    assert_string_equal(attitude_error_message(ATTITUDE_ERR_CALIBRATION - 1), unknown_attitude);
    const int estimator_codes[] = {WINDOW_ERR_ARM,           WINDOW_ERR_LENGTH,
                                   KALMAN_ERR_PROCESS_NOISE, KALMAN_ERR_MEASUREMENT_NOISE,
                                   KALMAN_ERR_WARMUP,        KALMAN_ERR_NOISE_SHIFT};
    for (size_t i = 0; i < sizeof estimator_codes / sizeof estimator_codes[0]; ++i) {
        assert_string_equal(hal_err_name(estimator_codes[i]), "UNKNOWN");
        assert_string_equal(attitude_error_message(estimator_codes[i]), unknown_attitude);
    }
}

/* The application names a code by its block alone. */
static void test_app_names_a_code_by_its_block(void **state) {
    (void)state;
    static struct tof_app app; /* zero: no estimator refusal recorded */
    for (int code = -1; code >= HAL_ERR_LAST; --code) {
        assert_string_equal(tof_app_error_message(&app, code), hal_err_name(code));
    }
    for (int code = ATTITUDE_ERR_ARM; code >= ATTITUDE_ERR_CALIBRATION; --code) {
        assert_string_equal(tof_app_error_message(&app, code), attitude_error_message(code));
    }
    assert_string_equal(tof_app_error_message(&app, HAL_OK), "OK");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_hal_code_has_a_slot),
        cmocka_unit_test(test_other_codes_count_as_other),
        cmocka_unit_test(test_blocks_are_disjoint),
        cmocka_unit_test(test_app_names_a_code_by_its_block),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
