/*
 * Four-sensor array on the simulated head: bring-up, MCU reset with sensors keeping
 * their addresses, a missing sensor, one stuck at 0x29, devices answering where none
 * should, recovery of a reset sensor without disturbing the others, two sensors reset
 * at once, a stuck bus.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "drv_fixture.h"
#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53_array/vl53_array.h"

static struct drv_fixture fx;

static int setup(void **state) {
    (void)state;
    drv_fixture_defaults(&fx);
    drv_fixture_build(&fx);
    return 0;
}

static void attach(void) {
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
}

/* Run the acquisition loop for `ms` (1 ms tick); count results per sensor; errors fail
 * unless `tolerate_errors`. */
static void run(uint32_t ms, uint32_t got[DRV_SENSORS], bool tolerate_errors) {
    for (uint32_t t = 0; t < ms; ++t) {
        for (size_t i = 0; i < DRV_SENSORS; ++i) {
            if (fx.array.report[i].state != VL53_SENSOR_RANGING) {
                continue;
            }
            struct vl53_result r;
            int err = vl53_array_poll(&fx.array, i, &r);
            if (err == HAL_OK) {
                got[i]++;
                assert_true(drv_result_matches(&fx.rig.sensor[i], &r));
            } else if (!tolerate_errors) {
                assert_int_equal(err, HAL_ERR_NOT_READY);
            }
        }
        drv_sleep(&fx, 1000u);
    }
}

static void test_four_sensor_bring_up(void **state) {
    (void)state;
    attach();
    /* Power-on: all four are out of reset at 0x29 (XSHUT pulled up) before we start. */
    drv_sleep(&fx, 2000u);
    uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    uint64_t took = drv_now(&fx) - t0;
    assert_true(took <= vl53_array_bring_up_budget_us(&fx.array) +
                            VL53_ARRAY_STEPS_PER_SENSOR * DRV_SENSORS * drv_transfer_slack_us(&fx));
    print_message("bring-up of four sensors: %llu us\n", (unsigned long long)took);
    assert_int_equal(vl53_array_ranging_count(&fx.array), 4u);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_int_equal(fx.rig.sensor[i].address, DRV_FIRST_ADDRESS + i);
        assert_true(fx.rig.sensor[i].ranging);
        assert_int_equal(fx.array.report[i].fault, VL53_ARRAY_OK);
        assert_int_equal(fx.rig.sensor[i].stats.protocol_errors, 0u);
    }
    uint8_t id[2];
    assert_int_equal(hal_i2c_reg16_read(&fx.rig.i2c, 0x29, 0x010F, id, 2, 1000u),
                     HAL_ERR_ADDR_NACK);
    uint32_t got[DRV_SENSORS] = {0};
    uint64_t start = drv_now(&fx);
    run(1000u, got, false);
    uint64_t periods = (drv_now(&fx) - start) / 20000u;
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_in_range(got[i], periods - 1u, periods + 1u); /* every measurement, once */
        assert_int_equal(fx.rig.sensor[i].stats.overruns, 0u);
    }
}

static void test_bring_up_again_after_mcu_reset(void **state) {
    (void)state;
    attach();
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    /* The MCU resets: the sensors stay powered at 0x30..0x33, ranging. The new firmware
     * instance knows nothing of that and brings the array up again. */
    memset(&fx.array, 0, sizeof fx.array);
    attach();
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    assert_int_equal(vl53_array_ranging_count(&fx.array), 4u);
    uint32_t got[DRV_SENSORS] = {0};
    run(200u, got, false);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_true(got[i] >= 9u);
    }
}

