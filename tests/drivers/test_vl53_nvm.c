/*
 * The parts' NVM identity (binding a calibration to its parts): the driver reads
 * lot, wafer and die X/Y by ST's NVM-read sequence at bring-up, and gets what each device
 * model holds; a part that NACKs the sequence is parked with the error and its sensor named;
 * the model refuses every access out of ST's sequence (firmware on, no settling time, no
 * word latched), so a driver that skipped a step could not read an identity by luck.
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
#include "vl53/vl53.h"

static struct drv_fixture fx;

static int setup(void **state) {
    (void)state;
    return drv_fixture_default_rig(&fx);
}

static int bring_up(void) {
    assert_int_equal(vl53_array_attach(&fx.array, &fx.array_cfg), HAL_OK);
    return vl53_array_bring_up(&fx.array);
}

static void test_bring_up_reads_each_parts_identity(void **state) {
    (void)state;
    assert_int_equal(bring_up(), HAL_OK);
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        const struct sim_vl53 *m = &fx.rig.sensor[s];
        const uint64_t id = vl53_part_id(vl53_array_sensor(&fx.array, s));
        assert_true(id != 0u);
        assert_true(id == sim_vl53_part_id(m));
        for (unsigned t = 0; t < s; ++t) { /* the defaults differ per part */
            assert_true(id != vl53_part_id(vl53_array_sensor(&fx.array, t)));
        }
        assert_int_equal(m->stats.nvm_words, 2u); /* the two words of NVM 0x1F8..0x1FF */
        assert_int_equal(m->stats.nvm_violations, 0u);
        assert_int_equal(m->stats.protocol_errors, 0u);
        assert_int_equal(vl53_array_report(&fx.array, s)->state, VL53_SENSOR_RANGING);
    }
}

/* On a 100 kHz bus the read (~19 transfers, several ms) still fits its budgets: one part
 * released and read at 0x29 right after boot, as the bring-up does before configuring. */
static void test_identity_read_at_100_khz(void **state) {
    (void)state;
    fx.rig_cfg.bus_hz = 100000u;
    drv_fixture_build(&fx);
    struct vl53_dev others;
    for (unsigned k = 0; k < DRV_SENSORS; ++k) { /* all in reset: one part at 0x29 */
        assert_int_equal(vl53_attach(&others, &fx.sensor_cfg[k]), HAL_OK);
        assert_int_equal(vl53_shutdown(&others), HAL_OK);
    }
    drv_sleep(&fx, 500u);
    struct vl53_dev dev;
    assert_int_equal(vl53_attach(&dev, &fx.sensor_cfg[1]), HAL_OK);
    assert_int_equal(vl53_power_up(&dev), HAL_OK);
    assert_int_equal(vl53_wait_boot(&dev), HAL_OK);
    const uint64_t t0 = drv_now(&fx);
    uint64_t id = 0u;
    assert_int_equal(vl53_read_part_id(&dev, &id), HAL_OK);
    const uint64_t took = drv_now(&fx) - t0;
    print_message("NVM identity read at 100 kHz: %llu us\n", (unsigned long long)took);
    assert_true(id == sim_vl53_part_id(&fx.rig.sensor[1]));
    assert_true(vl53_part_id(&dev) == id);
    assert_true(took > 2u * VL53_NVM_READ_TRIGGER_US + 300u); /* the waits were taken */
    assert_true(took <= 4u * VL53_DEFAULT_CALL_BUDGET_US);
    assert_int_equal(fx.rig.sensor[1].stats.nvm_violations, 0u);
}

static void test_configured_identity_is_read_back(void **state) {
    (void)state;
    const uint64_t ids[DRV_SENSORS] = {0x0123456789ABCDEFull, 0xFEDCBA9876543210ull,
                                       0x8000000000000001ull, 0x00000000000000FFull};
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        fx.rig_cfg.sensor[s].part_id = ids[s];
    }
    drv_fixture_build(&fx);
    assert_int_equal(bring_up(), HAL_OK);
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        uint64_t again = 0u;
        struct vl53_dev *dev = vl53_array_sensor(&fx.array, s);
        assert_true(vl53_part_id(dev) == ids[s]);
        /* ranging: refused before any bus access, the identity kept */
        assert_int_equal(vl53_read_part_id(dev, &again), HAL_ERR_STATE);
        assert_int_equal(vl53_stop_ranging(dev), HAL_OK);
        assert_int_equal(vl53_read_part_id(dev, &again), HAL_OK);
        assert_true(again == ids[s]);
        /* the firmware is back on: the part ranges again */
        assert_int_equal(vl53_start_ranging(dev), HAL_OK);
        assert_int_equal(fx.rig.sensor[s].refusal, SIM_VL53_RANGES);
    }
}

