/*
 * ST's bring-up as the bus sees it, and the part's statuses as the driver reports them:
 * the four-sensor bring-up read back from the I²C transaction log (every register
 * 0x2D..0x87 written before the first start, the VHV step, continuous ranging started with
 * the register image the ULD leaves for the same mode and budget: uld_reference.h), its
 * duration, the CSV form of the log, every range-status path and plausibility flag, a
 * part that kept power across an MCU reset, and ST's temperature update (VHV) on one sensor
 * while the others range, against the ULD's sequence (uld_temperature_update_check).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "drv_fixture.h"
#include "hal/hal_err.h"
#include "sim/sim_i2c_csv.h"
#include "uld_reference.h"
#include "vl53/vl53.h"

static struct drv_fixture fx;

/* --- a log sink keeping every transaction whole ------------------------------------------ */

#define CAP_MAX 4096u
struct cap {
    uint64_t t_us;
    uint8_t addr;
    int result;
    uint16_t tx_len;
    uint8_t tx[2u + VL53_DEFAULT_CONFIG_LEN + 4u];
};
static struct cap caps[CAP_MAX];
static size_t cap_count;
static char first_lines[3][SIM_I2C_CSV_LINE_MAX];

static void capture(void *ctx, const struct sim_i2c_transaction *t) {
    (void)ctx;
    if (cap_count < 3u) {
        assert_true(sim_i2c_csv_line(t, first_lines[cap_count], sizeof first_lines[0]) > 0u);
    }
    if (cap_count >= CAP_MAX) {
        return;
    }
    struct cap *c = &caps[cap_count++];
    c->t_us = t->start_us;
    c->addr = t->addr7;
    c->result = t->result;
    c->tx_len = (uint16_t)(t->tx_len < sizeof c->tx ? t->tx_len : sizeof c->tx);
    memcpy(c->tx, t->tx, c->tx_len);
}

static const struct sim_i2c_log_ops capture_ops = {.transaction = capture};

static int setup(void **state) {
    (void)state;
    drv_fixture_defaults(&fx);
    drv_fixture_build(&fx);
    cap_count = 0u;
    const struct sim_i2c_log sink = {&capture_ops, NULL};
    sim_i2c_set_log(&fx.rig.bus, &sink);
    return 0;
}

/* A successful register write to `addr`: its index (and data from tx[2]). */
static bool is_write(const struct cap *c, uint8_t addr, uint16_t *reg) {
    if (c->addr != addr || c->result != HAL_OK || c->tx_len < 3u) {
        return false;
    }
    *reg = (uint16_t)((c->tx[0] << 8) | c->tx[1]);
    return true;
}

/* Index in caps of the n-th (0-based) write of `value` to `reg` at `addr`, or CAP_MAX. */
static size_t find_write(uint8_t addr, uint16_t want_reg, uint8_t value, unsigned n) {
    for (size_t k = 0; k < cap_count; ++k) {
        uint16_t reg = 0u;
        if (is_write(&caps[k], addr, &reg) && reg == want_reg && caps[k].tx_len == 3u &&
            caps[k].tx[2] == value && n-- == 0u) {
            return k;
        }
    }
    return CAP_MAX;
}

