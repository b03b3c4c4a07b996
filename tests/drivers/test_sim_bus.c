/*
 * The simulated bus, clock, GPIO and VL53 model on their own (no driver): wire timing,
 * routing, wired-AND, boot and address behaviour, measurement timing and stream count,
 * range sources, fault injection and the --faults parser.
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
#include "sim/sim_fault.h"
#include "sim/sim_prng.h"
#include "uld_reference.h"
#include "vl53/vl53_regs.h"

static struct drv_fixture fx;

static int setup(void **state) {
    (void)state;
    drv_fixture_defaults(&fx);
    drv_fixture_build(&fx);
    return 0;
}

static int rd(uint8_t addr, uint16_t reg, uint8_t *data, size_t len) {
    return hal_i2c_reg16_read(&fx.rig.i2c, addr, reg, data, len, 1000u);
}

static int wr(uint8_t addr, uint16_t reg, const uint8_t *data, size_t len) {
    return hal_i2c_reg16_write(&fx.rig.i2c, addr, reg, data, len, 1000u);
}

static int wr1(uint8_t addr, uint16_t reg, uint8_t value) {
    return wr(addr, reg, &value, 1u);
}

/* Power only sensor `keep` (XSHUT of the others low) and wait for it to boot. */
static void only_sensor(unsigned keep) {
    for (unsigned i = 0; i < DRV_SENSORS; ++i) {
        fx.rig.hal_gpio.ops->write(fx.rig.hal_gpio.ctx, SIM_RIG_XSHUT_PIN(i), false);
    }
    drv_sleep(&fx, 100u);
    fx.rig.hal_gpio.ops->write(fx.rig.hal_gpio.ctx, SIM_RIG_XSHUT_PIN(keep), true);
    drv_sleep(&fx, 1500u);
}

/* ST's bring-up by hand ([ULD] SensorInit): the default configuration, the VHV range
 * (started, waited for, cleared, stopped), two-bounds VHV from the previous temperature. */
static void st_init(uint8_t addr) {
    assert_int_equal(wr(addr, ULD_BLOCK_FIRST, uld_default_configuration, ULD_BLOCK_LEN), 0);
    assert_int_equal(wr1(addr, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED), 0);
    uint8_t level = 0u;
    for (int i = 0; i < 200 && level == 0u; ++i) {
        drv_sleep(&fx, 1000u);
        assert_int_equal(rd(addr, VL53_REG_GPIO_TIO_HV_STATUS, &level, 1u), 0);
    }
    assert_int_equal(level, 1u);
    assert_int_equal(wr1(addr, VL53_REG_SYSTEM_INTERRUPT_CLEAR, 1u), 0);
    assert_int_equal(wr1(addr, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP), 0);
    assert_int_equal(wr1(addr, VL53_REG_VHV_CONFIG_TIMEOUT_MACROP_LOOP_BOUND, 0x09u), 0);
    assert_int_equal(wr1(addr, VL53_REG_VHV_CONFIG_INIT, 0x00u), 0);
}

/* The ULD's short-mode, 15 ms budget registers and a period of `period_ms`. */
static void program_short_15(uint8_t addr, uint32_t period_ms) {
    const uint8_t timing[6] = {0x00, 0x1D, VL53_VCSEL_PERIOD_A_SHORT,
                               0x00, 0x27, VL53_VCSEL_PERIOD_B_SHORT};
    const uint8_t sd[4] = {VL53_WOI_SD0_SHORT, VL53_WOI_SD1_SHORT, VL53_INITIAL_PHASE_SHORT,
                           VL53_INITIAL_PHASE_SHORT};
    assert_int_equal(wr1(addr, VL53_REG_PHASECAL_CONFIG_TIMEOUT_MACROP, VL53_PHASECAL_SHORT), 0);
    assert_int_equal(wr(addr, VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A, timing, 6u), 0);
    assert_int_equal(wr1(addr, VL53_REG_RANGE_CONFIG_VALID_PHASE_HIGH, VL53_VALID_PHASE_HIGH_SHORT),
                     0);
    assert_int_equal(wr(addr, VL53_REG_SD_CONFIG_WOI_SD0, sd, 4u), 0);
    /* Model clock_pll is 500: period_ms * 500 * 1.075. */
    uint8_t imp[4];
    hal_put_be32(imp, period_ms * 500u * 1075u / 1000u);
    assert_int_equal(wr(addr, VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD, imp, 4u), 0);
}

