/*
 * The VL53 driver against one simulated VL53 (the other three sensors absent): the happy
 * path, the exact bytes of initialisation and of one read, configuration checks, timing
 * changes, polarity, overruns, overdue data, and each fault kind injected on purpose.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "drv_fixture.h"
#include "hal/hal_err.h"
#include "uld_reference.h"
#include "hal/hal_i2c_reg.h"
#include "vl53/vl53.h"

static struct drv_fixture fx;
static struct vl53_dev dev;

static int setup(void **state) {
    (void)state;
    drv_fixture_defaults(&fx);
    fx.rig_cfg.absent[1] = true;
    fx.rig_cfg.absent[2] = true;
    fx.rig_cfg.absent[3] = true;
    drv_fixture_build(&fx);
    return 0;
}

/* Rebuild after changing fx.rig_cfg / fx.sensor_cfg in a test. */
static void rebuild(void) {
    drv_fixture_build(&fx);
}

/* Call `expr`, check it returned `expected` within `budget_us` (+ one transfer). */
#define EXPECT_WITHIN(expected, budget_us, expr)                                                   \
    do {                                                                                           \
        uint64_t t0_ = drv_now(&fx);                                                               \
        assert_int_equal((expr), (expected));                                                      \
        assert_true(drv_now(&fx) - t0_ <= (uint64_t)(budget_us) + drv_transfer_slack_us(&fx));     \
    } while (0)

/* Sensor 0 from reset to ranging at 0x30. */
static void bring_up_sensor0(void) {
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_shutdown(&dev), HAL_OK);
    drv_sleep(&fx, 500u);
    assert_int_equal(vl53_power_up(&dev), HAL_OK);
    EXPECT_WITHIN(HAL_OK, VL53_BOOT_TIME_MAX_US + VL53_BOOT_SLACK_US, vl53_wait_boot(&dev));
    uint16_t id = 0u;
    assert_int_equal(vl53_identify(&dev, &id), HAL_OK);
    assert_int_equal(id, 0xEACCu);
    assert_int_equal(vl53_set_address(&dev, 0x30u), HAL_OK);
    assert_int_equal(vl53_configure(&dev), HAL_OK);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
}

/* Poll (1 ms loop) until a result or an error other than NOT_READY; bounded. */
static int poll_next(struct vl53_result *r) {
    for (int i = 0; i < 1000; ++i) {
        int err = vl53_poll(&dev, r);
        if (err != HAL_ERR_NOT_READY) {
            return err;
        }
        drv_sleep(&fx, 1000u);
    }
    return HAL_ERR_NOT_READY;
}

static void test_config_checks(void **state) {
    (void)state;
    struct vl53_config c = fx.sensor_cfg[0];
    assert_null(vl53_config_check(&c));
    c.address = 0x07u;
    assert_string_equal(vl53_config_check(&c), "address");
    c.address = 0x78u;
    assert_string_equal(vl53_config_check(&c), "address");
    c = fx.sensor_cfg[0];
    c.timing.mode = VL53_DISTANCE_LONG; /* 15 ms exists in short mode only */
    assert_string_equal(vl53_config_check(&c), "timing");
    c = fx.sensor_cfg[0];
    c.timing.inter_measurement_ms = 18u; /* < 15 + 4 */
    assert_string_equal(vl53_config_check(&c), "timing");
    c.timing.inter_measurement_ms = 19u;
    assert_null(vl53_config_check(&c));
    c.timing.budget_ms = 25u;
    assert_string_equal(vl53_config_check(&c), "timing");
    c = fx.sensor_cfg[0];
    c.gpio.ops = NULL;
    assert_string_equal(vl53_config_check(&c), "gpio");
    c.xshut_pin = VL53_PIN_NONE;
    c.gpio1_pin = VL53_PIN_NONE;
    assert_null(vl53_config_check(&c));
    c = fx.sensor_cfg[0];
    c.polarity = (enum vl53_polarity)7;
    assert_string_equal(vl53_config_check(&c), "polarity");
    c = fx.sensor_cfg[0];
    c.i2c.ops = NULL;
    assert_string_equal(vl53_config_check(&c), "i2c");
    assert_string_equal(vl53_config_check(NULL), "config");
    assert_int_equal(vl53_attach(&dev, &c), HAL_ERR_INVALID);
    assert_int_equal(fx.rig.bus.stats.transactions, 0u);
}

/* The distance modes' facts and names, as replays and traces use them: the largest valid
 * distance, the shortest budget, and the spelling both ways (anything else refused). */
