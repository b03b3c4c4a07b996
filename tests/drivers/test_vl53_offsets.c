/*
 * The parts' own offset registers: whatever each part's NVM loaded into 0x1E,
 * 0x20 and 0x22, every bring-up leaves the recorded state of the driver's config there, so
 * the readings are the same on every boot (XSHUT cycle, MCU reset with the part powered);
 * a part that does not take the write is reported with the register named; the
 * --i2c-log lines show the writes. And the model: NVM values at power-up, the reported
 * range shifted by 0x1E / 4 mm as ST's calibration implies.
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
#include "hal/hal_i2c_reg.h"
#include "sim/sim_i2c_csv.h"
#include "vl53/vl53.h"

static struct drv_fixture fx;

/* A plausible spread of factory offsets (ST: up to +-20 mm before calibration), one part at
 * each end of the 13-bit field. */
static const int16_t nvm_p2p[DRV_SENSORS] = {37, -52, 4095, -4096};
static const int16_t nvm_inner[DRV_SENSORS] = {3, -7, 0, 12};
static const int16_t nvm_outer[DRV_SENSORS] = {9, -13, -20, 1};

static int setup(void **state) {
    (void)state;
    drv_fixture_defaults(&fx);
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        fx.rig_cfg.sensor[s].nvm_part_to_part_qmm = nvm_p2p[s];
        fx.rig_cfg.sensor[s].nvm_inner_offset_mm = nvm_inner[s];
        fx.rig_cfg.sensor[s].nvm_outer_offset_mm = nvm_outer[s];
    }
    /* One sensor with a recorded state other than the product's all-zero one. */
    fx.sensor_cfg[2].offsets.part_to_part_qmm = -8; /* -2 mm */
    fx.sensor_cfg[2].offsets.inner_mm = 2;
    fx.sensor_cfg[2].offsets.outer_mm = -3;
    drv_fixture_build(&fx);
    return 0;
}

/* 0x1E..0x23 as the model holds them. */
static void peek_offsets(unsigned s, uint8_t out[6]) {
    for (uint16_t k = 0; k < 6u; ++k) {
        out[k] = sim_vl53_peek(&fx.rig.sensor[s], (uint16_t)(0x001Eu + k));
    }
}

static void expect_recorded_state(unsigned s) {
    const struct vl53_offsets *o = &fx.sensor_cfg[s].offsets;
    uint8_t want[6];
    hal_put_be16(&want[0], (uint16_t)((uint16_t)o->part_to_part_qmm & 0x1FFFu));
    hal_put_be16(&want[2], (uint16_t)o->inner_mm);
    hal_put_be16(&want[4], (uint16_t)o->outer_mm);
    uint8_t got[6];
    peek_offsets(s, got);
    print_message("sensor %u: 0x1E..0x23 = %02x%02x %02x%02x %02x%02x\n", s, got[0], got[1], got[2],
                  got[3], got[4], got[5]);
    assert_memory_equal(got, want, sizeof want);
}

/* The next valid result of sensor `s`, and the distance the source gave the model for it. */
static void next_reading(unsigned s, struct vl53_result *r, uint16_t *source_mm) {
    for (unsigned n = 0; n < 200u; ++n) {
        int err = vl53_array_poll(&fx.array, s, r);
        if (err == HAL_OK && r->range_status == VL53_RANGE_VALID) {
            const struct sim_vl53 *m = &fx.rig.sensor[s];
            for (size_t k = 0; k < 2u; ++k) {
                if (m->published[k].valid && m->published[k].stream_count == r->stream_count) {
                    *source_mm = drv_expected_distance(s, m->published[k].sample_index);
                    return;
                }
            }
        }
        assert_true(err == HAL_OK || err == HAL_ERR_NOT_READY);
        drv_sleep(&fx, 1000u);
    }
    fail_msg("sensor %u: no valid result", s);
}

/* Reading minus the source's distance, per sensor: the offset the part applied. */
static void reading_offsets(int32_t out[DRV_SENSORS]) {
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        struct vl53_result r;
        uint16_t source_mm = 0u;
        next_reading(s, &r, &source_mm);
        out[s] = (int32_t)r.distance_mm - (int32_t)source_mm;
    }
}