static void test_wire_time_model(void **state) {
    (void)state;
    /* 400 kHz = 2.5 µs per bit. A 1-byte register write: S + 4 x 9 bits + P = 38 bits. */
    assert_int_equal(sim_i2c_transfer_ns(400000u, 3u, 0u), 38u * 2500u);
    /* The 17-byte result read: S, addr, 2 index, Sr, addr, 17 data, P = 192 bits = 480 µs. */
    assert_int_equal(sim_i2c_transfer_ns(400000u, 2u, 17u), 192u * 2500u);
    assert_int_equal(sim_i2c_transfer_ns(100000u, 2u, 17u), 192u * 10000u);
    /* The clock moves by the wire time plus tBUF (1.3 µs in fast mode). */
    drv_sleep(&fx, 1500u); /* past boot */
    sim_i2c_reset_stats(&fx.rig.bus);
    uint64_t t0 = drv_now(&fx);
    uint8_t id[2];
    assert_int_equal(rd(0x29, VL53_REG_IDENTIFICATION_MODEL_ID, id, 2u), HAL_OK);
    uint64_t wire_ns = sim_i2c_transfer_ns(400000u, 2u, 2u);
    assert_int_equal(drv_now(&fx) - t0, (wire_ns + 1300u) / 1000u);
    assert_int_equal(fx.rig.bus.stats.busy_ns, wire_ns);
    /* An address NACK costs 11 bits. */
    sim_i2c_reset_stats(&fx.rig.bus);
    assert_int_equal(rd(0x55, VL53_REG_IDENTIFICATION_MODEL_ID, id, 2u), HAL_ERR_ADDR_NACK);
    assert_int_equal(fx.rig.bus.stats.busy_ns, 11u * 2500u);
    assert_int_equal(fx.rig.bus.stats.errors[SIM_I2C_ERR_ADDR_NACK], 1u);
}

static void test_wired_and_of_two_devices(void **state) {
    (void)state;
    /* At start every sensor is powered at 0x29 (XSHUT pulled up): reads are wired-AND. */
    fx.rig_cfg.sensor[0].osc_calibrate = 0x00F0u;
    fx.rig_cfg.sensor[1].osc_calibrate = 0x003Cu;
    fx.rig_cfg.absent[2] = true;
    fx.rig_cfg.absent[3] = true;
    drv_fixture_build(&fx);
    drv_sleep(&fx, 1500u);
    uint8_t osc[2];
    assert_int_equal(rd(0x29, VL53_REG_RESULT_OSC_CALIBRATE_VAL, osc, 2u), HAL_OK);
    assert_int_equal(hal_get_be16(osc), 0x00F0u & 0x003Cu);
    /* A write reaches both: both move to 0x40. */
    assert_int_equal(wr1(0x29, VL53_REG_I2C_SLAVE_DEVICE_ADDRESS, 0x40u), HAL_OK);
    assert_int_equal(fx.rig.sensor[0].address, 0x40u);
    assert_int_equal(fx.rig.sensor[1].address, 0x40u);
    assert_int_equal(rd(0x29, VL53_REG_RESULT_OSC_CALIBRATE_VAL, osc, 2u), HAL_ERR_ADDR_NACK);
}