static void test_bring_up_from_the_i2c_log(void **state) {
    (void)state;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    drv_sleep(&fx, 2000u); /* all four booted at 0x29 (XSHUT pulled up) */
    const uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    const uint64_t t_end = drv_now(&fx);
    assert_int_equal(vl53_array_ranging_count(&fx.array), DRV_SENSORS);
    assert_true(cap_count < CAP_MAX);
    /* The CSV form of the first transactions (docs/reference/tools.md): the probe of 0x29 with
     * every XSHUT low is NACKed; time, address, write bytes, no read, the error's name. */
    char want[64];
    snprintf(want, sizeof want, "%llu,0x29,010f,,ADDR_NACK\n", (unsigned long long)caps[0].t_us);
    assert_string_equal(first_lines[0], want);

    uint8_t reference[ULD_BLOCK_LEN];
    assert_true(uld_reference_image(false, 15u, 20u, 500u, true, true, reference));
    uint64_t last_start_us = 0u;
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        const uint8_t addr = (uint8_t)(DRV_FIRST_ADDRESS + s);
        /* The first start at the new address is the VHV range; the second is continuous
         * ranging. */
        const size_t vhv_start = find_write(addr, 0x0087u, 0x40u, 0u);
        const size_t start = find_write(addr, 0x0087u, 0x40u, 1u);
        assert_true(vhv_start < CAP_MAX && start < CAP_MAX);
        /* Every register 0x2D..0x87 written before the first start, and the image from the
         * writes up to the second start. */
        bool written[ULD_BLOCK_LEN] = {false};
        uint8_t image[ULD_BLOCK_LEN] = {0};
        for (size_t k = 0; k <= start; ++k) {
            uint16_t reg = 0u;
            if (!is_write(&caps[k], addr, &reg)) {
                continue;
            }
            for (size_t b = 2u; b < caps[k].tx_len; ++b, ++reg) {
                if (reg >= ULD_BLOCK_FIRST && reg < ULD_BLOCK_FIRST + ULD_BLOCK_LEN) {
                    image[reg - ULD_BLOCK_FIRST] = caps[k].tx[b];
                    if (k < vhv_start) {
                        written[reg - ULD_BLOCK_FIRST] = true;
                    }
                }
            }
        }
        for (size_t r = 0; r < ULD_BLOCK_LEN; ++r) {
            if (!written[r]) {
                print_message("sensor %u: register 0x%02zx not written before the start\n", s,
                              r + ULD_BLOCK_FIRST);
            }
            assert_true(written[r]);
        }
        /* The VHV step exactly as the ULD: after the VHV range's start, clear, stop,
         * 0x0008 = 0x09, 0x000B = 0x00, in that order, before continuous ranging. */
        /* The interrupt cleared before the VHV range's start (a stale result must not end
         * its wait), then the VHV step's own clear after it. */
        const size_t pre_clear = find_write(addr, 0x0086u, 0x01u, 0u);
        assert_true(pre_clear < vhv_start);
        const size_t clear = find_write(addr, 0x0086u, 0x01u, 1u);
        size_t stop = CAP_MAX;
        for (unsigned n = 0; n < 4u && stop == CAP_MAX; ++n) {
            const size_t k = find_write(addr, 0x0087u, 0x00u, n);
            stop = (k != CAP_MAX && k > clear) ? k : CAP_MAX;
        }
        const size_t bound = find_write(addr, 0x0008u, 0x09u, 0u);
        const size_t init = find_write(addr, 0x000Bu, 0x00u, 0u);
        assert_true(vhv_start < clear && clear < stop && stop < bound && bound < init &&
                    init < start);
        /* The VHV range ran at the block's timing: ~103 ms between its start and the clear. */
        assert_in_range(caps[clear].t_us - caps[vhv_start].t_us, 103000u, 125000u);
        /* The register image at the start equals the ULD's for short mode, 15 ms, 20 ms
         * (0x31, a status register, is not compared; 0x86 / 0x87 are the clear and start). */
        for (size_t r = 0; r < ULD_BLOCK_LEN; ++r) {
            if (r + ULD_BLOCK_FIRST == 0x31u) {
                continue;
            }
            if (image[r] != reference[r]) {
                print_message("sensor %u: 0x%02zx = 0x%02x, the ULD's 0x%02x\n", s,
                              r + ULD_BLOCK_FIRST, image[r], reference[r]);
            }
            assert_int_equal(image[r], reference[r]);
        }
        /* The model holds the same image (0x2D..0x85; its own register file). */
        for (uint16_t reg = 0x2Du; reg <= 0x85u; ++reg) {
            if (reg != 0x31u) {
                assert_int_equal(sim_vl53_peek(&fx.rig.sensor[s], reg),
                                 reference[reg - ULD_BLOCK_FIRST]);
            }
        }
        last_start_us = caps[start].t_us > last_start_us ? caps[start].t_us : last_start_us;
        assert_int_equal(fx.rig.sensor[s].stats.protocol_errors, 0u);
        assert_int_equal(fx.rig.sensor[s].stats.refused_starts, 0u);
    }
    /* Goal: from the first XSHUT release to all four ranging within 150 ms (the four VHV
     * ranges overlap). The release follows the 0.5 ms XSHUT-low wait and one probe. */
    const uint64_t release_us = t0 + VL53_ARRAY_XSHUT_LOW_US;
    print_message("bring-up: XSHUT release to all four ranging %.1f ms (call %.1f ms)\n",
                  (double)(last_start_us - release_us) / 1000.0, (double)(t_end - t0) / 1000.0);
    assert_true(last_start_us - release_us <= 150000u);
}

