/*
 * Four sensors on a 100 kHz (standard-mode) bus, as a long harness runs: the array brings them
 * up within its stated bound and they range for a simulated minute at the product's 50 Hz with
 * every reading delivered and exact, no error and no call beyond its bound; the same at 400 kHz
 * as the reference.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "drv_fixture.h"
#include "hal/hal_err.h"

static struct drv_fixture fx;
static struct drv_manager mgr;

static void bring_up_and_range(uint32_t bus_hz) {
    drv_fixture_defaults(&fx);
    fx.rig_cfg.bus_hz = bus_hz;
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        fx.sensor_cfg[i].bus_hz = bus_hz;
    }
    drv_fixture_build(&fx);
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    const uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    const uint64_t took = drv_now(&fx) - t0;
    print_message("%u kHz: bring-up %.1f ms (bound %.1f ms)\n", (unsigned)(bus_hz / 1000u),
                  (double)took / 1000.0, (double)vl53_array_bring_up_budget_us(&fx.array) / 1000.0);
    assert_true(took <= vl53_array_bring_up_budget_us(&fx.array));
    drv_manager_init(&mgr, &fx);
    const uint64_t end = drv_now(&fx) + 60000000u;
    while (drv_now(&fx) < end) {
        drv_manager_tick(&mgr, 1000u);
    }
    const uint32_t period_ms = fx.sensor_cfg[0].timing.inter_measurement_ms;
    const uint64_t expected = 60000u / period_ms;
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        print_message("  sensor %zu: %llu results of %llu periods\n", i,
                      (unsigned long long)mgr.results[i], (unsigned long long)expected);
        assert_true(mgr.results[i] + 2u >= expected); /* the first one or two after the start */
        assert_true(mgr.results[i] <= expected + 1u);
    }
    for (size_t e = 0; e < sizeof mgr.errors / sizeof mgr.errors[0]; ++e) {
        assert_int_equal(mgr.errors[e], 0u);
    }
    assert_int_equal(mgr.unsafe_results, 0u);
    assert_int_equal(mgr.glitches, 0u);
    for (size_t c = 0; c < DRV_CALL_COUNT; ++c) {
        assert_int_equal(mgr.over_budget[c], 0u);
    }
    assert_int_equal(mgr.recoveries_ok + mgr.recoveries_failed, 0u);
}

static void test_four_sensors_at_100_khz(void **state) {
    (void)state;
    bring_up_and_range(100000u);
}

static void test_four_sensors_at_400_khz(void **state) {
    (void)state;
    bring_up_and_range(400000u);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_four_sensors_at_100_khz),
        cmocka_unit_test(test_four_sensors_at_400_khz),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