static void test_boot_and_xshut(void **state) {
    (void)state;
    fx.rig_cfg.sensor[0].boot_us = 1100u;
    fx.rig_cfg.sensor[0].boot_silent_us = 400u;
    drv_fixture_build(&fx);
    for (unsigned i = 0; i < DRV_SENSORS; ++i) {
        fx.rig.hal_gpio.ops->write(fx.rig.hal_gpio.ctx, SIM_RIG_XSHUT_PIN(i), false);
    }
    uint8_t st = 0xAAu;
    assert_int_equal(rd(0x29, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_ERR_ADDR_NACK);
    uint64_t rise = drv_now(&fx);
    fx.rig.hal_gpio.ops->write(fx.rig.hal_gpio.ctx, SIM_RIG_XSHUT_PIN(0), true);
    drv_sleep(&fx, 350u);
    assert_int_equal(rd(0x29, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_ERR_ADDR_NACK);
    drv_sleep(&fx, 100u);
    assert_int_equal(rd(0x29, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_OK);
    assert_int_equal(st, 0u);
    /* A write before boot is ignored and counted. */
    assert_int_equal(wr1(0x29, VL53_REG_I2C_SLAVE_DEVICE_ADDRESS, 0x41u), HAL_OK);
    assert_int_equal(fx.rig.sensor[0].address, 0x29u);
    assert_int_equal(fx.rig.sensor[0].stats.protocol_errors, 1u);
    drv_sleep(&fx, (uint32_t)(rise + 1100u - drv_now(&fx)));
    assert_int_equal(rd(0x29, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_OK);
    assert_int_equal(st, VL53_FIRMWARE_BOOTED_BIT);
    /* Moved, then XSHUT cycled: back at 0x29, not booted. */
    assert_int_equal(wr1(0x29, VL53_REG_I2C_SLAVE_DEVICE_ADDRESS, 0x41u), HAL_OK);
    assert_int_equal(rd(0x41, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_OK);
    fx.rig.hal_gpio.ops->write(fx.rig.hal_gpio.ctx, SIM_RIG_XSHUT_PIN(0), false);
    assert_int_equal(rd(0x41, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_ERR_ADDR_NACK);
    fx.rig.hal_gpio.ops->write(fx.rig.hal_gpio.ctx, SIM_RIG_XSHUT_PIN(0), true);
    drv_sleep(&fx, 500u);
    assert_int_equal(rd(0x29, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_OK);
    assert_int_equal(st, 0u);
    assert_int_equal(fx.rig.sensor[0].stats.power_ups, 3u); /* start, first rise, second rise */
}

static void test_measurement_timing_and_stream_count(void **state) {
    (void)state;
    only_sensor(1);
    st_init(0x29);
    program_short_15(0x29, 20u);
    uint64_t start = drv_now(&fx);
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED), HAL_OK);
    struct sim_vl53 *dev = &fx.rig.sensor[1];
    /* Not ready just before the budget has elapsed, ready at it (GPIO1 active high). */
    drv_sleep(&fx, (uint32_t)(start + 15000u - 1u - drv_now(&fx)));
    assert_false(sim_vl53_gpio1_level(dev));
    drv_sleep(&fx, 1u);
    assert_true(sim_vl53_gpio1_level(dev));
    assert_int_equal(sim_vl53_peek(dev, VL53_REG_GPIO_TIO_HV_STATUS), 1u);
    uint8_t block[17];
    assert_int_equal(rd(0x29, VL53_REG_RESULT_RANGE_STATUS, block, 17u), HAL_OK);
    assert_int_equal(block[0], 9u); /* raw 9 = ULD status 0 */
    assert_int_equal(block[2], 1u); /* after the VHV range's 0: no restart at a start */
    assert_int_equal(hal_get_be16(&block[13]), drv_expected_distance(1, 0));
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_INTERRUPT_CLEAR, 1u), HAL_OK);
    assert_false(sim_vl53_gpio1_level(dev));
    /* The next one a period (20 ms) later. */
    drv_sleep(&fx, (uint32_t)(start + 35000u - 1u - drv_now(&fx)));
    assert_false(sim_vl53_gpio1_level(dev));
    drv_sleep(&fx, 1u);
    assert_true(sim_vl53_gpio1_level(dev));
    /* 300 more measurements without reading: stream count (the VHV range's 0, then) up to
     * 255, then wraps to 128. */
    drv_sleep(&fx, (uint32_t)(start + 15000u + 299u * 20000u - drv_now(&fx)));
    assert_int_equal(dev->stats.measurements, 301u);
    assert_int_equal(sim_vl53_peek(dev, VL53_REG_RESULT_RANGE_STATUS + 2u), 128u + (300u - 256u));
    assert_int_equal(dev->stats.overruns, 298u);
    assert_int_equal(dev->published[0].sample_index, 299u);
    assert_int_equal(dev->stats.protocol_errors, 0u);
    /* Stop: nothing more. */
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP), HAL_OK);
    drv_sleep(&fx, 100000u);
    assert_int_equal(dev->stats.measurements, 301u);
}

/* Start, wait two budgets, and say what the model did: 0 nothing ready, else the raw status. */
static uint8_t start_and_look(unsigned sensor) {
    struct sim_vl53 *dev = &fx.rig.sensor[sensor];
    dev->stats.published = 0u;
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED), HAL_OK);
    drv_sleep(&fx, 40000u);
    const uint8_t raw = dev->stats.published == 0u ? 0u : dev->published[0].raw_status;
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP), HAL_OK);
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_INTERRUPT_CLEAR, 1u), HAL_OK);
    return raw;
}

