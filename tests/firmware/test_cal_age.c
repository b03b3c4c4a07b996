/*
 * The calibration's age counter (firmware/cal_age.h) on the simulated flash: the age after a
 * reset is the age before plus the off allowance, within one interval and never less, through
 * page switches, a new calibration, and a power cut at every step of every write (clean or
 * torn), as the record store's power-cut tests do.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "firmware/cal_age.h"
#include "hal/hal_err.h"
#include "sim/sim_flash.h"

#define PAGE_SIZE 256u /* 32 entries a page: page switches come often */
#define OFF_S     3600u
#define TAG       0x1234u
#define S         1000000ull

static struct sim_flash flash;

static int setup(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&flash, 4u, PAGE_SIZE), HAL_OK);
    return 0;
}

/* A boot: a fresh counter over the same flash (pages 2 and 3; 0 and 1 are the record's). */
static enum tof_cal_age_state boot(struct tof_cal_age *a, uint16_t tag, uint64_t now_us) {
    sim_flash_power_on(&flash);
    assert_int_equal(tof_cal_age_init(a, sim_flash_hal(&flash), 2u, 3u), HAL_OK);
    return tof_cal_age_boot(a, true, tag, OFF_S, now_us);
}

/* Run from `from_s` to `to_s` seconds of the unit's clock, one poll a second. */
static void run(struct tof_cal_age *a, uint64_t from_s, uint64_t to_s) {
    for (uint64_t t = from_s; t <= to_s; ++t) {
        (void)tof_cal_age_poll(a, t * S);
    }
}

static void test_init_checks_its_pages(void **state) {
    (void)state;
    struct tof_cal_age a;
    assert_int_equal(tof_cal_age_init(&a, sim_flash_hal(&flash), 2u, 2u), HAL_ERR_INVALID);
    assert_int_equal(tof_cal_age_init(&a, sim_flash_hal(&flash), 2u, 4u), HAL_ERR_INVALID);
    struct hal_records none = {0};
    assert_int_equal(tof_cal_age_init(&a, none, 0u, 1u), HAL_ERR_INVALID);
    /* no storage or no calibration: nothing kept, age 0 */
    assert_int_equal(tof_cal_age_boot(&a, true, TAG, OFF_S, 0u), TOF_CAL_AGE_NONE);
    assert_int_equal(boot(&a, TAG, 0u), TOF_CAL_AGE_UNKNOWN);
    assert_int_equal(tof_cal_age_init(&a, sim_flash_hal(&flash), 2u, 3u), HAL_OK);
    assert_int_equal(tof_cal_age_boot(&a, false, TAG, OFF_S, 0u), TOF_CAL_AGE_NONE);
    assert_int_equal(tof_cal_age_now_s(&a, 100u * S), 0u);
}

/* Resets after operating times over decades (1 s .. 3 days, many page switches): the age after
 * is the age before plus the allowance, within one interval, never less. */
static void test_the_age_survives_resets(void **state) {
    (void)state;
    struct tof_cal_age a;
    memset(&a, 0, sizeof a);
    assert_int_equal(tof_cal_age_restart(&a, TAG, 0u), HAL_ERR_INVALID); /* no storage */
    assert_int_equal(tof_cal_age_init(&a, sim_flash_hal(&flash), 2u, 3u), HAL_OK);
    assert_int_equal(tof_cal_age_restart(&a, TAG, 0u), HAL_OK); /* calibrated at t = 0 */
    static const uint32_t runs_s[] = {1u, 59u, 600u, 601u, 3599u, 7200u, 86400u, 259200u};
    uint32_t age_before = 0u;
    uint64_t clock_s = 0u; /* the unit's clock restarts at every boot; 0 here the first time */
    for (size_t k = 0; k < sizeof runs_s / sizeof runs_s[0]; ++k) {
        run(&a, clock_s, clock_s + runs_s[k]);
        age_before = tof_cal_age_now_s(&a, (clock_s + runs_s[k]) * S);
        clock_s = 5u; /* the next boot's clock */
        assert_int_equal(boot(&a, TAG, clock_s * S), TOF_CAL_AGE_KEPT);
        const uint32_t after = tof_cal_age_now_s(&a, clock_s * S);
        assert_true(after >= age_before + OFF_S);
        assert_true(after <= age_before + OFF_S + TOF_CAL_AGE_INTERVAL_S);
    }
    assert_true(flash.erases > 10u); /* pages switched many times over */
}

/* A new calibration starts at 0, whatever the old one had reached; another calibration's
 * entries do not count for this one; a reboot without a calibration keeps nothing. */
static void test_a_new_calibration_starts_at_zero(void **state) {
    (void)state;
    struct tof_cal_age a;
    assert_int_equal(boot(&a, TAG, 0u), TOF_CAL_AGE_UNKNOWN);
    assert_int_equal(tof_cal_age_now_s(&a, 0u), 0u); /* no entry: taken as made at this boot */
    run(&a, 0u, 20000u);
    assert_int_equal(tof_cal_age_restart(&a, 0x4321u, 20000u * S), HAL_OK);
    assert_int_equal(tof_cal_age_now_s(&a, 20000u * S), 0u);
    run(&a, 20000u, 21000u);
    assert_int_equal(boot(&a, 0x4321u, 0u), TOF_CAL_AGE_KEPT);
    const uint32_t after = tof_cal_age_now_s(&a, 0u);
    assert_true(after >= 1000u + OFF_S && after <= 1000u + OFF_S + TOF_CAL_AGE_INTERVAL_S);
    /* the old calibration's tag still finds its own, larger age */
    assert_int_equal(boot(&a, TAG, 0u), TOF_CAL_AGE_KEPT);
    assert_true(tof_cal_age_now_s(&a, 0u) >= 20000u + OFF_S);
}