static void test_csv_line_format(void **state) {
    (void)state;
    const uint8_t tx[3] = {0x00, 0x89, 0xAB};
    const uint8_t rx[2] = {0x0F, 0xE0};
    struct sim_i2c_transaction t = {123456789012u, 0u, 0x30u, HAL_OK, 0u, tx, 2u, rx, 2u};
    char line[SIM_I2C_CSV_LINE_MAX];
    assert_int_equal(sim_i2c_csv_line(&t, line, sizeof line),
                     strlen("123456789012,0x30,0089,0fe0,ok\n"));
    assert_string_equal(line, "123456789012,0x30,0089,0fe0,ok\n");
    t.tx_len = 3u;
    t.rx_len = 0u;
    t.result = HAL_ERR_DATA_NACK;
    (void)sim_i2c_csv_line(&t, line, sizeof line);
    assert_string_equal(line, "123456789012,0x30,0089ab,,DATA_NACK\n");
    t.result = HAL_ERR_TIMEOUT; /* a failed read shows no read bytes */
    t.rx_len = 2u;
    (void)sim_i2c_csv_line(&t, line, sizeof line);
    assert_string_equal(line, "123456789012,0x30,0089ab,,TIMEOUT\n");
    /* Too small a buffer: nothing, not a truncated line. */
    assert_int_equal(sim_i2c_csv_line(&t, line, 10u), 0u);
    assert_string_equal(line, "");
    assert_string_equal(SIM_I2C_CSV_HEADER, "t_us,addr,write,read,result");
}

/* --- statuses and plausibility on one sensor --------------------------------------------- */

static struct vl53_dev dev;

static void one_sensor_up(void) {
    for (unsigned i = 1; i < DRV_SENSORS; ++i) {
        fx.rig_cfg.absent[i] = true;
    }
    drv_fixture_build(&fx);
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_shutdown(&dev), HAL_OK);
    drv_sleep(&fx, 500u);
    assert_int_equal(vl53_power_up(&dev), HAL_OK);
    assert_int_equal(vl53_wait_boot(&dev), HAL_OK);
    assert_false(vl53_warm_boot(&dev));
    assert_int_equal(vl53_set_address(&dev, 0x30u), HAL_OK);
    assert_int_equal(vl53_configure(&dev), HAL_OK);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
}

static int next_result(struct vl53_result *r) {
    for (int i = 0; i < 200; ++i) {
        int err = vl53_poll(&dev, r);
        if (err != HAL_ERR_NOT_READY) {
            return err;
        }
        drv_sleep(&fx, 1000u);
    }
    return HAL_ERR_NOT_READY;
}