static void test_distance_mode_facts(void **state) {
    (void)state;
    assert_int_equal(vl53_range_max_mm(VL53_DISTANCE_SHORT), 1360);
    assert_int_equal(vl53_range_max_mm(VL53_DISTANCE_LONG), 4000);
    assert_int_equal(vl53_shortest_budget_ms(VL53_DISTANCE_SHORT), 15);
    assert_int_equal(vl53_shortest_budget_ms(VL53_DISTANCE_LONG), 20);
    assert_int_equal(vl53_shortest_budget_ms((enum vl53_distance_mode)7), 0);
    enum vl53_distance_mode m = VL53_DISTANCE_SHORT;
    assert_true(vl53_distance_mode_from_name("long", &m));
    assert_int_equal(m, VL53_DISTANCE_LONG);
    assert_string_equal(vl53_distance_mode_name(m), "long");
    assert_true(vl53_distance_mode_from_name("short", &m));
    assert_int_equal(m, VL53_DISTANCE_SHORT);
    assert_string_equal(vl53_distance_mode_name(m), "short");
    assert_false(vl53_distance_mode_from_name("LONG", &m));
    assert_false(vl53_distance_mode_from_name("", &m));
    assert_int_equal(m, VL53_DISTANCE_SHORT); /* untouched when refused */
}

static void test_timing_table(void **state) {
    (void)state;
    static const uint16_t budgets[] = {15u, 20u, 33u, 50u, 100u, 200u, 500u};
    for (size_t i = 0; i < sizeof budgets / sizeof budgets[0]; ++i) {
        struct vl53_timing t = {VL53_DISTANCE_SHORT, budgets[i], budgets[i] + 4u};
        assert_int_equal(vl53_timing_check(&t), HAL_OK);
        t.mode = VL53_DISTANCE_LONG;
        assert_int_equal(vl53_timing_check(&t), budgets[i] == 15u ? HAL_ERR_INVALID : HAL_OK);
        t.inter_measurement_ms = budgets[i] + 3u;
        assert_int_equal(vl53_timing_check(&t), HAL_ERR_INVALID);
    }
    struct vl53_timing too_long = {VL53_DISTANCE_LONG, 500u, VL53_IMP_MAX_MS + 1u};
    assert_int_equal(vl53_timing_check(&too_long), HAL_ERR_INVALID);
    struct vl53_timing t = {VL53_DISTANCE_SHORT, 15u, 20u};
    assert_int_equal(vl53_period_us(&t), 20000u);
}

static void test_happy_path(void **state) {
    (void)state;
    bring_up_sensor0();
    struct sim_vl53 *model = &fx.rig.sensor[0];
    assert_int_equal(model->address, 0x30u);
    assert_true(model->ranging);
    uint64_t previous_time = 0u;
    for (uint32_t n = 0; n < 20u; ++n) {
        struct vl53_result r;
        EXPECT_WITHIN(HAL_OK, 1000000u, poll_next(&r));
        assert_int_equal(r.distance_mm, drv_expected_distance(0, n));
        /* The first after the start is not wrap-checked ([SSD]): marked, status 6. */
        assert_int_equal(r.range_status, n == 0u ? VL53_RANGE_NO_WRAP_CHECK : VL53_RANGE_VALID);
        assert_int_equal(r.flags, n == 0u ? VL53_RESULT_FIRST : 0u);
        assert_int_equal(r.raw_status, 9u);
        assert_int_equal(r.stream_count, (uint8_t)(n + 1u)); /* the VHV range had 0 */
        assert_int_equal(r.missed, 0u);
        assert_int_equal(r.spad_count, 32u);
        assert_int_equal(r.ambient_kcps, 64u * 8u);
        assert_int_equal(r.signal_kcps,
                         (128000000u / ((uint32_t)r.distance_mm * r.distance_mm)) * 8u);
        if (n > 0u) {
            /* 50 Hz: one result every 20 ms (read within the 1 ms poll loop). */
            assert_in_range(drv_now(&fx) - previous_time, 19000u, 21000u);
        }
        previous_time = drv_now(&fx);
    }
    assert_int_equal(model->stats.overruns, 0u);
    assert_int_equal(model->stats.protocol_errors, 0u);
    assert_int_equal(vl53_stop_ranging(&dev), HAL_OK);
    assert_false(model->ranging);
    struct vl53_result r;
    assert_int_equal(vl53_poll(&dev, &r), HAL_ERR_STATE);
}

struct expected_xfer {
    uint8_t addr;
    uint8_t tx_len;
    uint8_t tx[10];
    uint8_t rx_len;
    uint8_t rx[17];
};