static void test_model_ranges_only_when_configured_as_st_does(void **state) {
    (void)state;
    only_sensor(0);
    struct sim_vl53 *dev = &fx.rig.sensor[0];
    /* Timing alone, no block: nothing, ever (no data ready). */
    program_short_15(0x29, 20u);
    assert_int_equal(start_and_look(0), 0u);
    assert_int_equal(dev->refusal, SIM_VL53_NO_BLOCK);
    /* The block but for one register: still nothing. */
    assert_int_equal(
        wr(0x29, ULD_BLOCK_FIRST + 1u, &uld_default_configuration[1], ULD_BLOCK_LEN - 1u),
        0); /* 0x2D never written */
    program_short_15(0x29, 20u);
    assert_int_equal(start_and_look(0), 0u);
    assert_int_equal(dev->refusal, SIM_VL53_NO_BLOCK);
    /* Whole block, firmware enable 0x85 cleared: nothing. */
    assert_int_equal(wr(0x29, ULD_BLOCK_FIRST, uld_default_configuration, ULD_BLOCK_LEN), 0);
    assert_int_equal(wr1(0x29, 0x0085u, 0x00u), 0);
    assert_int_equal(start_and_look(0), 0u);
    assert_int_equal(dev->refusal, SIM_VL53_NO_BLOCK);
    assert_int_equal(wr1(0x29, 0x0085u, 0x01u), 0);
    /* A timeout pair in no ULD table: nothing. */
    program_short_15(0x29, 20u);
    const uint8_t odd_a[2] = {0x00, 0x1E};
    assert_int_equal(wr(0x29, VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A, odd_a, 2u), 0);
    assert_int_equal(start_and_look(0), 0u);
    assert_int_equal(dev->refusal, SIM_VL53_BAD_TIMING);
    /* Long-mode VCSEL period with a short-mode phasecal: inconsistent, nothing. */
    program_short_15(0x29, 20u);
    assert_int_equal(wr1(0x29, VL53_REG_RANGE_CONFIG_VCSEL_PERIOD_A, VL53_VCSEL_PERIOD_A_LONG), 0);
    assert_int_equal(start_and_look(0), 0u);
    assert_int_equal(dev->refusal, SIM_VL53_BAD_TIMING);
    /* Block and valid timing but no VHV step: ranges, but "no VHV value found" (raw 3). */
    program_short_15(0x29, 20u);
    assert_int_equal(start_and_look(0), 3u);
    assert_int_equal(dev->refusal, SIM_VL53_RANGES);
    /* ... still after a range and a stop, until the VHV step's last two writes. */
    assert_int_equal(start_and_look(0), 3u);
    assert_int_equal(wr1(0x29, VL53_REG_VHV_CONFIG_TIMEOUT_MACROP_LOOP_BOUND, 0x09u), 0);
    assert_int_equal(start_and_look(0), 3u);
    assert_int_equal(wr1(0x29, VL53_REG_VHV_CONFIG_INIT, 0x00u), 0);
    assert_int_equal(start_and_look(0), 9u); /* calibrated: valid ranges */
    assert_true(dev->stats.no_vhv_results > 0u);
    assert_int_equal(dev->stats.refused_starts, 5u);
    /* A mode-start value the part does not take is a protocol error. */
    assert_int_equal(dev->stats.protocol_errors, 0u);
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, 0x21u), HAL_OK);
    assert_int_equal(dev->stats.protocol_errors, 1u);
}