static void test_every_range_status_path(void **state) {
    (void)state;
    one_sensor_up();
    struct sim_vl53 *m = &fx.rig.sensor[0];
    struct vl53_result r;
    assert_int_equal(next_result(&r), HAL_OK);
    assert_int_equal(r.flags, VL53_RESULT_FIRST); /* first after the start */
    assert_int_equal(r.range_status, VL53_RANGE_NO_WRAP_CHECK);
    /* Raw codes the part reports, and what the driver makes of them ([ULD] status_rtn,
     * [SSD] for the hardware faults): {raw, HAL result, ULD status}. */
    static const struct {
        uint8_t raw;
        int rc;
        uint8_t status;
    } paths[] = {
        {9, HAL_OK, VL53_RANGE_VALID},
        {6, HAL_OK, VL53_RANGE_SIGMA_FAIL},
        {4, HAL_OK, VL53_RANGE_SIGNAL_FAIL},
        {8, HAL_OK, VL53_RANGE_MIN_RANGE},
        {5, HAL_OK, VL53_RANGE_OUT_OF_BOUNDS},
        {7, HAL_OK, VL53_RANGE_WRAP_AROUND},
        {19, HAL_OK, VL53_RANGE_NO_WRAP_CHECK},
        {12, HAL_OK, 9u},
        {13, HAL_OK, 13u},
        {18, HAL_OK, 10u},
        {22, HAL_OK, 11u},
        {23, HAL_OK, 12u},
        {1, HAL_ERR_DEVICE, 5u},
        {2, HAL_ERR_DEVICE, 5u},
        {3, HAL_ERR_DEVICE, 5u},
        {17, HAL_ERR_DEVICE, 5u},
        {0, HAL_ERR_CORRUPT, VL53_RANGE_UNKNOWN},
        {10, HAL_ERR_CORRUPT, VL53_RANGE_UNKNOWN},
        {16, HAL_ERR_CORRUPT, VL53_RANGE_UNKNOWN},
        {31, HAL_ERR_CORRUPT, VL53_RANGE_UNKNOWN},
    };
    for (size_t k = 0; k < sizeof paths / sizeof paths[0]; ++k) {
        print_message("raw %u\n", paths[k].raw);
        sim_vl53_force_results(m, paths[k].raw, 500u, 1u);
        assert_int_equal(next_result(&r), paths[k].rc);
        assert_int_equal(r.raw_status, paths[k].raw);
        assert_int_equal(r.range_status, paths[k].status);
        assert_int_equal((r.flags & VL53_RESULT_HW_FAULT) != 0u, paths[k].rc == HAL_ERR_DEVICE);
        assert_int_equal(r.distance_mm, 500u);
        if (paths[k].rc == HAL_ERR_CORRUPT) {
            /* refused counts are adopted by the next good one: read one clean result */
            assert_int_equal(next_result(&r), HAL_OK);
        }
    }
    assert_int_equal(m->stats.protocol_errors, 0u);
}

static void test_plausibility_flags(void **state) {
    (void)state;
    one_sensor_up();
    struct sim_vl53 *m = &fx.rig.sensor[0];
    struct vl53_result r;
    assert_int_equal(next_result(&r), HAL_OK);
    /* Short mode: valid up to 1360 mm ([DS]); 0, 8190, 8191, 65535 never valid. */
    static const struct {
        uint8_t raw;
        uint16_t mm;
        bool flagged;
        uint8_t status;
    } cases[] = {
        {9, 1360u, false, VL53_RANGE_VALID},
        {9, 1361u, true, VL53_RANGE_IMPLAUSIBLE},
        {9, 0u, true, VL53_RANGE_IMPLAUSIBLE},
        {9, 8190u, true, VL53_RANGE_IMPLAUSIBLE},
        {9, 8191u, true, VL53_RANGE_IMPLAUSIBLE},
        {9, 65535u, true, VL53_RANGE_IMPLAUSIBLE},
        {9, 1u, false, VL53_RANGE_VALID},
        /* flagged whatever the status; a status already not valid is kept */
        {4, 8191u, true, VL53_RANGE_SIGNAL_FAIL},
        {7, 0u, true, VL53_RANGE_WRAP_AROUND},
        {4, 800u, false, VL53_RANGE_SIGNAL_FAIL},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        sim_vl53_force_results(m, cases[k].raw, cases[k].mm, 1u);
        assert_int_equal(next_result(&r), HAL_OK);
        assert_int_equal(r.distance_mm, cases[k].mm);
        assert_int_equal((r.flags & VL53_RESULT_IMPLAUSIBLE) != 0u, cases[k].flagged);
        assert_int_equal(r.range_status, cases[k].status);
    }
    /* The first result after a restart is marked and flagged too when implausible. */
    assert_int_equal(vl53_stop_ranging(&dev), HAL_OK);
    assert_int_equal(vl53_clear_interrupt(&dev), HAL_OK);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
    sim_vl53_force_results(m, 9u, 8190u, 1u);
    assert_int_equal(next_result(&r), HAL_OK);
    assert_int_equal(r.flags, VL53_RESULT_FIRST | VL53_RESULT_IMPLAUSIBLE);
    assert_int_equal(r.range_status, VL53_RANGE_IMPLAUSIBLE);
}