static void check_script(const struct sim_i2c_record *log, size_t logged,
                         const struct expected_xfer *want, size_t count) {
    assert_int_equal(logged, count);
    for (size_t i = 0; i < count; ++i) {
        print_message("transaction %zu\n", i);
        assert_int_equal(log[i].result, HAL_OK);
        assert_int_equal(log[i].addr7, want[i].addr);
        assert_int_equal(log[i].tx_len, want[i].tx_len);
        /* (longer transfers: their first sizeof tx bytes) */
        assert_memory_equal(log[i].tx, want[i].tx,
                            want[i].tx_len < sizeof want[i].tx ? want[i].tx_len
                                                               : sizeof want[i].tx);
        assert_int_equal(log[i].rx_len, want[i].rx_len);
        if (want[i].rx_len > 0u && want[i].rx_len <= sizeof want[i].rx) {
            assert_memory_equal(log[i].rx, want[i].rx, want[i].rx_len);
        }
    }
}

static void test_scripted_bytes_of_init_and_read(void **state) {
    (void)state;
    fx.sensor_cfg[0].gpio1_pin = VL53_PIN_NONE; /* data ready by register: visible on the bus */
    rebuild();
    static struct sim_i2c_record log[64];
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_shutdown(&dev), HAL_OK);
    drv_sleep(&fx, 500u);
    assert_int_equal(vl53_power_up(&dev), HAL_OK);
    drv_sleep(&fx, 1100u);
    sim_i2c_record(&fx.rig.bus, log, 64u);
    assert_int_equal(vl53_wait_boot(&dev), HAL_OK);
    assert_int_equal(vl53_identify(&dev, NULL), HAL_OK);
    assert_int_equal(vl53_set_address(&dev, 0x30u), HAL_OK);
    assert_int_equal(vl53_configure_begin(&dev), HAL_OK);
    /* ST's block in one transfer: index 0x002D, then 0x2D.., pads at AVDD (0x2E, 0x2F). */
    static const struct expected_xfer begin[] = {
        {0x29, 2, {0x00, 0xE5}, 1, {0x01}},       /* booted */
        {0x29, 2, {0x01, 0x0F}, 2, {0xEA, 0xCC}}, /* model ID */
        {0x29, 3, {0x00, 0x01, 0x30}, 0, {0}},    /* new address */
        {0x30, 2, {0x01, 0x0F}, 2, {0xEA, 0xCC}}, /* confirmed there */
        {0x30, 3, {0x00, 0x87, 0x00}, 0, {0}},    /* stop */
        {0x30, 93, {0x00, 0x2D, 0x00, 0x01, 0x01, 0x01, 0x02, 0x00, 0x02, 0x08}, 0, {0}},
        /* the offset registers 0x1E..0x23 to the recorded state (all 0), read back */
        {0x30, 8, {0x00, 0x1E, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, 0, {0}},
        {0x30, 2, {0x00, 0x1E}, 6, {0x00, 0x00, 0x00, 0x00, 0x00, 0x00}},
        {0x30, 3, {0x00, 0x86, 0x01}, 0, {0}}, /* clear: no stale result ends the VHV wait */
        {0x30, 3, {0x00, 0x87, 0x40}, 0, {0}}, /* the VHV range */
    };
    check_script(log, fx.rig.bus.record_count, begin, sizeof begin / sizeof begin[0]);
    /* The block as recorded (its first SIM_I2C_RECORD_BYTES - 2 bytes): ST's table with
     * the pad bits set (the whole image is checked in test_vl53_array). */
    uint8_t want_block[SIM_I2C_RECORD_BYTES - 2u];
    memcpy(want_block, uld_default_configuration, sizeof want_block);
    want_block[0x2E - 0x2D] |= 0x01u;
    want_block[0x2F - 0x2D] |= 0x01u;
    assert_memory_equal(&log[5].tx[2], want_block, sizeof want_block);
    drv_sleep(&fx, 110000u); /* the block's ~103 ms first range is over */
    sim_i2c_record(&fx.rig.bus, log, 64u);
    assert_int_equal(vl53_configure_finish(&dev), HAL_OK);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
    /* 20 ms x 500 (model clock_pll) x 1.075 = 10750 = 0x29FE. */
    static const struct expected_xfer init[] = {
        {0x30, 2, {0x00, 0x31}, 1, {0x01}},                                  /* VHV range done */
        {0x30, 3, {0x00, 0x86, 0x01}, 0, {0}},                               /* clear */
        {0x30, 3, {0x00, 0x87, 0x00}, 0, {0}},                               /* stop */
        {0x30, 3, {0x00, 0x08, 0x09}, 0, {0}},                               /* two-bounds VHV */
        {0x30, 3, {0x00, 0x0B, 0x00}, 0, {0}},                               /* VHV init */
        {0x30, 3, {0x00, 0x30, 0x01}, 0, {0}},                               /* active-high */
        {0x30, 3, {0x00, 0x4B, 0x14}, 0, {0}},                               /* short: phasecal */
        {0x30, 8, {0x00, 0x5E, 0x00, 0x1D, 0x07, 0x00, 0x27, 0x05}, 0, {0}}, /* 15 ms, VCSEL */
        {0x30, 3, {0x00, 0x69, 0x38}, 0, {0}},                               /* valid phase high */
        {0x30, 6, {0x00, 0x78, 0x07, 0x05, 0x06, 0x06}, 0, {0}}, /* WOI, initial phase */
        {0x30, 2, {0x00, 0xDE}, 2, {0x01, 0xF4}},                /* clock_pll */
        {0x30, 2, {0x00, 0xDE}, 2, {0x01, 0xF4}},                /* ... twice */
        {0x30, 6, {0x00, 0x6C, 0x00, 0x00, 0x29, 0xFE}, 0, {0}}, /* 20 ms period */
        {0x30, 2, {0x00, 0x4B}, 1, {0x14}},                      /* read back */
        {0x30, 2, {0x00, 0x5E}, 30, {0}},                        /* (checked below) */
        {0x30, 2, {0x00, 0x30}, 1, {0x01}},
        {0x30, 3, {0x00, 0x86, 0x01}, 0, {0}}, /* clear */
        {0x30, 3, {0x00, 0x87, 0x40}, 0, {0}}, /* start */
    };
    check_script(log, fx.rig.bus.record_count, init, sizeof init / sizeof init[0]);
    /* 0x5E..0x7B: ours, and ST's block between them (sigma 0x0168, min rate 0x0080, ...). */
    static const uint8_t readback[30] = {
        0x00, 0x1D, 0x07, 0x00, 0x27, 0x05, 0x01, 0x68, 0x00, 0x80, 0x08, 0x38, 0x00, 0x00, 0x00,
        0x00, 0x29, 0xFE, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x07, 0x05, 0x06, 0x06};
    assert_memory_equal(log[14].rx, readback, 30u);

    /* One read: data-ready register, the 17-byte block, the interrupt clear. Nothing on the
     * bus before the measurement is due. */
    sim_i2c_record(&fx.rig.bus, log, 64u);
    struct vl53_result r;
    assert_int_equal(vl53_poll(&dev, &r), HAL_ERR_NOT_READY);
    assert_int_equal(fx.rig.bus.record_count, 0u);
    drv_sleep(&fx, 15000u);
    assert_int_equal(vl53_poll(&dev, &r), HAL_OK);
    /* 100 mm, status raw 9, stream 1 (the VHV range had 0), 32 SPADs, signal
     * 128e6/100^2 = 12800 = 0x3200. */
    static const struct expected_xfer one_read[] = {
        {0x30, 2, {0x00, 0x31}, 1, {0x01}},
        {0x30,
         2,
         {0x00, 0x89},
         17,
         {0x09, 0x00, 0x01, 0x20, 0x00, 0x32, 0x00, 0x00, 0x40, 0x00, 0x20, 0x00, 0x00, 0x00, 0x64,
          0x32, 0x00}},
        {0x30, 3, {0x00, 0x86, 0x01}, 0, {0}},
    };
    check_script(log, fx.rig.bus.record_count, one_read, 3u);
    assert_int_equal(r.distance_mm, 100u);
    assert_int_equal(fx.rig.sensor[0].stats.protocol_errors, 0u);
}

