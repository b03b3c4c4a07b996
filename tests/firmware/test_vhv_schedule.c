/*
 * When ST's temperature update reruns (firmware/src/vhv_schedule.c): at 8 °C from a part's last
 * VHV calibration either way and not before, one part at a time, only on a part that ranges,
 * never without a temperature, and a part calibrated at an unknown temperature takes the
 * next known one as its reference.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "firmware/vhv_schedule.h"

#define ALL 0x0Fu

static void test_first_known_temperature_is_the_reference(void **state) {
    (void)state;
    struct tof_vhv_schedule v;
    tof_vhv_schedule_init(&v);
    assert_int_equal(tof_vhv_due(&v, ALL, false, 9000), TOF_VHV_NONE); /* none known */
    assert_false(v.ref_known[0]);
    assert_int_equal(tof_vhv_due(&v, ALL, true, 2000), TOF_VHV_NONE);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_true(v.ref_known[i]);
        assert_int_equal(v.ref_cdeg[i], 2000);
    }
}

static void test_due_at_eight_degrees_either_way(void **state) {
    (void)state;
    struct tof_vhv_schedule v;
    tof_vhv_schedule_init(&v);
    (void)tof_vhv_due(&v, ALL, true, 2000);
    assert_int_equal(tof_vhv_due(&v, ALL, true, 2799), TOF_VHV_NONE);
    assert_int_equal(tof_vhv_due(&v, ALL, true, 1201), TOF_VHV_NONE);
    assert_int_equal(tof_vhv_due(&v, ALL, true, 2800), 0u);
    tof_vhv_schedule_init(&v);
    (void)tof_vhv_due(&v, ALL, true, 2000);
    assert_int_equal(tof_vhv_due(&v, ALL, true, 1200), 0u);
    assert_int_equal(v.active, 0u);
}

static void test_one_part_at_a_time_in_turn(void **state) {
    (void)state;
    struct tof_vhv_schedule v;
    tof_vhv_schedule_init(&v);
    (void)tof_vhv_due(&v, ALL, true, -1000);
    for (unsigned expect = 0; expect < 4u; ++expect) {
        assert_int_equal(tof_vhv_due(&v, ALL, true, -100), expect);
        /* while it runs, nothing else is due */
        assert_int_equal(tof_vhv_due(&v, ALL, true, -100), TOF_VHV_NONE);
        tof_vhv_calibrated(&v, expect, true, -100);
        assert_int_equal(v.active, TOF_VHV_NONE);
    }
    assert_int_equal(tof_vhv_due(&v, ALL, true, -100), TOF_VHV_NONE); /* all recalibrated */
}

static void test_only_a_ranging_part(void **state) {
    (void)state;
    struct tof_vhv_schedule v;
    tof_vhv_schedule_init(&v);
    (void)tof_vhv_due(&v, ALL, true, 2500);
    assert_int_equal(tof_vhv_due(&v, 0x0Cu, true, 3500), 2u); /* A, B not ranging */
    tof_vhv_calibrated(&v, 2u, true, 3500);
    assert_int_equal(tof_vhv_due(&v, 0x00u, true, 3500), TOF_VHV_NONE);
    assert_int_equal(tof_vhv_due(&v, 0x01u, true, 3500), 0u); /* A back: due still */
}

static void test_unknown_calibration_temperature(void **state) {
    (void)state;
    struct tof_vhv_schedule v;
    tof_vhv_schedule_init(&v);
    (void)tof_vhv_due(&v, ALL, true, 2000);
    tof_vhv_calibrated(&v, 1u, false, 0); /* re-initialised while no temperature was read */
    assert_int_equal(tof_vhv_due(&v, ALL, true, 2500), TOF_VHV_NONE);
    assert_int_equal(v.ref_cdeg[1], 2500);
    assert_int_equal(tof_vhv_due(&v, ALL, true, 2850), 0u); /* A from 20 °C, not B */
    tof_vhv_calibrated(&v, 0u, true, 2850);
    assert_int_equal(tof_vhv_due(&v, ALL, true, 2850), 2u); /* C and D next, B is 3.5 away */
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_first_known_temperature_is_the_reference),
        cmocka_unit_test(test_due_at_eight_degrees_either_way),
        cmocka_unit_test(test_one_part_at_a_time_in_turn),
        cmocka_unit_test(test_only_a_ranging_part),
        cmocka_unit_test(test_unknown_calibration_temperature),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