static void test_long_mode_range_limit(void **state) {
    (void)state;
    fx.sensor_cfg[0].timing.mode = VL53_DISTANCE_LONG;
    fx.sensor_cfg[0].timing.budget_ms = 33u;
    fx.sensor_cfg[0].timing.inter_measurement_ms = 40u;
    one_sensor_up();
    struct sim_vl53 *m = &fx.rig.sensor[0];
    struct vl53_result r;
    assert_int_equal(next_result(&r), HAL_OK);
    sim_vl53_force_results(m, 9u, 4000u, 1u);
    assert_int_equal(next_result(&r), HAL_OK);
    assert_int_equal(r.range_status, VL53_RANGE_VALID);
    sim_vl53_force_results(m, 9u, 4001u, 1u);
    assert_int_equal(next_result(&r), HAL_OK);
    assert_int_equal(r.range_status, VL53_RANGE_IMPLAUSIBLE);
}

static void test_stream_count_continues_after_a_stop(void **state) {
    (void)state;
    one_sensor_up();
    struct vl53_result r;
    for (int n = 0; n < 5; ++n) {
        assert_int_equal(next_result(&r), HAL_OK);
    }
    const uint8_t before = r.stream_count;
    assert_int_equal(vl53_stop_ranging(&dev), HAL_OK);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
    assert_int_equal(next_result(&r), HAL_OK);
    /* The part's count goes on (the model's behaviour, docs/explanation/driver-and-bus.md); the
     * driver takes the first result after the start whatever its count, and marks it. */
    assert_int_equal(r.stream_count, (uint8_t)(before + 1u));
    assert_int_equal(r.flags, VL53_RESULT_FIRST);
    assert_int_equal(next_result(&r), HAL_OK);
    assert_int_equal(r.flags, 0u);
    assert_int_equal(r.range_status, VL53_RANGE_VALID);
}