static void test_vendor_block_override_and_vhv_step(void **state) {
    (void)state;
    /* An integrator's table instead of ST's: here ST's with another sigma threshold. */
    static uint8_t block[VL53_DEFAULT_CONFIG_LEN];
    memcpy(block, uld_default_configuration, sizeof block);
    block[0x65 - 0x2D] = 0x70u;
    fx.sensor_cfg[0].vendor_default_config = block;
    fx.sensor_cfg[0].pads_at_avdd = false;
    rebuild();
    bring_up_sensor0();
    struct sim_vl53 *model = &fx.rig.sensor[0];
    assert_int_equal(model->stats.starts, 2u); /* the VHV first range, then ours */
    assert_int_equal(model->vhv_stage, 3u);
    assert_int_equal(sim_vl53_peek(model, 0x0008u), 0x09u);
    assert_int_equal(sim_vl53_peek(model, 0x000Bu), 0x00u);
    assert_int_equal(sim_vl53_peek(model, 0x0065u), 0x70u);
    assert_int_equal(sim_vl53_peek(model, 0x002Eu), 0x00u); /* pads at 1V8 */
    /* Our configuration overrides the block's: short mode. */
    assert_int_equal(sim_vl53_peek(model, 0x004Bu), 0x14u);
    struct vl53_result r;
    assert_int_equal(poll_next(&r), HAL_OK);
    assert_int_equal(model->stats.protocol_errors, 0u);
}