static void test_block_timing_and_boot_states(void **state) {
    (void)state;
    only_sensor(3);
    struct sim_vl53 *dev = &fx.rig.sensor[3];
    uint8_t st = 0u;
    assert_int_equal(rd(0x29, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_OK);
    assert_int_equal(st, 0x01u); /* cold boot */
    /* The block's own timing: the first range completes 103 ms after the start. */
    assert_int_equal(wr(0x29, ULD_BLOCK_FIRST, uld_default_configuration, ULD_BLOCK_LEN), 0);
    const uint64_t start = drv_now(&fx);
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED), 0);
    drv_sleep(&fx, (uint32_t)(start + 103000u - 1u - drv_now(&fx)));
    assert_false(sim_vl53_gpio1_level(dev));
    drv_sleep(&fx, 1u);
    assert_true(sim_vl53_gpio1_level(dev));
    assert_int_equal(rd(0x29, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_OK);
    assert_int_equal(st, 0x03u); /* ran since boot, ranging */
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP), 0);
    assert_int_equal(rd(0x29, VL53_REG_FIRMWARE_SYSTEM_STATUS, &st, 1u), HAL_OK);
    assert_int_equal(st, 0x02u); /* what an MCU finds after its own warm reset */
    /* OSC_CALIBRATE_VAL is published (the model's default, 500). */
    uint8_t osc[2];
    assert_int_equal(rd(0x29, VL53_REG_RESULT_OSC_CALIBRATE_VAL, osc, 2u), HAL_OK);
    assert_int_equal(hal_get_be16(osc), 500u);
}

static void test_source_dropouts_and_end(void **state) {
    (void)state;
    fx.source.dropout_every = 3u; /* samples 2, 5, 8, ... absent */
    fx.source.limit = 7u;
    only_sensor(2);
    st_init(0x29);
    program_short_15(0x29, 20u);
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED), HAL_OK);
    drv_sleep(&fx, 15000u + 20000u * 10u);
    struct sim_vl53 *dev = &fx.rig.sensor[2];
    assert_true(dev->source_done);
    /* The VHV range, then 8 (the 8th found the source exhausted). */
    assert_int_equal(dev->stats.measurements, 9u);
    assert_int_equal(dev->stats.dropouts, 2u); /* indices 2 and 5 */
    assert_int_equal(dev->stats.published, 6u);
    assert_int_equal(dev->published[0].sample_index, 6u);
    assert_int_equal(dev->published[0].stream_count, 5u);
}