static void test_missing_sensor(void **state) {
    (void)state;
    fx.rig_cfg.absent[2] = true;
    drv_fixture_build(&fx);
    attach();
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_ERR_ADDR_NACK);
    assert_int_equal(fx.array.report[2].fault, VL53_ARRAY_MISSING);
    assert_int_equal(fx.array.report[2].err, HAL_ERR_ADDR_NACK);
    assert_int_equal(fx.array.report[2].state, VL53_SENSOR_OFF);
    assert_string_equal(vl53_array_fault_name(fx.array.report[2].fault), "missing");
    assert_int_equal(vl53_array_ranging_count(&fx.array), 3u);
    uint32_t got[DRV_SENSORS] = {0};
    run(200u, got, false);
    assert_int_equal(got[2], 0u);
    assert_true(got[3] >= 9u);
    struct vl53_result r;
    assert_int_equal(vl53_array_poll(&fx.array, 2, &r), HAL_ERR_STATE);
    /* Recovery attempts keep failing the same way, quickly. */
    uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 2), HAL_ERR_ADDR_NACK);
    assert_true(drv_now(&fx) - t0 <= vl53_array_recover_budget_us(&fx.array, 2));
}

static void test_sensor_stuck_at_default_address(void **state) {
    (void)state;
    fx.rig_cfg.sensor[1].ignores_address_change = true;
    drv_fixture_build(&fx);
    attach();
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_ERR_ADDR_NACK);
    assert_int_equal(fx.array.report[1].fault, VL53_ARRAY_STUCK_AT_DEFAULT);
    assert_int_equal(fx.array.report[1].conflict_address, 0x29u);
    /* Parked in reset, so 0x29 is free again and the sensors after it came up. */
    assert_false(fx.rig.sensor[1].powered);
    assert_int_equal(fx.array.report[2].state, VL53_SENSOR_RANGING);
    assert_int_equal(fx.array.report[3].state, VL53_SENSOR_RANGING);
    assert_int_equal(vl53_array_ranging_count(&fx.array), 3u);
}

static void test_uncontrolled_device_at_default_address(void **state) {
    (void)state;
    /* Sensor D's XSHUT line is broken (tied high): it sits at 0x29 whatever we do. Releasing
     * any other sensor would put two devices at 0x29, so nothing is released. */
    fx.rig_cfg.sensor[3].xshut_wired = false;
    drv_fixture_build(&fx);
    attach();
    drv_sleep(&fx, 2000u);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_ERR_STATE);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_int_equal(fx.array.report[i].fault, VL53_ARRAY_ADDRESS_CONFLICT);
        assert_int_equal(fx.array.report[i].conflict_address, 0x29u);
    }
    for (size_t i = 0; i < 3u; ++i) {
        assert_false(fx.rig.sensor[i].powered);
    }
    assert_int_equal(fx.rig.sensor[3].stats.address_changes, 0u); /* nobody was moved */
}

static void test_two_devices_at_one_address(void **state) {
    (void)state;
    /* A fifth part, not under XSHUT control, already answers at 0x31 (sensor B's address). */
    static struct sim_vl53 intruder;
    struct sim_vl53_config cfg = {0};
    cfg.xshut_wired = false;
    sim_vl53_init(&intruder, &cfg, &fx.rig.clock, NULL);
    struct sim_i2c_target target = sim_vl53_target(&intruder);
    assert_int_equal(sim_i2c_attach(&fx.rig.bus, &target), 0);
    attach();
    /* Move the intruder to 0x31 while the array sensors are held in reset. */
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_int_equal(vl53_shutdown(&fx.array.dev[i]), HAL_OK);
    }
    drv_sleep(&fx, 1500u);
    uint8_t to = 0x31u;
    assert_int_equal(hal_i2c_reg16_write(&fx.rig.i2c, 0x29, 0x0001, &to, 1u, 1000u), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_ERR_STATE);
    assert_int_equal(fx.array.report[1].fault, VL53_ARRAY_ADDRESS_CONFLICT);
    assert_int_equal(fx.array.report[1].conflict_address, 0x31u);
    assert_false(fx.rig.sensor[1].powered);
    assert_int_equal(vl53_array_ranging_count(&fx.array), 3u);
    assert_int_equal(intruder.address, 0x31u);
}