static void test_missing_sensor_and_boot_timeout(void **state) {
    (void)state;
    /* XSHUT 1 goes nowhere (sensor 1 absent): nothing answers at 0x29. */
    struct vl53_dev other;
    assert_int_equal(vl53_attach(&other, &fx.sensor_cfg[1]), HAL_OK);
    assert_int_equal(vl53_shutdown(&other), HAL_OK);
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_shutdown(&dev), HAL_OK);
    assert_int_equal(vl53_power_up(&other), HAL_OK);
    EXPECT_WITHIN(HAL_ERR_ADDR_NACK, VL53_BOOT_TIME_MAX_US + VL53_BOOT_SLACK_US,
                  vl53_wait_boot(&other));
    /* A part that answers but never finishes booting. */
    fx.rig_cfg.sensor[0].boot_us = 5000u;
    rebuild();
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_shutdown(&dev), HAL_OK);
    assert_int_equal(vl53_power_up(&dev), HAL_OK);
    EXPECT_WITHIN(HAL_ERR_TIMEOUT, VL53_BOOT_TIME_MAX_US + VL53_BOOT_SLACK_US,
                  vl53_wait_boot(&dev));
    /* Called long after power-up: one poll, not a fresh 1.5 ms. */
    drv_sleep(&fx, 10000u);
    EXPECT_WITHIN(HAL_OK, VL53_BOOT_POLL_US, vl53_wait_boot(&dev));
}

static void test_wrong_model_id(void **state) {
    (void)state;
    fx.rig_cfg.sensor[0].model_id = 0xEAAAu;
    rebuild();
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[0]), HAL_OK);
    drv_sleep(&fx, 1500u);
    uint16_t id = 0u;
    assert_int_equal(vl53_identify(&dev, &id), HAL_ERR_ID_MISMATCH);
    assert_int_equal(id, 0xEAAAu);
}

static void test_set_timing(void **state) {
    (void)state;
    bring_up_sensor0();
    struct vl53_timing bad = {VL53_DISTANCE_LONG, 15u, 40u};
    uint32_t before = fx.rig.bus.stats.transactions;
    assert_int_equal(vl53_set_timing(&dev, &bad), HAL_ERR_INVALID);
    assert_int_equal(vl53_set_inter_measurement(&dev, 18u), HAL_ERR_INVALID);
    assert_int_equal(fx.rig.bus.stats.transactions, before); /* rejected before any I/O */
    assert_int_equal(vl53_set_inter_measurement(&dev, 30u), HAL_ERR_STATE); /* ranging */
    assert_int_equal(vl53_stop_ranging(&dev), HAL_OK);
    assert_int_equal(vl53_set_distance_mode(&dev, VL53_DISTANCE_LONG), HAL_ERR_INVALID); /* 15 ms */
    assert_int_equal(vl53_set_inter_measurement(&dev, 40u), HAL_OK);
    assert_int_equal(vl53_set_timing_budget(&dev, 33u), HAL_OK);
    assert_int_equal(vl53_set_distance_mode(&dev, VL53_DISTANCE_LONG), HAL_OK);
    assert_int_equal(sim_vl53_peek(&fx.rig.sensor[0], 0x004Bu), 0x0Au);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
    struct vl53_result r;
    uint64_t start = drv_now(&fx);
    assert_int_equal(poll_next(&r), HAL_OK);
    assert_in_range(drv_now(&fx) - start, 33000u, 34100u); /* first after the 33 ms budget */
    start = drv_now(&fx);
    assert_int_equal(poll_next(&r), HAL_OK);
    assert_in_range(drv_now(&fx) - start, 39000u, 41000u); /* then every 40 ms */
    assert_int_equal(fx.rig.sensor[0].stats.protocol_errors, 0u);
}

static void test_active_low_polarity(void **state) {
    (void)state;
    fx.sensor_cfg[0].polarity = VL53_INT_ACTIVE_LOW;
    rebuild();
    bring_up_sensor0();
    struct sim_vl53 *model = &fx.rig.sensor[0];
    assert_true(sim_vl53_gpio1_level(model)); /* idle high */
    drv_sleep(&fx, 15000u);
    assert_false(sim_vl53_gpio1_level(model)); /* data ready pulls it low */
    bool ready = false;
    assert_int_equal(vl53_gpio1_ready(&dev, &ready), HAL_OK);
    assert_true(ready);
    assert_int_equal(vl53_data_ready(&dev, &ready), HAL_OK);
    assert_true(ready);
    struct vl53_result r;
    assert_int_equal(vl53_poll(&dev, &r), HAL_OK);
    assert_int_equal(vl53_data_ready(&dev, &ready), HAL_OK);
    assert_false(ready);
}