static void test_index_by_time(void **state) {
    (void)state;
    fx.rig_cfg.sensor[0].index_mode = SIM_VL53_INDEX_BY_TIME;
    fx.rig_cfg.sensor[0].index_period_us = 20000u;
    drv_fixture_build(&fx);
    only_sensor(0);
    st_init(0x29);
    drv_sleep(&fx, 200000u - (uint32_t)drv_now(&fx)); /* start ranging at t = 200 ms */
    program_short_15(0x29, 20u);
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED), HAL_OK);
    drv_sleep(&fx, 16000u);
    /* Completed near t = 215.x ms: trace row 10 (of 20 ms rows), not sample 0. */
    assert_int_equal(fx.rig.sensor[0].published[0].sample_index, 10u);
}

static void test_fault_parser(void **state) {
    (void)state;
    struct sim_fault_config cfg = {{0}, 7u, 0u};
    size_t at = 0u;
    const char *what = NULL;
    assert_int_equal(
        sim_fault_parse("nack=0.01,reset=0.0005,stuck=0.0005,garbage=0.002", &cfg, &at, &what), 0);
    assert_int_equal(cfg.ppm[SIM_FAULT_NACK], 10000u);
    assert_int_equal(cfg.ppm[SIM_FAULT_RESET], 500u);
    assert_int_equal(cfg.ppm[SIM_FAULT_STUCK], 500u);
    assert_int_equal(cfg.ppm[SIM_FAULT_GARBAGE], 2000u);
    assert_int_equal(cfg.ppm[SIM_FAULT_BITFLIP], 0u);
    assert_int_equal(cfg.seed, 7u);
    assert_int_equal(sim_fault_parse("drdy_high=1,bitflip=.5", &cfg, &at, &what), 0);
    assert_int_equal(cfg.ppm[SIM_FAULT_DRDY_HIGH], 1000000u);
    assert_int_equal(cfg.ppm[SIM_FAULT_BITFLIP], 500000u);
    assert_int_equal(cfg.ppm[SIM_FAULT_NACK], 0u);
    assert_int_equal(sim_fault_parse("nack=0.01,foo=0.1", &cfg, &at, &what), -1);
    assert_int_equal(at, 10u);
    assert_int_equal(sim_fault_parse("nack=1.5", &cfg, &at, &what), -1);
    assert_int_equal(sim_fault_parse("nack=0.0000001", &cfg, &at, &what), -1);
    assert_int_equal(at, 13u);
    assert_int_equal(sim_fault_parse("nack", &cfg, &at, &what), -1);
    assert_int_equal(at, 4u);
    assert_int_equal(sim_fault_parse("nack=0.1,", &cfg, &at, &what), -1);
    assert_int_equal(sim_fault_parse("nack=x", &cfg, &at, &what), -1);
    assert_int_equal(at, 5u);
    assert_int_equal(sim_fault_parse("nack=0.1;", &cfg, &at, &what), -1);
    assert_non_null(what);
    assert_int_equal(sim_fault_kind_from_name("stretch", 7u), SIM_FAULT_STRETCH);
    assert_int_equal(sim_fault_kind_from_name("stretchy", 8u), -1);
    assert_string_equal(sim_fault_name(SIM_FAULT_DRDY_LOW), "drdy_low");
}

static void test_prng_rate_and_determinism(void **state) {
    (void)state;
    struct sim_prng a;
    struct sim_prng b;
    sim_prng_seed(&a, 42u);
    sim_prng_seed(&b, 42u);
    uint32_t hits = 0u;
    for (uint32_t i = 0; i < 1000000u; ++i) {
        bool x = sim_prng_chance_ppm(&a, 10000u);
        assert_true(x == sim_prng_chance_ppm(&b, 10000u));
        hits += x ? 1u : 0u;
    }
    /* 1 % of 10^6 draws: 10000 +- 5 sigma (sigma ~ 99.5). */
    assert_in_range(hits, 9500u, 10500u);
    sim_prng_seed(&b, 43u);
    assert_true(sim_prng_next(&a) != sim_prng_next(&b));
}