static void test_bring_up_pins_the_offsets_whatever_the_nvm(void **state) {
    (void)state;
    /* The parts booted with their NVM values in place (the model's power-up). */
    uint8_t before[6];
    peek_offsets(1, before);
    assert_int_equal(hal_get_be16(before), (uint16_t)(-52) & 0x1FFFu);
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    int32_t offsets[DRV_SENSORS];
    reading_offsets(offsets);
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        expect_recorded_state(s);
        assert_int_equal(vl53_offset_mismatch_register(&fx.array.dev[s]), 0u);
    }
    /* The product's state (all 0): the part's raw range; sensor 2's recorded -2 mm. */
    assert_int_equal(offsets[0], 0);
    assert_int_equal(offsets[1], 0);
    assert_int_equal(offsets[2], -2);
    assert_int_equal(offsets[3], 0);
}

static void test_second_bring_up_gives_the_same_state_and_readings(void **state) {
    (void)state;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    int32_t first[DRV_SENSORS];
    reading_offsets(first);
    /* Each part through an XSHUT cycle: it reboots and reloads its NVM offsets. */
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        const uint32_t power_ups = fx.rig.sensor[s].stats.power_ups;
        assert_int_equal(vl53_array_recover_sensor(&fx.array, s), HAL_OK);
        assert_int_equal(fx.rig.sensor[s].stats.power_ups, power_ups + 1u);
        expect_recorded_state(s);
    }
    int32_t again[DRV_SENSORS];
    reading_offsets(again);
    assert_memory_equal(again, first, sizeof first);
    /* The MCU resets and brings the array up again from scratch (fresh state). */
    memset(&fx.array, 0, sizeof fx.array);
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        expect_recorded_state(s);
    }
    reading_offsets(again);
    assert_memory_equal(again, first, sizeof first);
}

/* A part that kept power across an MCU reset keeps what was last written to it (here by
 * other firmware: a ULD-style SetOffset of +6 mm); the next bring-up restores the state. */
static void test_mcu_reset_with_the_part_powered(void **state) {
    (void)state;
    for (unsigned i = 1; i < DRV_SENSORS; ++i) {
        fx.rig_cfg.absent[i] = true;
    }
    fx.rig_cfg.sensor[0].xshut_wired = false;
    fx.sensor_cfg[0].xshut_pin = VL53_PIN_NONE;
    fx.sensor_cfg[0].address = 0x29u;
    fx.sensor_cfg[0].offsets.part_to_part_qmm = 10; /* +2.5 mm: rounds half up to +3 */
    fx.array_cfg.count = 1u;
    drv_fixture_build(&fx);
    drv_sleep(&fx, 2000u);
    struct vl53_dev *dev = &fx.array.dev[0];
    fx.array.cfg = &fx.array_cfg;
    int32_t offsets[2];
    for (unsigned life = 0; life < 2u; ++life) {
        assert_int_equal(vl53_attach(dev, &fx.sensor_cfg[0]), HAL_OK);
        assert_int_equal(vl53_wait_boot(dev), HAL_OK);
        assert_true(life == 0u ? !vl53_warm_boot(dev) : vl53_warm_boot(dev));
        assert_int_equal(vl53_configure(dev), HAL_OK);
        assert_int_equal(vl53_start_ranging(dev), HAL_OK);
        expect_recorded_state(0);
        struct vl53_result r;
        uint16_t source_mm = 0u;
        next_reading(0, &r, &source_mm);
        offsets[life] = (int32_t)r.distance_mm - (int32_t)source_mm;
        /* Other firmware writes its own offset, then the MCU resets. */
        const uint8_t uld_offset[6] = {0x00, 0x18, 0x00, 0x00, 0x00, 0x00}; /* 6 mm x 4 */
        assert_int_equal(hal_i2c_reg16_write(&fx.sensor_cfg[0].i2c, 0x29u, 0x001Eu, uld_offset,
                                             sizeof uld_offset, 2000u),
                         HAL_OK);
    }
    assert_int_equal(offsets[0], 3);
    assert_int_equal(offsets[1], 3);
}