static void test_late_reader_sees_missed_count(void **state) {
    (void)state;
    bring_up_sensor0();
    struct vl53_result r;
    assert_int_equal(poll_next(&r), HAL_OK);
    drv_sleep(&fx, 50000u); /* 2.5 periods without reading */
    assert_int_equal(vl53_poll(&dev, &r), HAL_OK);
    assert_int_equal(r.missed, 1u);
    assert_int_equal(r.stream_count, 3u); /* 0 was the VHV range's */
    assert_int_equal(r.distance_mm, drv_expected_distance(0, 2));
    assert_int_equal(fx.rig.sensor[0].stats.overruns, 1u);
}

static void test_overdue_data_is_a_timeout(void **state) {
    (void)state;
    fx.source.limit = 3u; /* then the sensor produces nothing */
    rebuild();
    bring_up_sensor0();
    struct vl53_result r;
    for (int n = 0; n < 3; ++n) {
        assert_int_equal(poll_next(&r), HAL_OK);
    }
    uint64_t last = drv_now(&fx);
    assert_int_equal(poll_next(&r), HAL_ERR_TIMEOUT);
    /* 1.5 periods plus the slack after the last result, within the 1 ms poll loop. */
    assert_in_range(drv_now(&fx) - last, 30000u + VL53_DATA_SLACK_US,
                    30000u + VL53_DATA_SLACK_US + 1100u);
}

/* --- each fault kind, injected deliberately ---------------------------------------------- */

static void set_fault(enum sim_fault_kind kind, uint32_t ppm) {
    struct sim_fault_config faults = {{0}, 11u, 0u};
    faults.ppm[kind] = ppm;
    sim_i2c_set_faults(&fx.rig.bus, &faults);
}

static void test_fault_nack_burst(void **state) {
    (void)state;
    fx.sensor_cfg[0].gpio1_pin = VL53_PIN_NONE;
    rebuild();
    bring_up_sensor0();
    drv_sleep(&fx, 15000u);
    fx.rig.bus.nack_remaining[0] = 2u;
    fx.rig.bus.nack_is_data[0] = true;
    struct vl53_result r;
    assert_int_equal(vl53_poll(&dev, &r), HAL_ERR_DATA_NACK);
    drv_sleep(&fx, 1000u);
    assert_int_equal(vl53_poll(&dev, &r), HAL_ERR_DATA_NACK);
    drv_sleep(&fx, 1000u);
    assert_int_equal(vl53_poll(&dev, &r), HAL_OK); /* burst over, data still there */
    assert_int_equal(r.distance_mm, drv_expected_distance(0, 0));
    fx.rig.bus.nack_remaining[0] = 1u;
    fx.rig.bus.nack_is_data[0] = false;
    assert_int_equal(vl53_identify(&dev, NULL), HAL_ERR_ADDR_NACK);
}

static void test_fault_clock_stretch(void **state) {
    (void)state;
    fx.sensor_cfg[0].i2c_timeout_us = 3000u;
    fx.sensor_cfg[0].call_budget_us = 5000u;
    rebuild();
    bring_up_sensor0();
    set_fault(SIM_FAULT_STRETCH, SIM_PPM_ONE);
    /* One transfer: its timeout. */
    EXPECT_WITHIN(HAL_ERR_TIMEOUT, 3000u, vl53_identify(&dev, NULL));
    /* Configure: stops at the first timeout, well within its budget. */
    EXPECT_WITHIN(HAL_ERR_TIMEOUT, 3000u, vl53_configure(&dev));
    set_fault(SIM_FAULT_STRETCH, 0u);
    assert_int_equal(vl53_configure(&dev), HAL_OK);
}

static void test_call_budget_caps_transfer_timeouts(void **state) {
    (void)state;
    /* A budget smaller than two transfer timeouts: the second transfer gets what is left. */
    fx.sensor_cfg[0].i2c_timeout_us = 3000u;
    fx.sensor_cfg[0].call_budget_us = 4000u;
    fx.sensor_cfg[0].gpio1_pin = VL53_PIN_NONE;
    fx.sensor_cfg[0].verify_distance = true;
    rebuild();
    bring_up_sensor0();
    drv_sleep(&fx, 15000u);
    /* Ready read OK, block read stretched (3 ms), nothing else fits: TIMEOUT within 4 ms. */
    struct vl53_result r;
    set_fault(SIM_FAULT_STRETCH, 0u);
    fx.rig.bus.faults.ppm[SIM_FAULT_STRETCH] = SIM_PPM_ONE;
    EXPECT_WITHIN(HAL_ERR_TIMEOUT, 4000u, vl53_poll(&dev, &r));
}