static void test_recover_reset_sensor_without_disturbing_others(void **state) {
    (void)state;
    attach();
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    uint32_t got[DRV_SENSORS] = {0};
    run(100u, got, false);
    /* Sensor C resets spontaneously: back at 0x29, stopped. */
    assert_true(sim_vl53_inject(&fx.rig.sensor[2], SIM_FAULT_RESET));
    drv_sleep(&fx, 1500u);
    int err = HAL_ERR_NOT_READY;
    struct vl53_result r;
    for (int ms = 0; ms < 100 && err == HAL_ERR_NOT_READY; ++ms) {
        err = vl53_array_poll(&fx.array, 2, &r);
        drv_sleep(&fx, 1000u);
    }
    assert_int_equal(err, HAL_ERR_TIMEOUT); /* no data ready any more: overdue */

    static struct sim_i2c_record log[64];
    sim_i2c_record(&fx.rig.bus, log, 64u);
    uint32_t gpio_writes = fx.rig.gpio.writes;
    struct sim_vl53_stats before[DRV_SENSORS];
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        before[i] = fx.rig.sensor[i].stats;
    }
    uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 2), HAL_OK);
    assert_true(drv_now(&fx) - t0 <= vl53_array_recover_budget_us(&fx.array, 2) +
                                         VL53_ARRAY_STEPS_PER_SENSOR * drv_transfer_slack_us(&fx));
    /* Only 0x29 and C's address were written to; the others saw one model-ID read each
     * (the check that none of them lost its address); only C's XSHUT moved (low, high). */
    assert_true(fx.rig.bus.record_count > 10u);
    uint32_t reads_of_others = 0u;
    for (size_t n = 0; n < fx.rig.bus.record_count && n < 64u; ++n) {
        if (log[n].addr7 != 0x29u && log[n].addr7 != DRV_FIRST_ADDRESS + 2u) {
            assert_int_equal(log[n].tx_len, 2u);
            assert_int_equal(hal_get_be16(log[n].tx), 0x010Fu);
            assert_int_equal(log[n].rx_len, 2u);
            reads_of_others++;
        }
    }
    assert_int_equal(reads_of_others, 3u);
    assert_int_equal(fx.rig.gpio.writes - gpio_writes, 2u);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        if (i == 2u) {
            continue;
        }
        assert_int_equal(fx.rig.sensor[i].stats.starts, before[i].starts);
        assert_int_equal(fx.rig.sensor[i].stats.stops, before[i].stops);
        assert_int_equal(fx.rig.sensor[i].stats.power_ups, before[i].power_ups);
        assert_true(fx.rig.sensor[i].ranging);
    }
    sim_i2c_record(&fx.rig.bus, NULL, 0u);
    memset(got, 0, sizeof got);
    run(200u, got, false);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_true(got[i] >= 9u);
    }
}

static void test_two_sensors_reset_at_once(void **state) {
    (void)state;
    attach();
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    assert_true(sim_vl53_inject(&fx.rig.sensor[0], SIM_FAULT_RESET));
    assert_true(sim_vl53_inject(&fx.rig.sensor[3], SIM_FAULT_RESET));
    drv_sleep(&fx, 1500u);
    /* A is parked, but D still answers at 0x29: recovering A now would collide. */
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 0), HAL_ERR_STATE);
    assert_int_equal(fx.array.report[0].fault, VL53_ARRAY_ADDRESS_CONFLICT);
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 3), HAL_OK);
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 0), HAL_OK);
    assert_int_equal(vl53_array_ranging_count(&fx.array), 4u);
    uint32_t got[DRV_SENSORS] = {0};
    run(100u, got, false);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_true(got[i] >= 4u);
    }
}

