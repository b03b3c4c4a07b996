/*
 * Every driver and array call stays within its time bound under every fault kind, no
 * fault lets a wrong reading through as valid, and the array is back to four ranging
 * sensors once the faults stop. Each kind runs at 2 % per transaction for 3 s of
 * simulated time on the four-sensor head, driven by the reference fault policy
 * (drv_fixture.h), with GPIO1 data ready; the mix of all kinds also runs with data
 * ready read from the register.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "drv_fixture.h"
#include "hal/hal_err.h"
#include "sim/sim_fault.h"

static struct drv_fixture fx;
static struct drv_manager mgr;

#define FAULT_PPM    20000u
#define FAULT_RUN_MS 3000u
/* Two clean seconds: a sensor re-init now blocks ~105 ms (the VHV range at the block's
 * timing), and a few may still be due when the faults stop. */
#define CLEAN_RUN_MS 2000u

static void run_with_faults(const uint32_t ppm[SIM_FAULT_COUNT], bool gpio1, uint32_t seed) {
    drv_fixture_defaults(&fx);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        fx.sensor_cfg[i].verify_distance = true;
        fx.sensor_cfg[i].i2c_timeout_us = 2000u;
        if (!gpio1) {
            fx.sensor_cfg[i].gpio1_pin = VL53_PIN_NONE;
        }
    }
    drv_fixture_build(&fx);
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    drv_manager_init(&mgr, &fx);

    struct sim_fault_config faults = {{0}, seed, 0u};
    memcpy(faults.ppm, ppm, sizeof faults.ppm);
    sim_i2c_set_faults(&fx.rig.bus, &faults);
    uint64_t end = drv_now(&fx) + FAULT_RUN_MS * 1000u;
    while (drv_now(&fx) < end) {
        drv_manager_tick(&mgr, 1000u);
    }
    uint32_t injected = 0u;
    for (unsigned k = 0; k < (unsigned)SIM_FAULT_COUNT; ++k) {
        injected += fx.rig.bus.stats.injected[k];
    }
    sim_i2c_set_faults(&fx.rig.bus, NULL);
    {}
    end = drv_now(&fx) + CLEAN_RUN_MS * 1000u;
    uint64_t results_before[DRV_SENSORS];
    memcpy(results_before, mgr.results, sizeof results_before);
    while (drv_now(&fx) < end) {
        drv_manager_tick(&mgr, 1000u);
    }
    print_message("  injected %u; polls max %u us, recoveries %u ok %u failed (max %u us), "
                  "bus recoveries %u; safe glitches %llu\n",
                  injected, mgr.max_us[DRV_CALL_POLL], mgr.recoveries_ok, mgr.recoveries_failed,
                  mgr.max_us[DRV_CALL_RECOVER_SENSOR], mgr.calls[DRV_CALL_RECOVER_BUS],
                  (unsigned long long)mgr.glitches);
    assert_true(injected > 0u);
    for (unsigned c = 0; c < (unsigned)DRV_CALL_COUNT; ++c) {
        assert_int_equal(mgr.over_budget[c], 0u);
    }
    assert_int_equal(mgr.unsafe_results, 0u);
    /* Healthy again: all four ranging and delivering through the clean second. */
    assert_int_equal(vl53_array_ranging_count(&fx.array), DRV_SENSORS);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        print_message("  sensor %zu: %llu results in the clean second, state %d fault %s err %d "
                      "model addr 0x%02x ranging %d\n",
                      i, (unsigned long long)(mgr.results[i] - results_before[i]),
                      fx.array.report[i].state, vl53_array_fault_name(fx.array.report[i].fault),
                      fx.array.report[i].err, fx.rig.sensor[i].address, fx.rig.sensor[i].ranging);
    }
    /* 100 periods; at most four blocking re-inits (~105 ms, five periods, each) after the
     * faults stopped cost every sensor up to 21 of them. */
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        assert_true(mgr.results[i] - results_before[i] >= 75u);
    }
    assert_true(drv_manager_all_healthy_since(&mgr) < end - 1000000u);
}

static void one_kind(enum sim_fault_kind kind, bool gpio1) {
    uint32_t ppm[SIM_FAULT_COUNT] = {0};
    ppm[kind] = FAULT_PPM;
    print_message("%s:\n", sim_fault_name(kind));
    run_with_faults(ppm, gpio1, 1000u + (uint32_t)kind);
}

static void test_nack(void **state) {
    (void)state;
    one_kind(SIM_FAULT_NACK, true);
}
static void test_stretch(void **state) {
    (void)state;
    one_kind(SIM_FAULT_STRETCH, true);
}
static void test_reset(void **state) {
    (void)state;
    one_kind(SIM_FAULT_RESET, true);
}
static void test_drdy_high(void **state) {
    (void)state;
    one_kind(SIM_FAULT_DRDY_HIGH, true);
}
static void test_drdy_low(void **state) {
    (void)state;
    one_kind(SIM_FAULT_DRDY_LOW, true);
}
static void test_garbage(void **state) {
    (void)state;
    one_kind(SIM_FAULT_GARBAGE, true);
}
static void test_bitflip(void **state) {
    (void)state;
    one_kind(SIM_FAULT_BITFLIP, true);
}
static void test_stuck(void **state) {
    (void)state;
    one_kind(SIM_FAULT_STUCK, true);
}

static void test_all_kinds_register_polling(void **state) {
    (void)state;
    uint32_t ppm[SIM_FAULT_COUNT];
    for (unsigned k = 0; k < (unsigned)SIM_FAULT_COUNT; ++k) {
        ppm[k] = FAULT_PPM / 4u;
    }
    print_message("all kinds, data ready by register:\n");
    run_with_faults(ppm, false, 77u);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nack),
        cmocka_unit_test(test_stretch),
        cmocka_unit_test(test_reset),
        cmocka_unit_test(test_drdy_high),
        cmocka_unit_test(test_drdy_low),
        cmocka_unit_test(test_garbage),
        cmocka_unit_test(test_bitflip),
        cmocka_unit_test(test_stuck),
        cmocka_unit_test(test_all_kinds_register_polling),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