static void test_part_that_does_not_take_the_offsets(void **state) {
    (void)state;
    fx.rig_cfg.sensor[1].ignores_offset_writes = true;
    fx.rig_cfg.sensor[3].ignores_offset_writes = true;
    fx.rig_cfg.sensor[3].nvm_part_to_part_qmm = 0; /* holds the recorded state already */
    fx.rig_cfg.sensor[3].nvm_inner_offset_mm = 0;
    fx.rig_cfg.sensor[3].nvm_outer_offset_mm = 0;
    drv_fixture_build(&fx);
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_ERR_DEVICE);
    const struct vl53_sensor_report *report = vl53_array_report(&fx.array, 1u);
    assert_int_equal(report->state, VL53_SENSOR_OFF);
    assert_int_equal(report->fault, VL53_ARRAY_CONFIG_FAILED);
    assert_int_equal(report->err, HAL_ERR_DEVICE);
    assert_int_equal(vl53_offset_mismatch_register(&fx.array.dev[1]), 0x001Eu);
    /* The others came up; sensor 3 holds the state, whoever wrote it. */
    assert_int_equal(vl53_array_ranging_count(&fx.array), 3u);
    assert_int_equal(vl53_offset_mismatch_register(&fx.array.dev[3]), 0u);
    /* Only the inner offset refused: that register is named. */
    fx.rig_cfg.sensor[1].nvm_part_to_part_qmm = 0;
    fx.rig_cfg.sensor[1].nvm_outer_offset_mm = 0;
    drv_fixture_build(&fx);
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_ERR_DEVICE);
    assert_int_equal(vl53_offset_mismatch_register(&fx.array.dev[1]), 0x0020u);
}

/* --- the --i2c-log lines (sim_i2c_csv_line, what host_sim and the twin write) ------------ */

#define LINES_MAX 2048u
static char lines[LINES_MAX][96];
static size_t line_count;

static void log_line(void *ctx, const struct sim_i2c_transaction *t) {
    (void)ctx;
    if (line_count < LINES_MAX) {
        char full[SIM_I2C_CSV_LINE_MAX];
        assert_true(sim_i2c_csv_line(t, full, sizeof full) > 0u);
        memcpy(lines[line_count], full, sizeof lines[0] - 1u); /* long lines cut */
        lines[line_count][sizeof lines[0] - 1u] = '\0';
        line_count++;
    }
}

static const struct sim_i2c_log_ops log_ops = {.transaction = log_line};

/* Index of the first line from `from` on containing `needle`, or LINES_MAX. */
static size_t find_line(size_t from, const char *needle) {
    for (size_t k = from; k < line_count; ++k) {
        if (strstr(lines[k], needle) != NULL) {
            return k;
        }
    }
    return LINES_MAX;
}

static void test_i2c_log_shows_the_offset_writes(void **state) {
    (void)state;
    line_count = 0u;
    const struct sim_i2c_log sink = {&log_ops, NULL};
    sim_i2c_set_log(&fx.rig.bus, &sink);
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    assert_true(line_count < LINES_MAX);
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        char addr[8];
        char write[64];
        char read[64];
        snprintf(addr, sizeof addr, ",0x%02x,", DRV_FIRST_ADDRESS + s);
        /* sensor 2: -8 quarter mm = 0x1ff8 in 13 bits, inner 2, outer -3 */
        const char *data = s == 2u ? "1ff80002fffd" : "000000000000";
        snprintf(write, sizeof write, "%s001e%s,,ok", addr, data);
        snprintf(read, sizeof read, "%s001e,%s,ok", addr, data);
        char block[24];
        snprintf(block, sizeof block, "%s002d", addr);
        char vhv[24];
        snprintf(vhv, sizeof vhv, "%s008740,", addr);
        const size_t k_block = find_line(0u, block);
        const size_t k_write = find_line(0u, write);
        const size_t k_read = find_line(0u, read);
        const size_t k_vhv = find_line(0u, vhv);
        print_message("sensor %u: block %zu, offsets %zu, read back %zu, VHV start %zu\n", s,
                      k_block, k_write, k_read, k_vhv);
        assert_true(k_block < k_write && k_write + 1u == k_read && k_read < k_vhv &&
                    k_vhv < LINES_MAX);
        assert_int_equal(find_line(k_read + 1u, write), LINES_MAX); /* once per bring-up */
    }
}