static void test_fault_spontaneous_reset(void **state) {
    (void)state;
    bring_up_sensor0();
    struct vl53_result r;
    assert_int_equal(poll_next(&r), HAL_OK);
    struct sim_vl53 *model = &fx.rig.sensor[0];
    assert_true(sim_vl53_inject(model, SIM_FAULT_RESET));
    assert_int_equal(model->address, 0x29u);
    assert_false(model->ranging);
    /* With GPIO1: no more data ready, so the poll ends in an overdue-data timeout... */
    assert_int_equal(poll_next(&r), HAL_ERR_TIMEOUT);
    /* ...and anything addressed to 0x30 is NACKed. */
    assert_int_equal(vl53_identify(&dev, NULL), HAL_ERR_ADDR_NACK);
}

static void test_fault_data_ready_stuck_high(void **state) {
    (void)state;
    bring_up_sensor0();
    struct vl53_result r;
    assert_int_equal(poll_next(&r), HAL_OK);
    assert_true(sim_vl53_inject(&fx.rig.sensor[0], SIM_FAULT_DRDY_HIGH));
    /* "Ready" with the block unchanged: stale, reported as corrupt, not as new data. */
    drv_sleep(&fx, 2000u);
    assert_int_equal(vl53_poll(&dev, &r), HAL_ERR_CORRUPT);
    assert_int_equal(vl53_poll(&dev, &r), HAL_ERR_CORRUPT);
    /* Genuinely new data still gets through. */
    drv_sleep(&fx, 20000u);
    assert_int_equal(vl53_poll(&dev, &r), HAL_OK);
    assert_int_equal(r.stream_count, 2u);
}

static void test_fault_data_ready_stuck_low(void **state) {
    (void)state;
    fx.sensor_cfg[0].gpio1_pin = VL53_PIN_NONE; /* same outcome through the register */
    rebuild();
    bring_up_sensor0();
    struct vl53_result r;
    assert_int_equal(poll_next(&r), HAL_OK);
    assert_true(sim_vl53_inject(&fx.rig.sensor[0], SIM_FAULT_DRDY_LOW));
    sim_i2c_reset_stats(&fx.rig.bus); /* the bring-up's VHV wait polled too */
    assert_int_equal(poll_next(&r), HAL_ERR_TIMEOUT);
    /* Register polling stayed throttled while waiting: about one read per ms, not a flood. */
    assert_true(fx.rig.bus.stats.transactions < 100u);
}

static void test_fault_garbage_reads(void **state) {
    (void)state;
    fx.sensor_cfg[0].verify_distance = true;
    rebuild();
    bring_up_sensor0();
    set_fault(SIM_FAULT_GARBAGE, SIM_PPM_ONE);
    uint16_t id = 0u;
    int err = vl53_identify(&dev, &id);
    assert_true(err == HAL_ERR_ID_MISMATCH || (err == HAL_OK && id == 0xEACCu));
    assert_int_equal(vl53_configure(&dev), HAL_ERR_CORRUPT); /* read-back caught it */
    set_fault(SIM_FAULT_GARBAGE, 0u);
    assert_int_equal(vl53_configure(&dev), HAL_OK);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
    struct vl53_result r;
    assert_int_equal(poll_next(&r), HAL_OK);
    /* Every garbled result read is refused. */
    set_fault(SIM_FAULT_GARBAGE, SIM_PPM_ONE);
    for (int n = 0; n < 30; ++n) {
        drv_sleep(&fx, 20000u);
        /* (a garbled raw status of 1, 2, 3 or 17 reads as the sensor's hardware fault) */
        const int poll_err = vl53_poll(&dev, &r);
        assert_true(poll_err == HAL_ERR_CORRUPT || poll_err == HAL_ERR_DEVICE);
    }
}

static void test_fault_bit_flips(void **state) {
    (void)state;
    fx.sensor_cfg[0].verify_distance = true;
    rebuild();
    bring_up_sensor0();
    set_fault(SIM_FAULT_BITFLIP, 300000u);
    /* 30 % of result reads (the distance re-read included) have one flipped bit. OK results must
     * carry the true distance and a status that is not falsely "valid"; flips in the rates/SPADs
     * are not detectable. */
    struct vl53_result r;
    uint32_t ok = 0u;
    uint32_t corrupt = 0u;
    for (int n = 0; n < 200; ++n) {
        int err = poll_next(&r);
        /* Several refused blocks in a row make the data overdue: a timeout, also surfaced. */
        assert_true(err == HAL_OK || err == HAL_ERR_CORRUPT || err == HAL_ERR_TIMEOUT);
        if (err == HAL_OK) {
            const struct sim_vl53_published *p = &fx.rig.sensor[0].published[0];
            assert_int_equal(r.distance_mm, p->distance_mm);
            /* A flipped status bit may turn "valid" into another code, never the reverse. */
            assert_true(r.range_status != VL53_RANGE_VALID || p->range_status == 0u);
            ok++;
        } else {
            corrupt++;
            drv_sleep(&fx, 1000u);
        }
    }
    /* About 30 % of re-reads and ~20 % of flipped blocks are refused; the rest pass. */
    assert_in_range(corrupt, 40u, 90u);
    assert_in_range(ok, 110u, 160u);
}