/* Same seed, same faults, same outcome of every transaction. */
static void run_fault_script(uint32_t seed, struct sim_i2c_record *log, size_t cap) {
    drv_fixture_defaults(&fx);
    for (unsigned k = 0; k < (unsigned)SIM_FAULT_COUNT; ++k) {
        fx.rig_cfg.faults.ppm[k] = 30000u;
    }
    fx.rig_cfg.faults.seed = seed;
    drv_fixture_build(&fx);
    sim_i2c_record(&fx.rig.bus, log, cap);
    uint8_t buf[17];
    for (size_t i = 0; i < cap; ++i) {
        if (i % 50u == 49u) {
            fx.rig.i2c.ops->recover(fx.rig.i2c.ctx);
        }
        (void)rd(0x29, (uint16_t)(i % 2u == 0u ? VL53_REG_RESULT_RANGE_STATUS : 0x010Fu), buf,
                 i % 2u == 0u ? 17u : 2u);
    }
}

static void test_faults_are_seeded_and_recorded(void **state) {
    (void)state;
    static struct sim_i2c_record first[400];
    static struct sim_i2c_record second[400];
    run_fault_script(99u, first, 400u);
    uint32_t injected = 0u;
    for (unsigned k = 0; k < (unsigned)SIM_FAULT_COUNT; ++k) {
        injected += fx.rig.bus.stats.injected[k];
    }
    assert_true(injected > 10u);
    run_fault_script(99u, second, 400u);
    for (size_t i = 0; i < 400u; ++i) {
        assert_int_equal(first[i].result, second[i].result);
        assert_int_equal(first[i].fault_mask, second[i].fault_mask);
        assert_int_equal(first[i].start_us, second[i].start_us);
        assert_memory_equal(first[i].rx, second[i].rx, SIM_I2C_RECORD_BYTES);
    }
    /* Each error in the log carries the fault that caused it (or is a NACK burst/stuck tail). */
    uint32_t stuck_seen = 0u;
    for (size_t i = 0; i < 400u; ++i) {
        if ((first[i].fault_mask & (1u << SIM_FAULT_STRETCH)) != 0u) {
            assert_int_equal(first[i].result, HAL_ERR_TIMEOUT);
        }
        if (first[i].result == HAL_ERR_BUS_STUCK) {
            stuck_seen++;
        }
    }
    assert_true(stuck_seen > 0u);
}

static void test_stuck_bus_and_recovery(void **state) {
    (void)state;
    uint8_t id[2];
    sim_i2c_set_sda_stuck(&fx.rig.bus, true);
    uint64_t t0 = drv_now(&fx);
    assert_int_equal(rd(0x29, VL53_REG_IDENTIFICATION_MODEL_ID, id, 2u), HAL_ERR_BUS_STUCK);
    /* The master waited its timeout (1000 µs here) for SDA. */
    assert_in_range(drv_now(&fx) - t0, 1000u, 1003u);
    assert_int_equal(fx.rig.i2c.ops->recover(fx.rig.i2c.ctx), HAL_OK);
    assert_int_equal(rd(0x29, VL53_REG_IDENTIFICATION_MODEL_ID, id, 2u), HAL_OK);
    assert_int_equal(fx.rig.bus.stats.recoveries, 1u);
}