/* --- the model ------------------------------------------------------------------------- */

static void write_p2p(unsigned s, uint16_t field) {
    uint8_t bytes[2];
    hal_put_be16(bytes, field);
    assert_int_equal(hal_i2c_reg16_write(&fx.sensor_cfg[s].i2c, fx.sensor_cfg[s].address, 0x001Eu,
                                         bytes, sizeof bytes, 2000u),
                     HAL_OK);
}

/* The reported range is the source's plus 0x1E / 4 mm, rounded half up ([ULD]
 * CalibrateOffset: offset = target - mean, written x 4); bits 15:13 are not kept; the NVM
 * values come back at every power-up. */
static void test_model_applies_the_part_to_part_offset(void **state) {
    (void)state;
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    assert_int_equal(vl53_array_bring_up(&fx.array), HAL_OK);
    static const struct {
        uint16_t field;
        int32_t shift_mm;
    } cases[] = {
        {0x0014u, 5}, {0x1FECu, -5}, {0x0006u, 2}, {0x1FFAu, -1}, {0xE014u, 5}, {0x0000u, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        write_p2p(0, cases[i].field);
        assert_int_equal(sim_vl53_peek(&fx.rig.sensor[0], 0x001Eu), (cases[i].field >> 8) & 0x1Fu);
        struct vl53_result r;
        uint16_t source_mm = 0u;
        next_reading(0, &r, &source_mm); /* may have been measured before the write */
        next_reading(0, &r, &source_mm);
        print_message("0x1E = 0x%04x: %u mm for %u mm\n", cases[i].field, r.distance_mm, source_mm);
        assert_int_equal((int32_t)r.distance_mm - (int32_t)source_mm, cases[i].shift_mm);
    }
    /* A reset (brown-out): the part reloads its NVM offsets, the readings move. */
    assert_true(sim_vl53_inject(&fx.rig.sensor[3], SIM_FAULT_RESET));
    uint8_t got[6];
    peek_offsets(3, got);
    assert_int_equal(hal_get_be16(&got[0]), 0x1000u); /* -4096 in 13 bits */
    assert_int_equal((int16_t)hal_get_be16(&got[2]), 12);
    assert_int_equal((int16_t)hal_get_be16(&got[4]), 1);
}

static void test_offsets_out_of_the_field_are_refused(void **state) {
    (void)state;
    struct vl53_config c = fx.sensor_cfg[0];
    c.offsets.part_to_part_qmm = 4096;
    assert_string_equal(vl53_config_check(&c), "offsets");
    c.offsets.part_to_part_qmm = -4097;
    assert_string_equal(vl53_config_check(&c), "offsets");
    c.offsets.part_to_part_qmm = -4096;
    c.offsets.inner_mm = INT16_MIN;
    c.offsets.outer_mm = INT16_MAX;
    assert_null(vl53_config_check(&c));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_bring_up_pins_the_offsets_whatever_the_nvm, setup),
        cmocka_unit_test_setup(test_second_bring_up_gives_the_same_state_and_readings, setup),
        cmocka_unit_test_setup(test_mcu_reset_with_the_part_powered, setup),
        cmocka_unit_test_setup(test_part_that_does_not_take_the_offsets, setup),
        cmocka_unit_test_setup(test_i2c_log_shows_the_offset_writes, setup),
        cmocka_unit_test_setup(test_model_applies_the_part_to_part_offset, setup),
        cmocka_unit_test_setup(test_offsets_out_of_the_field_are_refused, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