static void test_sensor_that_reset_during_recovery_is_caught(void **state) {
    (void)state;
    attach();
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    /* B resets just before C is recovered, and is still silent in early boot when the
     * recovery probes 0x29: it boots alongside C and follows it to C's address. */
    assert_true(sim_vl53_inject(&fx.rig.sensor[1], SIM_FAULT_RESET));
    assert_int_equal(vl53_shutdown(&fx.array.dev[2]), HAL_OK);
    fx.rig.sensor[1].power_up_us = drv_now(&fx) + VL53_ARRAY_XSHUT_LOW_US - 100u;
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 2), HAL_ERR_STATE);
    assert_int_equal(fx.array.report[2].fault, VL53_ARRAY_ADDRESS_CONFLICT);
    assert_int_equal(fx.array.report[2].conflict_address, DRV_FIRST_ADDRESS + 2u);
    assert_int_equal(fx.rig.sensor[1].address, DRV_FIRST_ADDRESS + 2u); /* B did follow */
    assert_false(fx.rig.sensor[2].powered);                             /* C parked */
    /* Recovering B (its XSHUT takes it off C's address), then C, restores all four. */
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 1), HAL_OK);
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 2), HAL_OK);
    assert_int_equal(vl53_array_ranging_count(&fx.array), 4u);
    uint32_t got[DRV_SENSORS] = {0};
    run(100u, got, false);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_true(got[i] >= 4u);
    }
}

static void test_stuck_bus_recovery(void **state) {
    (void)state;
    attach();
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    sim_i2c_set_sda_stuck(&fx.rig.bus, true);
    uint32_t stuck = 0u;
    for (int ms = 0; ms < 40; ++ms) {
        for (size_t i = 0; i < DRV_SENSORS; ++i) {
            struct vl53_result r;
            int err = vl53_array_poll(&fx.array, i, &r);
            assert_true(err == HAL_ERR_NOT_READY || err == HAL_ERR_BUS_STUCK);
            stuck += err == HAL_ERR_BUS_STUCK ? 1u : 0u;
        }
        drv_sleep(&fx, 1000u);
    }
    assert_true(stuck >= 4u);
    assert_int_equal(vl53_array_recover_bus(&fx.array), HAL_OK);
    uint32_t got[DRV_SENSORS] = {0};
    run(100u, got, false);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_true(got[i] >= 4u);
    }
}

static void test_attach_checks(void **state) {
    (void)state;
    fx.sensor_cfg[2].address = 0x31u; /* same as B */
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_ERR_INVALID);
    fx.sensor_cfg[2].address = 0x29u; /* the power-on address */
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_ERR_INVALID);
    fx.sensor_cfg[2].address = 0x32u;
    fx.sensor_cfg[2].xshut_pin = VL53_PIN_NONE;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_ERR_INVALID);
    fx.sensor_cfg[2].xshut_pin = SIM_RIG_XSHUT_PIN(1); /* B's pin */
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_ERR_INVALID);
    fx.sensor_cfg[2].xshut_pin = SIM_RIG_XSHUT_PIN(2);
    fx.array_cfg.count = 5u;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_ERR_INVALID);
    fx.array_cfg.count = 4u;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(fx.rig.bus.stats.transactions, 0u);
    assert_null(vl53_array_sensor(&fx.array, 4u));
    assert_int_equal(vl53_array_recover_sensor(&fx.array, 4u), HAL_ERR_INVALID);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_four_sensor_bring_up, setup),
        cmocka_unit_test_setup(test_bring_up_again_after_mcu_reset, setup),
        cmocka_unit_test_setup(test_missing_sensor, setup),
        cmocka_unit_test_setup(test_sensor_stuck_at_default_address, setup),
        cmocka_unit_test_setup(test_uncontrolled_device_at_default_address, setup),
        cmocka_unit_test_setup(test_two_devices_at_one_address, setup),
        cmocka_unit_test_setup(test_recover_reset_sensor_without_disturbing_others, setup),
        cmocka_unit_test_setup(test_two_sensors_reset_at_once, setup),
        cmocka_unit_test_setup(test_sensor_that_reset_during_recovery_is_caught, setup),
        cmocka_unit_test_setup(test_stuck_bus_recovery, setup),
        cmocka_unit_test_setup(test_attach_checks, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