/* A damaged entry (a bit flipped: its CRC fails) is skipped; the one before it holds. */
static void test_a_damaged_entry_is_skipped(void **state) {
    (void)state;
    struct tof_cal_age a;
    assert_int_equal(boot(&a, TAG, 0u), TOF_CAL_AGE_UNKNOWN);
    run(&a, 0u, 1300u); /* entries at 600 (boot), 1200, 1800 */
    const uint16_t page = a.page[a.active];
    const uint16_t last = (uint16_t)(a.next_slot - 1u);
    sim_flash_poke(&flash, page, (uint32_t)last * TOF_CAL_AGE_ENTRY + 1u, 0x01u);
    assert_int_equal(boot(&a, TAG, 0u), TOF_CAL_AGE_KEPT);
    assert_int_equal(tof_cal_age_now_s(&a, 0u), 1200u + OFF_S);
    assert_true(a.next_slot == last + 2u); /* the damaged slot is not programmed again */
}

/* A power cut at every step of every write over a run with page switches, each clean or torn:
 * the next boot's age is never less than the age reached before the cut plus the allowance,
 * and within one interval (plus the allowance the cut boot itself added) of it. */
static void cut_sweep(bool torn) {
    unsigned cuts = 0u;
    for (uint32_t n = 0;; ++n) {
        setup(NULL);
        struct tof_cal_age a;
        assert_int_equal(tof_cal_age_init(&a, sim_flash_hal(&flash), 2u, 3u), HAL_OK);
        assert_int_equal(tof_cal_age_restart(&a, TAG, 0u), HAL_OK);
        assert_int_equal(tof_cal_age_poll(&a, 0u), HAL_OK); /* the calibration's first entry */
        sim_flash_cut_after(&flash, n, torn);
        uint64_t t = 1u;
        uint32_t reached = 0u;
        for (; t <= 40u * TOF_CAL_AGE_INTERVAL_S && flash.powered; ++t) {
            (void)tof_cal_age_poll(&a, t * S);
            if (flash.powered) {
                reached = tof_cal_age_now_s(&a, t * S);
            }
        }
        const bool cut = !flash.powered;
        assert_int_equal(boot(&a, TAG, 0u), TOF_CAL_AGE_KEPT);
        const uint32_t after = tof_cal_age_now_s(&a, 0u);
        assert_true(after >= reached + OFF_S);
        assert_true(after <= reached + OFF_S + TOF_CAL_AGE_INTERVAL_S + 1u);
        /* and the counter goes on from there */
        run(&a, 0u, 2u * TOF_CAL_AGE_INTERVAL_S);
        struct tof_cal_age b;
        assert_int_equal(boot(&b, TAG, 0u), TOF_CAL_AGE_KEPT);
        assert_true(tof_cal_age_now_s(&b, 0u) >= after + 2u * TOF_CAL_AGE_INTERVAL_S + OFF_S);
        if (!cut) {
            break;
        }
        ++cuts;
        assert_true(n < 200u);
    }
    assert_true(cuts > 40u); /* every program and both erases of the run were cut */
}

static void test_power_cut_at_every_step_keeps_the_age(void **state) {
    (void)state;
    cut_sweep(false);
    cut_sweep(true);
}

/* A cut in a new calibration's very first entry: no entry of it stored, so the next boot takes
 * it as made then (unknown, age 0: the status says so), never another calibration's age. */
static void test_a_cut_first_entry_is_unknown(void **state) {
    (void)state;
    struct tof_cal_age a;
    assert_int_equal(boot(&a, 0x0BADu, 0u), TOF_CAL_AGE_UNKNOWN);
    run(&a, 0u, 5000u); /* an older calibration's entries */
    assert_int_equal(tof_cal_age_restart(&a, TAG, 5000u * S), HAL_OK);
    sim_flash_cut_after(&flash, 0u, true);
    (void)tof_cal_age_poll(&a, 5000u * S);
    assert_false(flash.powered);
    assert_int_equal(boot(&a, TAG, 0u), TOF_CAL_AGE_UNKNOWN);
    assert_int_equal(tof_cal_age_now_s(&a, 0u), 0u);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_init_checks_its_pages, setup),
        cmocka_unit_test_setup(test_the_age_survives_resets, setup),
        cmocka_unit_test_setup(test_a_new_calibration_starts_at_zero, setup),
        cmocka_unit_test_setup(test_a_damaged_entry_is_skipped, setup),
        cmocka_unit_test_setup(test_power_cut_at_every_step_keeps_the_age, setup),
        cmocka_unit_test_setup(test_a_cut_first_entry_is_unknown, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