static void test_part_that_kept_power_across_an_mcu_reset(void **state) {
    (void)state;
    /* XSHUT tied high: the part keeps power and address when the MCU resets. */
    for (unsigned i = 1; i < DRV_SENSORS; ++i) {
        fx.rig_cfg.absent[i] = true;
    }
    fx.rig_cfg.sensor[0].xshut_wired = false;
    fx.sensor_cfg[0].xshut_pin = VL53_PIN_NONE;
    fx.sensor_cfg[0].address = 0x29u; /* one sensor: it keeps the default address */
    drv_fixture_build(&fx);
    drv_sleep(&fx, 2000u);
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_wait_boot(&dev), HAL_OK);
    assert_false(vl53_warm_boot(&dev)); /* 0x01: a cold boot */
    assert_int_equal(vl53_configure(&dev), HAL_OK);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
    struct vl53_result r;
    assert_int_equal(next_result(&r), HAL_OK);
    /* The MCU resets; the part goes on ranging. A fresh driver finds boot state 0x03. */
    struct vl53_dev fresh;
    assert_int_equal(vl53_attach(&fresh, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_wait_boot(&fresh), HAL_OK);
    assert_true(vl53_warm_boot(&fresh));
    assert_int_equal(fresh.boot_state, 0x03u);
    /* Stopped, it reads 0x02: booted all the same. */
    assert_int_equal(vl53_stop_ranging(&fresh), HAL_OK);
    assert_int_equal(vl53_attach(&fresh, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_wait_boot(&fresh), HAL_OK);
    assert_int_equal(fresh.boot_state, 0x02u);
    /* Configured again from scratch (it stops first), it ranges. */
    assert_int_equal(vl53_configure(&fresh), HAL_OK);
    assert_int_equal(vl53_start_ranging(&fresh), HAL_OK);
    dev = fresh;
    assert_int_equal(next_result(&r), HAL_OK);
    assert_int_equal(r.flags, VL53_RESULT_FIRST);
    assert_int_equal(next_result(&r), HAL_OK);
    assert_int_equal(r.range_status, VL53_RANGE_VALID);
}

/* A part that kept power across an MCU reset may have a result pending (the old firmware
 * never cleared it). The VHV step must wait for its own range (about 100 ms of ST's block
 * timing), not take the stale data ready for it and stop the VHV range at once. */
static void test_vhv_step_ignores_a_stale_interrupt(void **state) {
    (void)state;
    for (unsigned i = 1; i < DRV_SENSORS; ++i) {
        fx.rig_cfg.absent[i] = true;
    }
    fx.rig_cfg.sensor[0].xshut_wired = false;
    fx.sensor_cfg[0].xshut_pin = VL53_PIN_NONE;
    fx.sensor_cfg[0].address = 0x29u;
    drv_fixture_build(&fx);
    drv_sleep(&fx, 2000u);
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_wait_boot(&dev), HAL_OK);
    assert_int_equal(vl53_configure(&dev), HAL_OK);
    assert_int_equal(vl53_start_ranging(&dev), HAL_OK);
    drv_sleep(&fx, 100000u); /* ranging; nobody clears: the interrupt is pending */
    struct sim_vl53 *m = &fx.rig.sensor[0];
    assert_true(m->irq_pending);
    struct vl53_dev fresh;
    assert_int_equal(vl53_attach(&fresh, &fx.sensor_cfg[0]), HAL_OK);
    assert_int_equal(vl53_wait_boot(&fresh), HAL_OK);
    assert_true(vl53_warm_boot(&fresh));
    const uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_configure_begin(&fresh), HAL_OK);
    assert_int_equal(vl53_configure_finish(&fresh), HAL_OK);
    const uint64_t took = drv_now(&fx) - t0;
    print_message("configure after a warm reset with a pending interrupt: %llu us\n",
                  (unsigned long long)took);
    assert_true(took >= 100000u); /* the VHV range ran to its end */
}

static void test_non_blocking_recovery(void **state) {
    (void)state;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    const uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_array_recover_sensor_begin(&fx.array, 2u), HAL_OK);
    assert_true(drv_now(&fx) - t0 < 10000u); /* XSHUT cycle to the VHV range's start */
    assert_int_equal(fx.array.report[2].state, VL53_SENSOR_CONFIGURING);
    assert_int_equal(vl53_array_ranging_count(&fx.array), 3u);
    /* Each step is one quick look while the range runs; the others keep ranging. */
    unsigned steps = 0u;
    int rc = HAL_ERR_NOT_READY;
    uint32_t got[DRV_SENSORS] = {0};
    while (rc == HAL_ERR_NOT_READY && steps < 500u) {
        const uint64_t s0 = drv_now(&fx);
        rc = vl53_array_recover_sensor_step(&fx.array, 2u);
        if (rc == HAL_ERR_NOT_READY) {
            assert_true(drv_now(&fx) - s0 < 1000u);
        }
        for (size_t i = 0; i < DRV_SENSORS; ++i) {
            struct vl53_result r;
            if (i != 2u && vl53_array_poll(&fx.array, i, &r) == HAL_OK) {
                got[i]++;
            }
        }
        drv_sleep(&fx, 1000u);
        steps++;
    }
    assert_int_equal(rc, HAL_OK);
    assert_int_equal(fx.array.report[2].state, VL53_SENSOR_RANGING);
    assert_in_range(drv_now(&fx) - t0, 100000u, 130000u);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        if (i != 2u) {
            assert_true(got[i] >= 4u); /* ~5 periods of results meanwhile */
        }
    }
    assert_int_equal(vl53_array_recover_sensor_step(&fx.array, 2u), HAL_ERR_STATE);
}