static void test_nacking_part_is_parked_and_named(void **state) {
    (void)state;
    fx.rig_cfg.sensor[2].nvm_unreadable = true;
    drv_fixture_build(&fx);
    assert_int_equal(bring_up(), HAL_ERR_DATA_NACK);
    const struct vl53_sensor_report *r = vl53_array_report(&fx.array, 2);
    assert_int_equal(r->fault, VL53_ARRAY_IDENTITY_FAILED);
    assert_int_equal(r->err, HAL_ERR_DATA_NACK);
    assert_int_equal(r->state, VL53_SENSOR_OFF);
    assert_string_equal(vl53_array_fault_name(r->fault), "identity_failed");
    assert_true(vl53_part_id(vl53_array_sensor(&fx.array, 2)) == 0u);
    assert_true(fx.rig.sensor[2].stats.nvm_nacks > 0u);
    for (unsigned s = 0; s < DRV_SENSORS; ++s) {
        if (s != 2u) {
            assert_int_equal(vl53_array_report(&fx.array, s)->state, VL53_SENSOR_RANGING);
            assert_true(vl53_part_id(vl53_array_sensor(&fx.array, s)) ==
                        sim_vl53_part_id(&fx.rig.sensor[s]));
        }
    }
}

static int wr(uint16_t reg, uint8_t v) {
    return hal_i2c_reg16_write(&fx.sensor_cfg[0].i2c, DRV_FIRST_ADDRESS, reg, &v, 1u, 2000u);
}

static void test_model_refuses_accesses_out_of_sequence(void **state) {
    (void)state;
    assert_int_equal(bring_up(), HAL_OK);
    struct vl53_dev *dev = vl53_array_sensor(&fx.array, 0);
    struct sim_vl53 *m = &fx.rig.sensor[0];
    assert_int_equal(vl53_stop_ranging(dev), HAL_OK);
    uint8_t out[4];
    /* no word latched */
    assert_int_equal(
        hal_i2c_reg16_read(&fx.sensor_cfg[0].i2c, DRV_FIRST_ADDRESS, 0x0790u, out, 4u, 2000u),
        HAL_ERR_DATA_NACK);
    /* NVM power-up with the firmware still on */
    assert_int_equal(wr(0x0781u, 1u), HAL_ERR_DATA_NACK);
    /* firmware off and power force on, but no settling time */
    assert_int_equal(wr(0x0085u, 0u), HAL_OK);
    assert_int_equal(wr(0x0083u, 1u), HAL_OK);
    assert_int_equal(wr(0x0781u, 1u), HAL_ERR_DATA_NACK);
    drv_sleep(&fx, 250u);
    assert_int_equal(wr(0x0781u, 1u), HAL_OK);
    /* a word before the clock and read mode */
    assert_int_equal(wr(0x0794u, 0x7Eu), HAL_ERR_DATA_NACK);
    /* firmware back on under a powered NVM */
    assert_int_equal(wr(0x0085u, 1u), HAL_ERR_DATA_NACK);
    assert_int_equal(m->stats.nvm_violations, 5u);
    assert_int_equal(m->stats.nvm_words, 2u); /* only the bring-up's */
    /* the driver's own sequence still works from this state, and leaves the part running */
    uint64_t id = 0u;
    assert_int_equal(vl53_read_part_id(dev, &id), HAL_OK);
    assert_true(id == sim_vl53_part_id(m));
    assert_int_equal(m->stats.nvm_violations, 5u);
    assert_int_equal(vl53_start_ranging(dev), HAL_OK);
    assert_int_equal(m->refusal, SIM_VL53_RANGES);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_bring_up_reads_each_parts_identity, setup),
        cmocka_unit_test_setup(test_identity_read_at_100_khz, setup),
        cmocka_unit_test_setup(test_configured_identity_is_read_back, setup),
        cmocka_unit_test_setup(test_nacking_part_is_parked_and_named, setup),
        cmocka_unit_test_setup(test_model_refuses_accesses_out_of_sequence, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