static void test_garbage_and_bitflip_targets(void **state) {
    (void)state;
    only_sensor(0);
    program_short_15(0x29, 20u);
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED), HAL_OK);
    drv_sleep(&fx, 16000u);
    uint8_t clean[17];
    uint8_t bad[17];
    assert_int_equal(rd(0x29, VL53_REG_RESULT_RANGE_STATUS, clean, 17u), HAL_OK);
    struct sim_fault_config faults = {{0}, 5u, 0u};
    faults.ppm[SIM_FAULT_BITFLIP] = SIM_PPM_ONE;
    sim_i2c_set_faults(&fx.rig.bus, &faults);
    for (int n = 0; n < 20; ++n) {
        assert_int_equal(rd(0x29, VL53_REG_RESULT_RANGE_STATUS, bad, 17u), HAL_OK);
        unsigned differing_bits = 0u;
        for (size_t i = 0; i < 17u; ++i) {
            differing_bits += (unsigned)__builtin_popcount((unsigned)(clean[i] ^ bad[i]));
        }
        assert_int_equal(differing_bits, 1u);
    }
    /* Not a result register: no flip, not counted. */
    uint8_t id[2];
    uint32_t flips = fx.rig.bus.stats.injected[SIM_FAULT_BITFLIP];
    assert_int_equal(rd(0x29, VL53_REG_IDENTIFICATION_MODEL_ID, id, 2u), HAL_OK);
    assert_int_equal(hal_get_be16(id), 0xEACCu);
    assert_int_equal(fx.rig.bus.stats.injected[SIM_FAULT_BITFLIP], flips);
    /* Garbage hits reads only; writes still land. */
    faults.ppm[SIM_FAULT_BITFLIP] = 0u;
    faults.ppm[SIM_FAULT_GARBAGE] = SIM_PPM_ONE;
    sim_i2c_set_faults(&fx.rig.bus, &faults);
    assert_int_equal(wr1(0x29, VL53_REG_SYSTEM_INTERRUPT_CLEAR, 1u), HAL_OK);
    assert_false(fx.rig.sensor[0].irq_pending);
    assert_int_equal(fx.rig.bus.stats.injected[SIM_FAULT_GARBAGE], 0u);
    assert_int_equal(rd(0x29, VL53_REG_IDENTIFICATION_MODEL_ID, id, 2u), HAL_OK);
    assert_int_equal(fx.rig.bus.stats.injected[SIM_FAULT_GARBAGE], 1u);
}

static void test_gpio_model(void **state) {
    (void)state;
    bool level = false;
    const struct hal_gpio *g = &fx.rig.hal_gpio;
    assert_int_equal(g->ops->write(g->ctx, 12u, true), HAL_OK);
    assert_int_equal(g->ops->read(g->ctx, 12u, &level), HAL_OK);
    assert_true(level);
    assert_int_equal(g->ops->write(g->ctx, SIM_GPIO_PINS, true), HAL_ERR_INVALID);
    assert_int_equal(g->ops->read(g->ctx, SIM_GPIO_PINS, &level), HAL_ERR_INVALID);
    /* GPIO1 of a sensor in reset reads high (pull-up). */
    assert_int_equal(g->ops->write(g->ctx, SIM_RIG_XSHUT_PIN(3), false), HAL_OK);
    assert_int_equal(g->ops->read(g->ctx, SIM_RIG_GPIO1_PIN(3), &level), HAL_OK);
    assert_true(level);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_wire_time_model, setup),
        cmocka_unit_test_setup(test_wired_and_of_two_devices, setup),
        cmocka_unit_test_setup(test_boot_and_xshut, setup),
        cmocka_unit_test_setup(test_measurement_timing_and_stream_count, setup),
        cmocka_unit_test_setup(test_model_ranges_only_when_configured_as_st_does, setup),
        cmocka_unit_test_setup(test_block_timing_and_boot_states, setup),
        cmocka_unit_test_setup(test_source_dropouts_and_end, setup),
        cmocka_unit_test_setup(test_index_by_time, setup),
        cmocka_unit_test_setup(test_fault_parser, setup),
        cmocka_unit_test_setup(test_prng_rate_and_determinism, setup),
        cmocka_unit_test_setup(test_faults_are_seeded_and_recorded, setup),
        cmocka_unit_test_setup(test_stuck_bus_and_recovery, setup),
        cmocka_unit_test_setup(test_garbage_and_bitflip_targets, setup),
        cmocka_unit_test_setup(test_gpio_model, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