/* The writes to `addr` in caps[from..]: single-byte register writes, in bus order. */
static size_t writes_to(uint8_t addr, size_t from, struct uld_write *out, size_t max) {
    size_t n = 0;
    for (size_t k = from; k < cap_count && n < max; ++k) {
        uint16_t reg = 0u;
        if (is_write(&caps[k], addr, &reg) && caps[k].tx_len == 3u) {
            out[n++] = (struct uld_write){reg, caps[k].tx[2]};
        }
    }
    return n;
}

/* The checker itself can fail: a missing 0x92, an order swapped, a stray write, a short run. */
static void test_uld_temperature_checker_rejects_departures(void **state) {
    (void)state;
    const struct uld_write good[] = {{0x0008, 0x81}, {0x000B, 0x92}, {0x0087, 0x40}, {0x0086, 0x01},
                                     {0x0087, 0x00}, {0x0008, 0x09}, {0x000B, 0x00}};
    assert_int_equal(uld_temperature_update_check(good, 7u), -1);
    const struct uld_write no_92[] = {{0x0008, 0x81}, {0x0087, 0x40}, {0x0086, 0x01},
                                      {0x0087, 0x00}, {0x0008, 0x09}, {0x000B, 0x00}};
    assert_int_equal(uld_temperature_update_check(no_92, 6u), 1);
    const struct uld_write swapped[] = {{0x0008, 0x81}, {0x000B, 0x92}, {0x0087, 0x40},
                                        {0x0087, 0x00}, {0x0086, 0x01}, {0x0008, 0x09},
                                        {0x000B, 0x00}};
    assert_int_equal(uld_temperature_update_check(swapped, 7u), 3);
    const struct uld_write late_clear[] = {
        {0x0086, 0x01}, {0x0008, 0x81}, {0x000B, 0x92}, {0x0087, 0x40}};
    assert_int_equal(uld_temperature_update_check(late_clear, 4u), 0);
    assert_int_equal(uld_temperature_update_check(good, 5u), 5);
}

/* ST's temperature update on one sensor of four while the other three keep ranging: the
 * writes are the ULD's (the independent checker), the VHV range runs a whole range, the
 * model counts one update and no protocol error, and the sensor ranges valid again. */
static void test_temperature_update_is_the_ulds(void **state) {
    (void)state;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    drv_sleep(&fx, 100000u);
    struct vl53_dev *d = vl53_array_sensor(&fx.array, 1u);
    const uint8_t addr = (uint8_t)(DRV_FIRST_ADDRESS + 1u);
    assert_int_equal(vl53_temperature_update_begin(d), HAL_ERR_STATE); /* still ranging */
    assert_int_equal(vl53_stop_ranging(d), HAL_OK);
    drv_sleep(&fx, 40000u); /* a result may be left pending: the update must not take it */
    const size_t mark = cap_count;
    const uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_temperature_update_begin(d), HAL_OK);
    int rc = HAL_ERR_NOT_READY;
    uint32_t got[DRV_SENSORS] = {0};
    for (unsigned step = 0; step < 500u && rc == HAL_ERR_NOT_READY; ++step) {
        rc = vl53_temperature_update_pending(d);
        for (size_t i = 0; i < DRV_SENSORS; ++i) {
            struct vl53_result r;
            if (i != 1u && vl53_array_poll(&fx.array, i, &r) == HAL_OK) {
                got[i]++;
            }
        }
        drv_sleep(&fx, 1000u);
    }
    assert_int_equal(rc, HAL_OK);
    assert_int_equal(vl53_temperature_update_finish(d), HAL_OK);
    const uint64_t took = drv_now(&fx) - t0;
    struct uld_write w[32];
    const size_t n = writes_to(addr, mark, w, 32u);
    const int departs = uld_temperature_update_check(w, n);
    if (departs >= 0) {
        print_message("write %d of %zu departs from the ULD's temperature update\n", departs, n);
    }
    assert_int_equal(departs, -1);
    /* The VHV range ran a whole range (budget 15 ms) before its clear. */
    size_t start = CAP_MAX, clear = CAP_MAX;
    for (size_t k = mark; k < cap_count && clear == CAP_MAX; ++k) {
        uint16_t reg = 0u;
        if (is_write(&caps[k], addr, &reg) && caps[k].tx_len == 3u) {
            if (reg == 0x0087u && caps[k].tx[2] == 0x40u) {
                start = k;
            } else if (reg == 0x0086u && start != CAP_MAX) {
                clear = k;
            }
        }
    }
    assert_true(start < CAP_MAX && clear < CAP_MAX);
    print_message("VHV range: %llu us from its start to the clear\n",
                  (unsigned long long)(caps[clear].t_us - caps[start].t_us));
    assert_true(caps[clear].t_us - caps[start].t_us >= 15000u);
    print_message("temperature update: %llu us from begin to finish\n", (unsigned long long)took);
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        if (i != 1u) {
            assert_true(got[i] >= 1u); /* the others kept ranging */
        }
    }
    const struct sim_vl53 *m = &fx.rig.sensor[1];
    assert_int_equal(m->stats.temperature_updates, 1u);
    assert_int_equal(m->stats.protocol_errors, 0u);
    /* Ranging again: valid readings, not the uncalibrated part's raw 3. */
    assert_int_equal(vl53_start_ranging(d), HAL_OK);
    unsigned valid = 0;
    for (unsigned step = 0; step < 100u; ++step) {
        drv_sleep(&fx, 1000u);
        struct vl53_result r;
        if (vl53_array_poll(&fx.array, 1u, &r) == HAL_OK && r.range_status == VL53_RANGE_VALID) {
            ++valid;
        }
    }
    assert_true(valid >= 3u);
    assert_int_equal(m->stats.no_vhv_results, 2u); /* its bring-up and update VHV ranges only */
}