static void test_fault_stuck_sda(void **state) {
    (void)state;
    bring_up_sensor0();
    sim_i2c_set_sda_stuck(&fx.rig.bus, true);
    EXPECT_WITHIN(HAL_ERR_BUS_STUCK, VL53_DEFAULT_CALL_BUDGET_US, vl53_identify(&dev, NULL));
    drv_sleep(&fx, 15000u);
    struct vl53_result r;
    /* GPIO1 says ready; the block read fails on the stuck bus, passed up unchanged. */
    EXPECT_WITHIN(HAL_ERR_BUS_STUCK, VL53_DEFAULT_CALL_BUDGET_US, vl53_poll(&dev, &r));
    assert_int_equal(fx.rig.i2c.ops->recover(fx.rig.i2c.ctx), HAL_OK);
    assert_int_equal(vl53_poll(&dev, &r), HAL_OK);
}

static void test_many_sensors_no_globals(void **state) {
    (void)state;
    /* Two driver instances with different configs on one bus, independent state. */
    fx.rig_cfg.absent[1] = false;
    rebuild();
    struct vl53_dev a;
    struct vl53_dev b;
    fx.sensor_cfg[1].timing.budget_ms = 33u;
    fx.sensor_cfg[1].timing.inter_measurement_ms = 50u;
    assert_int_equal(vl53_attach(&a, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_attach(&b, &fx.sensor_cfg[1]), HAL_OK);
    assert_int_equal(vl53_shutdown(&a), HAL_OK);
    assert_int_equal(vl53_shutdown(&b), HAL_OK);
    struct vl53_dev *both[2] = {&a, &b};
    for (int i = 0; i < 2; ++i) {
        assert_int_equal(vl53_power_up(both[i]), HAL_OK);
        assert_int_equal(vl53_wait_boot(both[i]), HAL_OK);
        assert_int_equal(vl53_set_address(both[i], (uint8_t)(0x30 + i)), HAL_OK);
        assert_int_equal(vl53_configure(both[i]), HAL_OK);
        assert_int_equal(vl53_start_ranging(both[i]), HAL_OK);
    }
    uint32_t got[2] = {0u, 0u};
    for (int ms = 0; ms < 500; ++ms) {
        struct vl53_result r;
        for (int i = 0; i < 2; ++i) {
            int err = vl53_poll(both[i], &r);
            assert_true(err == HAL_OK || err == HAL_ERR_NOT_READY);
            got[i] += err == HAL_OK ? 1u : 0u;
        }
        drv_sleep(&fx, 1000u);
    }
    /* 20 ms period, plus the result pending since b's ~100 ms VHV step. */
    assert_in_range(got[0], 25u, 27u);
    assert_in_range(got[1], 9u, 10u); /* 50 ms period */
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_config_checks, setup),
        cmocka_unit_test_setup(test_timing_table, setup),
        cmocka_unit_test(test_distance_mode_facts),
        cmocka_unit_test_setup(test_happy_path, setup),
        cmocka_unit_test_setup(test_scripted_bytes_of_init_and_read, setup),
        cmocka_unit_test_setup(test_vendor_block_override_and_vhv_step, setup),
        cmocka_unit_test_setup(test_missing_sensor_and_boot_timeout, setup),
        cmocka_unit_test_setup(test_wrong_model_id, setup),
        cmocka_unit_test_setup(test_set_timing, setup),
        cmocka_unit_test_setup(test_active_low_polarity, setup),
        cmocka_unit_test_setup(test_late_reader_sees_missed_count, setup),
        cmocka_unit_test_setup(test_overdue_data_is_a_timeout, setup),
        cmocka_unit_test_setup(test_fault_nack_burst, setup),
        cmocka_unit_test_setup(test_fault_clock_stretch, setup),
        cmocka_unit_test_setup(test_call_budget_caps_transfer_timeouts, setup),
        cmocka_unit_test_setup(test_fault_spontaneous_reset, setup),
        cmocka_unit_test_setup(test_fault_data_ready_stuck_high, setup),
        cmocka_unit_test_setup(test_fault_data_ready_stuck_low, setup),
        cmocka_unit_test_setup(test_fault_garbage_reads, setup),
        cmocka_unit_test_setup(test_fault_bit_flips, setup),
        cmocka_unit_test_setup(test_fault_stuck_sda, setup),
        cmocka_unit_test_setup(test_many_sensors_no_globals, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
