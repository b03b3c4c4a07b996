/*
 * The calibration's age through the firmware's link (firmware/link.h, firmware/cal_age.h) on
 * the simulated rig and flash: a calibration written by command starts at age 0; after a
 * reset the estimator and the status frame have the age reached before it plus the off
 * allowance (within one counter interval, never less), and every further reset adds the
 * allowance again; a new calibration starts at 0; without age storage it counts from the boot.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "firmware/calibration_record.h"
#include "firmware/link.h"
#include "hal/hal_err.h"
#include "sim/sim_flash.h"
#include "sim/sim_rig.h"
#include "telemetry/tlm_messages.h"
#include "test_calibration.h"

#define BUF 16384u
#define OFF 86400u

static struct {
    struct sim_rig rig;
    uint8_t rx[BUF], tx[BUF];
    size_t rx_len, rx_pos, tx_len;
    struct tof_link link;
    struct tof_app app;
    struct tof_platform platform;
    struct tlm_status status;
    unsigned statuses, acks;
} t;

static struct sim_flash flash; /* pages 0, 1: the age; 2, 3: the record (as the board) */
static struct tof_record_store store;
static struct tof_cal_age age;

static size_t serial_write(void *ctx, const uint8_t *data, size_t len) {
    (void)ctx;
    const size_t n = len <= BUF - t.tx_len ? len : 0u;
    memcpy(t.tx + t.tx_len, data, n);
    t.tx_len += n;
    return n;
}

static size_t serial_read(void *ctx, uint8_t *buf, size_t max) {
    (void)ctx;
    size_t n = t.rx_len - t.rx_pos;
    n = n < max ? n : max;
    memcpy(buf, t.rx + t.rx_pos, n);
    t.rx_pos += n;
    return n;
}

static uint32_t serial_rx_lost(void *ctx) {
    (void)ctx;
    return 0u;
}

static const struct hal_serial_ops serial_ops = {
    .write = serial_write, .read = serial_read, .rx_lost = serial_rx_lost};

static void on_frame(void *ctx, const struct tlm_frame *frame) {
    (void)ctx;
    struct tlm_telemetry msg;
    assert_int_equal(tlm_parse_telemetry(frame, &msg, NULL), TLM_RESULT_OK);
    if (msg.type == TLM_TYPE_STATUS) {
        ++t.statuses;
        t.status = msg.u.status;
    } else if (msg.type == TLM_TYPE_ACK && msg.u.ack.result == TLM_RESULT_OK) {
        ++t.acks;
    }
}

static void decode_output(void) {
    struct tlm_decoder dec;
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_TELEMETRY));
    const struct tlm_frame_sink sink = {.on_frame = on_frame, .ctx = NULL};
    tlm_decoder_feed(&dec, t.tx, t.tx_len, &sink);
    t.tx_len = 0;
}

static void push_command(const struct tlm_command *cmd, uint8_t seq) {
    uint8_t frame[TLM_FRAME_MAX];
    const int n = tlm_encode_command(seq, cmd, frame, sizeof frame);
    assert_true(n > 0);
    memcpy(t.rx + t.rx_len, frame, (size_t)n);
    t.rx_len += (size_t)n;
}

static void run_ms(uint32_t ms) {
    const uint64_t end = sim_clock_now(&t.rig.clock) + (uint64_t)ms * 1000u;
    for (unsigned guard = 0; sim_clock_now(&t.rig.clock) < end && guard < 1000000u; ++guard) {
        tof_app_step(&t.app, true);
        tof_link_poll(&t.link);
    }
}

/* A power-on: a new rig and application (the clock from 0), the same flash; `with_age`: the
 * board keeps the age. The service's start sends the status frame. */
