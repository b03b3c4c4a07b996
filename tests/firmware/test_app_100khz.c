/*
 * The firmware on a 100 kHz (standard-mode) bus, the simulated rig's bus at that clock: the
 * application brings the four sensors up and ranges a minute at the longest-harness default
 * (a 40 ms period) with every sample assembled and read, no read error and no loop overrun;
 * a period whose readings would take more than half of it on the wire is refused, at init
 * and by set-period (tof_app_bus_fits()), and the same periods at 400 kHz are not.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "firmware/app.h"
#include "firmware/config.h"
#include "hal/hal_err.h"
#include "sim/sim_rig.h"

static struct sim_rig rig;
static struct tof_app app;
static struct tof_platform platform;

static int start(uint16_t khz, uint32_t period_ms) {
    struct sim_rig_config rc;
    sim_rig_default_config(&rc);
    rc.bus_hz = (uint32_t)khz * 1000u;
    sim_rig_init(&rig, &rc);
    platform = (struct tof_platform){
        .board_name = "test", .i2c = rig.i2c, .gpio = rig.hal_gpio, .time = rig.time};
    for (unsigned i = 0; i < 4; ++i) {
        platform.xshut_pin[i] = SIM_RIG_XSHUT_PIN(i);
        platform.gpio1_pin[i] = SIM_RIG_GPIO1_PIN(i);
    }
    struct tof_app_config cfg = tof_app_default_config;
    cfg.i2c_khz = khz;
    if (tof_app_config_period(&cfg, period_ms) != HAL_OK) {
        return HAL_ERR_INVALID;
    }
    memset(&app, 0, sizeof app);
    return tof_app_init(&app, &platform, &cfg);
}

static void run_s(uint32_t s) {
    const uint64_t end = sim_clock_now(&rig.clock) + (uint64_t)s * 1000000u;
    for (unsigned guard = 0; sim_clock_now(&rig.clock) < end && guard < 10000000u; ++guard) {
        tof_app_step(&app, true);
    }
}

static void test_a_minute_of_ranging_at_100_khz(void **state) {
    (void)state;
    assert_int_equal(start(100u, 40u), HAL_OK);
    run_s(60u);
    const struct tof_app_counters *c = &app.counters;
    print_message("100 kHz, 40 ms: %u samples, %u readings, worst iteration %u us, %u overruns\n",
                  (unsigned)c->samples, (unsigned)c->readings, (unsigned)c->max_iteration_us,
                  (unsigned)c->overruns);
    assert_true(c->samples >= 60000u / 40u - 5u); /* the bring-up's first ~0.2 s */
    assert_true(c->readings >= 4u * c->samples - 4u);
    for (unsigned i = 0; i < 4; ++i) {
        assert_int_equal(c->read_errors[i], 0u);
    }
    assert_int_equal(c->overruns, 0u);
    assert_int_equal(app.assembler.counters.incomplete, 0u); /* every sample has all four */
    assert_int_equal(app.assembler.counters.late + app.assembler.counters.duplicates, 0u);
    assert_int_equal(c->reinits_ok + c->reinits_failed + c->bus_recoveries, 0u);
    assert_true(c->max_iteration_us <= 40000u / 2u);
}

/* At 100 kHz four readings take 14.1 ms on the wire, their skew window 15.1 ms, which must stay
 * under half the period: 20 ms (50 Hz) and 25 ms are refused at init and by set-period, 31 ms
 * and longer accepted; at 400 kHz every VL53L1X period is. */
static void test_periods_the_bus_cannot_carry_are_refused(void **state) {
    (void)state;
    assert_false(tof_app_bus_fits(20u, 100u));
    assert_false(tof_app_bus_fits(30u, 100u));
    assert_true(tof_app_bus_fits(31u, 100u));
    assert_true(tof_app_bus_fits(19u, 400u));
    assert_true(tof_app_bus_fits(10u, 400u));
    assert_false(tof_app_bus_fits(9u, 400u));
    struct tof_app_config cfg = tof_app_default_config;
    cfg.i2c_khz = 100u;
    assert_string_equal(tof_app_config_check(&cfg),
                        "timing (the bus at i2c_khz cannot carry the period)");
    assert_int_equal(start(100u, 20u), HAL_ERR_INVALID);
    assert_int_equal(start(100u, 40u), HAL_OK);
    assert_int_equal(tof_app_set_period(&app, 25u), HAL_ERR_INVALID);
    assert_int_equal(app.cfg.timing.inter_measurement_ms, 40u); /* unchanged */
    assert_int_equal(tof_app_set_period(&app, 33u), HAL_OK);
    assert_int_equal(start(400u, 20u), HAL_OK);
    cfg.i2c_khz = 250u;
    assert_string_equal(tof_app_config_check(&cfg), "i2c_khz");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_a_minute_of_ranging_at_100_khz),
        cmocka_unit_test(test_periods_the_bus_cannot_carry_are_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