/* A data ready that never comes: the update's pending look reports HAL_ERR_TIMEOUT within
 * its bound (the configure budget, 200 ms, here above twice budget + period). */
static void test_temperature_update_without_data_ready_times_out(void **state) {
    (void)state;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    struct vl53_dev *d = vl53_array_sensor(&fx.array, 0u);
    assert_int_equal(vl53_stop_ranging(d), HAL_OK);
    assert_true(sim_vl53_inject(&fx.rig.sensor[0], SIM_FAULT_DRDY_LOW));
    const uint64_t t0 = drv_now(&fx);
    assert_int_equal(vl53_temperature_update_begin(d), HAL_OK);
    int rc = HAL_ERR_NOT_READY;
    for (unsigned step = 0; step < 1000u && rc == HAL_ERR_NOT_READY; ++step) {
        rc = vl53_temperature_update_pending(d);
        drv_sleep(&fx, 1000u);
    }
    assert_int_equal(rc, HAL_ERR_TIMEOUT);
    assert_in_range(drv_now(&fx) - t0, VL53_DEFAULT_CONFIGURE_BUDGET_US,
                    VL53_DEFAULT_CONFIGURE_BUDGET_US + 5000u);
    assert_int_equal(vl53_temperature_update_finish(d), HAL_ERR_TIMEOUT);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_bring_up_from_the_i2c_log, setup),
        cmocka_unit_test_setup(test_csv_line_format, setup),
        cmocka_unit_test_setup(test_every_range_status_path, setup),
        cmocka_unit_test_setup(test_plausibility_flags, setup),
        cmocka_unit_test_setup(test_long_mode_range_limit, setup),
        cmocka_unit_test_setup(test_stream_count_continues_after_a_stop, setup),
        cmocka_unit_test_setup(test_part_that_kept_power_across_an_mcu_reset, setup),
        cmocka_unit_test_setup(test_vhv_step_ignores_a_stale_interrupt, setup),
        cmocka_unit_test_setup(test_non_blocking_recovery, setup),
        cmocka_unit_test_setup(test_uld_temperature_checker_rejects_departures, setup),
        cmocka_unit_test_setup(test_temperature_update_is_the_ulds, setup),
        cmocka_unit_test_setup(test_temperature_update_without_data_ready_times_out, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