static void boot(bool with_age) {
    memset(&t, 0, sizeof t);
    struct sim_rig_config cfg;
    sim_rig_default_config(&cfg);
    sim_rig_init(&t.rig, &cfg);
    tof_link_init(&t.link, (struct hal_serial){.ops = &serial_ops, .ctx = NULL});
    t.platform = (struct tof_platform){.board_name = "test",
                                       .i2c = t.rig.i2c,
                                       .gpio = t.rig.hal_gpio,
                                       .time = t.rig.time,
                                       .output = {.ops = &tof_link_output_ops, .ctx = &t.link}};
    for (unsigned i = 0; i < 4; ++i) {
        t.platform.xshut_pin[i] = SIM_RIG_XSHUT_PIN(i);
        t.platform.gpio1_pin[i] = SIM_RIG_GPIO1_PIN(i);
    }
    sim_flash_power_on(&flash);
    assert_int_equal(tof_record_init(&store, sim_flash_hal(&flash), 2u, 3u), HAL_OK);
    tof_link_set_records(&t.link, &tof_link_storage, &store);
    if (with_age) { /* as the board's main: the age booted before the application */
        assert_int_equal(tof_cal_age_init(&age, sim_flash_hal(&flash), 0u, 1u), HAL_OK);
        (void)tof_record_load(&store);
        const uint16_t tag = tof_cal_tag(&store);
        (void)tof_cal_age_boot(&age, tag != 0u, tag, tof_app_default_config.cal_off_allowance_s,
                               t.rig.time.ops->now_us(t.rig.time.ctx));
        tof_link_set_cal_age(&t.link, &age);
    }
    assert_int_equal(tof_app_init(&t.app, &t.platform, &tof_app_default_config), 0);
    tof_link_service_ops.start(&t.link, &t.app);
    decode_output();
    assert_int_equal(t.statuses, 1);
}

static uint32_t status_age(void) {
    const struct tlm_command cmd = {.type = TLM_TYPE_STATUS_REQUEST};
    push_command(&cmd, 9);
    run_ms(5);
    decode_output();
    return t.status.cal_age_s;
}

/* A calibration (`shift_um` on sensor A's offset: another one). */
static void write_calibration(int32_t shift_um) {
    struct calibration_head cal;
    test_calibration_fitted(&cal);
    cal.offset_um[0] += shift_um;
    struct tlm_command cmd = {.type = TLM_TYPE_WRITE_CALIBRATION};
    const struct tof_cal_binding b = tof_cal_binding_of(&t.app.cfg);
    assert_int_equal(tof_cal_encode(&cal, true, &b, cmd.u.cal_section), HAL_OK);
    push_command(&cmd, 1);
    run_ms(40);
    decode_output();
    assert_int_equal(t.acks, 1);
}

static int setup(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&flash, 4u, 2048u), HAL_OK);
    return 0;
}

static void test_the_age_goes_through_resets(void **state) {
    (void)state;
    boot(true);
    assert_int_equal(t.status.cal_age, TLM_CAL_AGE_NONE); /* nothing calibrated yet */
    write_calibration(0);
    assert_int_equal(t.app.estimator.cfg.calibration_age_s, 0u);
    run_ms(3000u);
    const uint32_t before = status_age();
    assert_int_equal(t.status.cal_age, TLM_CAL_AGE_KEPT);
    assert_true(before >= 2u && before <= 4u);
    /* reset after about 3 s: the stored age (one interval ahead) plus the allowance */
    boot(true);
    assert_int_equal(t.status.calibration, TLM_CAL_APPLIED);
    assert_int_equal(t.status.cal_age, TLM_CAL_AGE_KEPT);
    const uint32_t after = t.status.cal_age_s;
    assert_true(after >= before + OFF && after <= before + OFF + TOF_CAL_AGE_INTERVAL_S);
    assert_int_equal(t.app.estimator.cfg.calibration_age_s, after); /* what the walk counts */
    /* and again: each boot adds the allowance */
    boot(true);
    assert_true(t.status.cal_age_s >= after + OFF);
    /* a new calibration starts at 0 (the same one written again keeps its larger age) */
    write_calibration(0);
    boot(true);
    assert_true(t.status.cal_age_s >= after + 2u * OFF);
    write_calibration(40);
    assert_true(status_age() <= 1u);
    assert_int_equal(t.app.estimator.cfg.calibration_age_s, 0u);
    boot(true);
    assert_true(t.status.cal_age_s >= OFF && t.status.cal_age_s <= OFF + TOF_CAL_AGE_INTERVAL_S);
}

/* A board without age pages: the calibration applies, its age counts from the boot (status
 * none), never a stored one. */
static void test_without_age_storage_it_counts_from_the_boot(void **state) {
    (void)state;
    boot(true);
    write_calibration(0);
    boot(false);
    assert_int_equal(t.status.calibration, TLM_CAL_APPLIED);
    assert_int_equal(t.status.cal_age, TLM_CAL_AGE_NONE);
    assert_int_equal(t.status.cal_age_s, 0u);
    assert_int_equal(t.app.estimator.cfg.calibration_age_s, 0u);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_the_age_goes_through_resets, setup),
        cmocka_unit_test_setup(test_without_age_storage_it_counts_from_the_boot, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
