/* The host's command text (telemetry/tlm_command_text.h, tof_telemetry.py --send syntax) into
 * commands: every verb, its aliases and case, the ranges, and the refusals. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "telemetry/tlm_command_text.h"

static struct tlm_command parse_ok(const char *text) {
    struct tlm_command c;
    const char *why = tlm_command_from_text(text, &c);
    if (why != NULL) {
        fail_msg("'%s': %s", text, why);
    }
    return c;
}

static void test_set_window(void **state) {
    (void)state;
    struct tlm_command c = parse_ok("set-window 50 sliding");
    assert_int_equal(c.type, TLM_TYPE_SET_WINDOW);
    assert_int_equal(c.u.set_window.window_n, 50);
    assert_int_equal(c.u.set_window.mode, TLM_WINDOW_SLIDING);
    c = parse_ok("  SET-WINDOW   255 ");
    assert_int_equal(c.u.set_window.window_n, 255);
    assert_int_equal(c.u.set_window.mode, TLM_WINDOW_TUMBLING);
    c = parse_ok("set-window 2 tumbling");
    assert_int_equal(c.u.set_window.window_n, 2);
    struct tlm_command bad;
    assert_non_null(tlm_command_from_text("set-window 1", &bad));
    assert_non_null(tlm_command_from_text("set-window 256", &bad));
    assert_non_null(tlm_command_from_text("set-window 99999999999", &bad));
    assert_non_null(tlm_command_from_text("set-window 50 rolling", &bad));
    assert_non_null(tlm_command_from_text("set-window", &bad));
    assert_non_null(tlm_command_from_text("set-window 5x", &bad));
}

static void test_estimator_and_plain(void **state) {
    (void)state;
    assert_int_equal(parse_ok("estimator kalman").u.estimator, TLM_ESTIMATOR_KALMAN);
    assert_int_equal(parse_ok("select-estimator consensus-paper").u.estimator,
                     TLM_ESTIMATOR_CONSENSUS_PAPER);
    assert_int_equal(parse_ok("estimator MEAN").u.estimator, TLM_ESTIMATOR_MEAN);
    assert_int_equal(parse_ok("start").type, TLM_TYPE_START);
    assert_int_equal(parse_ok("stop").type, TLM_TYPE_STOP);
    assert_int_equal(parse_ok("status").type, TLM_TYPE_STATUS_REQUEST);
    assert_int_equal(parse_ok("status-request").type, TLM_TYPE_STATUS_REQUEST);
    assert_int_equal(parse_ok("save").type, TLM_TYPE_SAVE);
    assert_true(parse_ok("raw on").u.raw_enable);
    assert_false(parse_ok("raw-stream off").u.raw_enable);
    struct tlm_command bad;
    assert_non_null(tlm_command_from_text("estimator best", &bad));
    assert_non_null(tlm_command_from_text("save now", &bad));
    assert_non_null(tlm_command_from_text("raw maybe", &bad));
    assert_non_null(tlm_command_from_text("raw", &bad));
    assert_non_null(tlm_command_from_text("reboot", &bad));
    assert_non_null(tlm_command_from_text("", &bad));
}

static void test_process_noise(void **state) {
    (void)state;
    struct tlm_command c = parse_ok("process-noise auto");
    assert_int_equal(c.type, TLM_TYPE_SET_PROCESS_NOISE);
    assert_int_equal(c.u.process_noise.flags, TLM_PROCESS_NOISE_AUTO);
    c = parse_ok("set-process-noise 0.5,0.000001");
    assert_int_equal(c.u.process_noise.qd_um2_per_s, 500000u);
    assert_int_equal(c.u.process_noise.qt_um2_per_s, 1u);
    assert_int_equal(c.u.process_noise.flags, 0);
    c = parse_ok("process-noise 4294.967295,12");
    assert_int_equal(c.u.process_noise.qd_um2_per_s, 4294967295u);
    assert_int_equal(c.u.process_noise.qt_um2_per_s, 12000000u);
    struct tlm_command bad;
    assert_non_null(tlm_command_from_text("process-noise 4294.967296,1", &bad));
    assert_non_null(tlm_command_from_text("process-noise 0.1234567,1", &bad));
    assert_non_null(tlm_command_from_text("process-noise 1", &bad));
    assert_non_null(tlm_command_from_text("process-noise ,1", &bad));
    assert_non_null(tlm_command_from_text("process-noise -1,1", &bad));
}

static void test_row_argument(void **state) {
    (void)state;
    uint32_t row = 0;
    struct tlm_command c;
    assert_null(tlm_command_from_arg("3000:raw on", &row, &c));
    assert_int_equal(row, 3000);
    assert_true(c.u.raw_enable);
    assert_null(tlm_command_from_arg("0:set-window 20", &row, &c));
    assert_int_equal(row, 0);
    assert_non_null(tlm_command_from_arg("raw on", &row, &c));
    assert_non_null(tlm_command_from_arg(":raw on", &row, &c));
    assert_non_null(tlm_command_from_arg("4294967296:raw on", &row, &c));
    assert_non_null(tlm_command_from_arg("12:raw", &row, &c));
}

/* set-arm, set-period, the calibration commands (the twin sends every type). */
static void test_arm_period_and_calibration(void **state) {
    (void)state;
    assert_int_equal(parse_ok("set-arm 45.25").u.arm_um, 45250u);
    assert_int_equal(parse_ok("set-arm 1").u.arm_um, 1000u);
    assert_int_equal(parse_ok("SET-ARM 1000").u.arm_um, 1000000u);
    assert_int_equal(parse_ok("set-period 33").u.period_ms, 33u);
    assert_int_equal(parse_ok("set-period 10000").type, TLM_TYPE_SET_PERIOD);
    assert_int_equal(parse_ok("read-calibration").type, TLM_TYPE_READ_CALIBRATION);
    assert_int_equal(parse_ok("re-zero 50").u.rezero_samples, 50u);
    /* tests/twin/head.cal as tools/tof_telemetry.py --send-cal sends it */
    static const char hex[] =
        "020472000000000001010f00e2040000d00700001e000000c8000000f68812fdffff30f8ffff1e000000c8"
        "000000f68824faffffe80300001e000000c8000000f688f401000018fcffff1e000000c8000000f6880000"
        "0000000000000000000000000000000000000000000000000000000000000000";
    char text[300] = "write-calibration ";
    strcat(text, hex);
    const struct tlm_command c = parse_ok(text);
    assert_int_equal(c.type, TLM_TYPE_WRITE_CALIBRATION);
    assert_int_equal(c.u.cal_section[0], 2u);
    assert_int_equal(c.u.cal_section[1], 4u);
    assert_int_equal(c.u.cal_section[2], 114u);
    assert_int_equal(c.u.cal_section[8], 0x01u); /* distance mode short */
    assert_int_equal(c.u.cal_section[83], 0x88u);
    assert_int_equal(c.u.cal_section[117], 0x00u); /* the thermal fields: none */
    struct tlm_command bad;
    static const char *const refused[] = {"set-arm 0.999",
                                          "set-arm 1000.001",
                                          "set-arm 30.0001",
                                          "set-arm",
                                          "set-arm x",
                                          "set-period 0",
                                          "set-period 10001",
                                          "set-period 20.5",
                                          "set-period 20 30",
                                          "re-zero 9",
                                          "re-zero 5001",
                                          "re-zero",
                                          "read-calibration now",
                                          "write-calibration",
                                          "write-calibration 0201",
                                          "write-calibrationx"};
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; ++i) {
        if (tlm_command_from_text(refused[i], &bad) == NULL) {
            fail_msg("'%s' accepted", refused[i]);
        }
    }
    text[18] = '3'; /* section id 3: not a calibration section */
    assert_non_null(tlm_command_from_text(text, &bad));
    text[18] = '0';
    strcat(text, "00"); /* a byte too many */
    assert_non_null(tlm_command_from_text(text, &bad));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_set_window),
        cmocka_unit_test(test_estimator_and_plain),
        cmocka_unit_test(test_process_noise),
        cmocka_unit_test(test_row_argument),
        cmocka_unit_test(test_arm_period_and_calibration),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
