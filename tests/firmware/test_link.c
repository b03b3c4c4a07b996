/*
 * The firmware on the simulated rig, driven over its telemetry link: commands in
 * (set window, select estimator, set process noise, status request, stop/start, save,
 * malformed frames),
 * estimates, health and acks out, decoded with the protocol's own decoder.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "firmware/calibration_record.h"
#include "firmware/link.h"
#include "hal/hal_err.h"
#include "hal/hal_temp.h"
#include "sim/sim_flash.h"
#include "sim/sim_rig.h"
#include "telemetry/tlm_messages.h"

#define BUF 65536u

struct fake_serial {
    uint8_t rx[BUF];
    size_t rx_len, rx_pos;
    uint8_t tx[BUF];
    size_t tx_len;
    uint32_t rx_lost; /* what the port says its receiver lost */
};

static size_t serial_write(void *ctx, const uint8_t *data, size_t len) {
    struct fake_serial *s = ctx;
    const size_t n = len <= BUF - s->tx_len ? len : 0u; /* whole frames or nothing */
    memcpy(s->tx + s->tx_len, data, n);
    s->tx_len += n;
    return n;
}

static size_t serial_read(void *ctx, uint8_t *buf, size_t max) {
    struct fake_serial *s = ctx;
    size_t n = s->rx_len - s->rx_pos;
    n = n < max ? n : max;
    memcpy(buf, s->rx + s->rx_pos, n);
    s->rx_pos += n;
    return n;
}

static uint32_t serial_rx_lost(void *ctx) {
    const struct fake_serial *s = ctx;
    return s->rx_lost;
}

static const struct hal_serial_ops serial_ops = {
    .write = serial_write, .read = serial_read, .rx_lost = serial_rx_lost};

static struct {
    struct sim_rig rig;
    struct fake_serial serial;
    struct tof_link link;
    struct tof_app app;
    struct tof_platform platform;
    /* decoded output */
    unsigned acks, nacks, estimates, health, status, raw;
    uint8_t last_nack_result, last_ack_command;
    int last_nack_error;
    struct tlm_status last_status;
    struct tlm_estimate last_estimate[4];
    struct tlm_health last_health;
    unsigned calibrations;
    struct tlm_calibration last_calibration;
} t;

static void push_command(const struct tlm_command *cmd, uint8_t seq) {
    uint8_t frame[TLM_FRAME_MAX];
    const int n = tlm_encode_command(seq, cmd, frame, sizeof frame);
    assert_true(n > 0);
    memcpy(t.serial.rx + t.serial.rx_len, frame, (size_t)n);
    t.serial.rx_len += (size_t)n;
}

static void on_frame(void *ctx, const struct tlm_frame *frame) {
    (void)ctx;
    struct tlm_telemetry msg;
    assert_int_equal(tlm_parse_telemetry(frame, &msg, NULL), TLM_RESULT_OK);
    switch (msg.type) {
    case TLM_TYPE_ACK:
        if (msg.u.ack.result == TLM_RESULT_OK) {
            ++t.acks;
            t.last_ack_command = msg.u.ack.command;
        } else {
            ++t.nacks;
            t.last_nack_result = msg.u.ack.result;
            t.last_nack_error = msg.u.ack.error;
        }
        break;
    case TLM_TYPE_ESTIMATE:
        ++t.estimates;
        t.last_estimate[msg.u.estimate.estimator] = msg.u.estimate;
        break;
    case TLM_TYPE_HEALTH:
        ++t.health;
        t.last_health = msg.u.health;
        break;
    case TLM_TYPE_STATUS:
        ++t.status;
        t.last_status = msg.u.status;
        break;
    case TLM_TYPE_RAW_SAMPLE:
        ++t.raw;
        break;
    case TLM_TYPE_CALIBRATION:
        ++t.calibrations;
        t.last_calibration = msg.u.calibration;
        break;
    default:
        fail_msg("unexpected telemetry type 0x%02x", msg.type);
    }
}

static void decode_output(void) {
    struct tlm_decoder dec;
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_TELEMETRY));
    const struct tlm_frame_sink sink = {.on_frame = on_frame, .ctx = NULL};
    tlm_decoder_feed(&dec, t.serial.tx, t.serial.tx_len, &sink);
    assert_int_equal(dec.counters.bad_crc, 0);
    assert_int_equal(dec.counters.discarded_bytes, 0);
}

static void run_ms(uint32_t ms) {
    const uint64_t end = sim_clock_now(&t.rig.clock) + (uint64_t)ms * 1000u;
    for (unsigned guard = 0; sim_clock_now(&t.rig.clock) < end && guard < 1000000u; ++guard) {
        tof_app_step(&t.app, true);
        tof_link_poll(&t.link);
    }
}

/* The rig's distances: NULL for the default 100 mm parallel plate. */
static const struct sim_range_source *rig_source;

static void setup_with(const struct tof_app_config *app_cfg) {
    memset(&t, 0, sizeof t);
    struct sim_rig_config cfg;
    sim_rig_default_config(&cfg); /* every sensor reads 100 mm: a parallel plate */
    if (rig_source != NULL) {
        cfg.source = *rig_source;
    }
    sim_rig_init(&t.rig, &cfg);
    tof_link_init(&t.link, (struct hal_serial){.ops = &serial_ops, .ctx = &t.serial});
    t.platform = (struct tof_platform){.board_name = "test",
                                       .i2c = t.rig.i2c,
                                       .gpio = t.rig.hal_gpio,
                                       .time = t.rig.time,
                                       .output = {.ops = &tof_link_output_ops, .ctx = &t.link}};
    for (unsigned i = 0; i < 4; ++i) {
        t.platform.xshut_pin[i] = SIM_RIG_XSHUT_PIN(i);
        t.platform.gpio1_pin[i] = SIM_RIG_GPIO1_PIN(i);
    }
    assert_int_equal(tof_app_init(&t.app, &t.platform, app_cfg), 0);
    tof_link_bind(&t.link, &t.app);
}

static int setup(void **state) {
    (void)state;
    rig_source = NULL;
    setup_with(&tof_app_default_config);
    return 0;
}

/* Sensor C reads 8190, the VL53L0X's no-target value (with status 0, as popular
 * libraries log it); the others 100 mm. */
static int no_target_next(void *ctx, unsigned sensor, uint32_t sample_index,
                          struct sim_range *out) {
    (void)ctx;
    (void)sample_index;
    *out = (struct sim_range){.distance_mm = sensor == 2u ? 8190u : 100u, .present = true};
    return 0;
}

static const struct sim_range_source_ops no_target_ops = {.next = no_target_next};

static int setup_no_target(void **state) {
    (void)state;
    static const struct sim_range_source source = {.ops = &no_target_ops, .ctx = NULL};
    rig_source = &source;
    setup_with(&tof_app_default_config);
    rig_source = NULL;
    return 0;
}

static void test_default_windows_report_a_parallel_plate(void **state) {
    (void)state;
    /* Two windows of 100 samples at 20 ms, after the ~115 ms bring-up (ST's block and VHV
     * step) and the first slot, with time for the link to send the second window. */
    run_ms(2 * 100 * 20 + 300);
    decode_output();
    assert_int_equal(t.estimates, 2 * 4); /* four estimators per window */
    assert_int_equal(t.health, 2);
    const struct tlm_estimate *e = &t.last_estimate[TLM_ESTIMATOR_CONSENSUS];
    /* The default image has no head calibration: never ok, and `uncalibrated`
     * is the only reason for the perfect readings of a parallel plate. */
    assert_int_equal(e->status, TLM_STATUS_DEGRADED);
    assert_int_equal(e->alpha_udeg, 0);
    assert_int_equal(e->beta_udeg, 0);
    assert_int_equal(e->distance_um, 100000);
    assert_int_equal(e->window_index, 1);
    /* Each value with its sd (>= 1 um or udeg, never a claimed 0), why naming only the
     * missing calibration, and the estimator's own figures unchanged on the wire. */
    assert_true(e->why == ATTITUDE_WHY_UNCALIBRATED);
    assert_true(e->alpha_sd_udeg >= 1 && e->beta_sd_udeg >= 1 && e->distance_sd_um >= 1);
    assert_int_equal(t.link.tx_dropped, 0); /* every estimate encoded */
    for (unsigned i = 0; i < 4; ++i) {
        assert_int_equal(t.last_health.sensor_state[i], TLM_HEALTH_HEALTHY);
    }
}

static void test_commands_are_applied_and_acknowledged(void **state) {
    (void)state;
    struct tlm_command cmd = {.type = TLM_TYPE_SET_WINDOW};
    cmd.u.set_window.window_n = 10;
    cmd.u.set_window.mode = TLM_WINDOW_TUMBLING;
    push_command(&cmd, 1);
    cmd = (struct tlm_command){.type = TLM_TYPE_SELECT_ESTIMATOR};
    cmd.u.estimator = TLM_ESTIMATOR_KALMAN;
    push_command(&cmd, 2);
    cmd = (struct tlm_command){.type = TLM_TYPE_STATUS_REQUEST};
    push_command(&cmd, 3);
    run_ms(30 * 20);
    decode_output();
    assert_int_equal(t.acks, 3);
    assert_int_equal(t.nacks, 0);
    assert_int_equal(t.status, 1);
    assert_int_equal(t.last_status.window_n, 10);
    assert_int_equal(t.last_status.estimator, TLM_ESTIMATOR_KALMAN);
    assert_true(t.last_status.running);
    assert_int_equal(t.last_status.period_ms, 20);
    /* windows of 10 samples: at least two in 600 ms */
    assert_true(t.estimates >= 2u * 4u);
    assert_int_equal(t.app.estimator.cfg.window, 10);
}

/* A host that lost an answer sends the same frame again (same sequence, type, payload): it
 * is answered again but applied once; the same payload under a new sequence number, or
 * another type under the same one, is a new command (docs/reference/telemetry-protocol.md,
 * "Retries"). */
static void test_a_retried_command_is_answered_but_applied_once(void **state) {
    (void)state;
    struct tlm_command cmd = {.type = TLM_TYPE_SET_WINDOW};
    cmd.u.set_window.window_n = 10;
    cmd.u.set_window.mode = TLM_WINDOW_TUMBLING;
    push_command(&cmd, 5);
    push_command(&cmd, 5); /* the retry */
    run_ms(60);
    assert_int_equal(t.link.commands_ok, 1);
    assert_int_equal(t.link.commands_repeated, 1);
    push_command(&cmd, 6); /* a new command with the same payload */
    const struct tlm_command stop = {.type = TLM_TYPE_STOP};
    push_command(&stop, 6); /* another type, the same sequence */
    run_ms(60);
    decode_output();
    assert_int_equal(t.acks, 4);
    assert_int_equal(t.link.commands_ok, 3);
    assert_int_equal(t.link.commands_repeated, 1);
}

/* Short windows send health at most once a second (TOF_LINK_HEALTH_PERIOD_US), not one
 * 155-byte frame per window; the frame carries the port's lost received bytes. */
static void test_health_is_rate_limited_and_counts_uart_overruns(void **state) {
    (void)state;
    t.serial.rx_lost = 3;
    struct tlm_command cmd = {.type = TLM_TYPE_SET_WINDOW};
    cmd.u.set_window.window_n = 2;
    cmd.u.set_window.mode = TLM_WINDOW_TUMBLING;
    push_command(&cmd, 1);
    run_ms(2500); /* ~55 windows of 40 ms after bring-up */
    decode_output();
    assert_true(t.estimates >= 50u * 4u);
    assert_true(t.health >= 2u && t.health <= 3u);
    assert_int_equal(t.last_health.uart_overruns, 3);
}

/* The flight image runs consensus and kalman only (ATTITUDE_EST_BUILT): making a
 * stopped estimator primary is refused and changes nothing. */
static void test_selecting_an_estimator_that_does_not_run_is_refused(void **state) {
    (void)state;
    t.app.estimator.cfg.estimators =
        (uint8_t)(ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS) | ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN));
    struct tlm_command cmd = {.type = TLM_TYPE_SELECT_ESTIMATOR};
    cmd.u.estimator = TLM_ESTIMATOR_CONSENSUS_PAPER;
    push_command(&cmd, 1);
    cmd.u.estimator = TLM_ESTIMATOR_MEAN;
    push_command(&cmd, 2);
    cmd.u.estimator = TLM_ESTIMATOR_KALMAN;
    push_command(&cmd, 3);
    cmd = (struct tlm_command){.type = TLM_TYPE_STATUS_REQUEST};
    push_command(&cmd, 4);
    run_ms(100);
    decode_output();
    assert_int_equal(t.nacks, 2);
    assert_int_equal(t.last_nack_result, TLM_RESULT_STATE);
    assert_int_equal(t.last_nack_error, ATTITUDE_ERR_ESTIMATORS); /* the estimator's code */
    assert_int_equal(t.acks, 2);
    assert_int_equal(t.last_status.estimator, TLM_ESTIMATOR_KALMAN);
}

/* A configuration without the product consensus: the primary estimator at start is the
 * first one that runs, so status and telemetry never lead with a stopped estimator. */
static struct tof_app_config kalman_only;
static int setup_kalman_only(void **state) {
    (void)state;
    kalman_only = tof_app_default_config;
    kalman_only.estimator.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN);
    setup_with(&kalman_only);
    return 0;
}

static void test_primary_is_an_estimator_that_runs(void **state) {
    (void)state;
    assert_int_equal(t.app.primary, ATTITUDE_EST_KALMAN);
    struct tlm_command cmd = {.type = TLM_TYPE_STATUS_REQUEST};
    push_command(&cmd, 1);
    run_ms(100);
    decode_output();
    assert_int_equal(t.last_status.estimator, TLM_ESTIMATOR_KALMAN);
}

static void test_stop_silences_estimates_and_raw_stream_sends_samples(void **state) {
    (void)state;
    struct tlm_command cmd = {.type = TLM_TYPE_STOP};
    push_command(&cmd, 7);
    cmd = (struct tlm_command){.type = TLM_TYPE_RAW_STREAM};
    cmd.u.raw_enable = true;
    push_command(&cmd, 8);
    run_ms(150 * 20 + 200);
    decode_output();
    assert_int_equal(t.acks, 2);
    assert_int_equal(t.estimates, 0);
    assert_true(t.raw >= 140u);
}

/* A sensor reporting its own hardware fault (raw 2 VCSEL watchdog, 1, 17) is re-initialised by
 * the fault manager, alone, and the bus is left alone. */
static void test_sensor_hardware_fault_reinits_that_sensor(void **state) {
    (void)state;
    run_ms(500);
    assert_int_equal(t.app.counters.reinits_ok, 0u);
    sim_vl53_force_results(&t.rig.sensor[2], 2u, 100u, 1u);
    run_ms(600);
    assert_int_equal(t.app.counters.reinits_ok, 1u);
    assert_int_equal(t.app.counters.reinits_failed, 0u);
    assert_int_equal(t.app.counters.bus_recoveries, 0u);
    assert_int_equal(t.rig.bus.stats.recoveries, 0u);
    assert_int_equal(t.rig.sensor[2].stats.injected_resets + t.rig.sensor[2].stats.power_ups,
                     3u); /* powered at start, bring-up, the re-init's XSHUT cycle */
    assert_int_equal(t.rig.sensor[0].stats.power_ups, 2u);
    for (unsigned i = 0; i < 4; ++i) {
        assert_int_equal(t.app.health[i].state, TOF_HEALTH_HEALTHY);
    }
    /* The other two hardware-fault codes (raw 1 VCSEL continuity, 17 multi-clip) take the
     * same path, each on its own sensor. */
    sim_vl53_force_results(&t.rig.sensor[0], 1u, 100u, 1u);
    run_ms(600);
    sim_vl53_force_results(&t.rig.sensor[3], 17u, 100u, 1u);
    run_ms(600);
    assert_int_equal(t.app.counters.reinits_ok, 3u);
    assert_int_equal(t.app.counters.bus_recoveries, 0u);
    assert_int_equal(t.rig.bus.stats.recoveries, 0u);
    assert_int_equal(t.rig.sensor[0].stats.power_ups, 3u);
    assert_int_equal(t.rig.sensor[1].stats.power_ups, 2u);
    assert_int_equal(t.rig.sensor[3].stats.power_ups, 3u);
}

static void test_malformed_frames_are_counted_and_refused(void **state) {
    (void)state;
    /* bad CRC: a valid frame with its last byte changed */
    struct tlm_command cmd = {.type = TLM_TYPE_START};
    push_command(&cmd, 4);
    t.serial.rx[t.serial.rx_len - 1u] ^= 0xFFu;
    /* out of range: window 1 (encoded by hand: the encoder refuses it) */
    const uint8_t payload[3] = {1, 0, 0};
    uint8_t frame[TLM_FRAME_MAX];
    const int n =
        tlm_frame_encode(TLM_TYPE_SET_WINDOW, 5, payload, sizeof payload, frame, sizeof frame);
    assert_true(n > 0);
    memcpy(t.serial.rx + t.serial.rx_len, frame, (size_t)n);
    t.serial.rx_len += (size_t)n;
    /* unknown command type 0x9F with an empty payload */
    const int m = tlm_frame_encode(0x9F, 6, NULL, 0, frame, sizeof frame);
    assert_true(m > 0);
    memcpy(t.serial.rx + t.serial.rx_len, frame, (size_t)m);
    t.serial.rx_len += (size_t)m;
    run_ms(2 * 100 * 20 + 100);
    decode_output();
    assert_int_equal(t.acks, 0);
    assert_int_equal(t.nacks, 2); /* the bad-CRC frame gets no answer: it is not a frame */
    assert_int_equal(t.link.decoder.counters.bad_crc, 1);
    assert_int_equal(t.link.decoder.counters.out_of_range, 1);
    assert_int_equal(t.link.decoder.counters.unknown_type, 1);
    assert_int_equal(t.last_health.link.bad_crc, 1);
    assert_int_equal(t.app.estimator.cfg.window, 100); /* nothing applied */
}

/* The estimator's error codes reach the firmware's callers unchanged. */
static void test_estimator_errors_pass_up_unchanged(void **state) {
    (void)state;
    assert_int_equal(tof_app_set_window(&t.app, 1, false), ATTITUDE_ERR_WINDOW);
    assert_int_equal(tof_app_set_window(&t.app, ATTITUDE_WINDOW_MAX + 1u, true),
                     ATTITUDE_ERR_WINDOW);
    assert_int_equal(t.app.estimator.cfg.window, 100); /* nothing changed */
    assert_int_equal(t.app.estimator.cfg.mode, ATTITUDE_TUMBLING);
    assert_int_equal(tof_app_set_window(&t.app, 20, true), ATTITUDE_ERR_NONE);
    assert_int_equal(t.app.estimator.cfg.window, 20);
    assert_int_equal(tof_app_set_primary(&t.app, (enum attitude_estimator)9),
                     ATTITUDE_ERR_ESTIMATORS);
    /* At init: the estimator's refusal is returned as it is and named by its message. */
    static struct tof_app app;
    static struct tof_app_config bad;
    bad = tof_app_default_config;
    bad.estimator.consensus_tolerance_udeg = 0;
    const int rc = tof_app_init(&app, &t.platform, &bad);
    assert_int_equal(rc, ATTITUDE_ERR_TOLERANCE);
    assert_int_equal(app.estimator_error, ATTITUDE_ERR_TOLERANCE);
    assert_string_equal(tof_app_error_message(&app, rc),
                        attitude_error_message(ATTITUDE_ERR_TOLERANCE));
    assert_string_equal(tof_app_error_message(&t.app, HAL_ERR_TIMEOUT), "TIMEOUT");
}

/* tof_app_main knows the link only as a service: started once after init, polled after
 * every iteration, never started when init fails (which it logs in the estimator's words). */
static unsigned service_starts, service_polls;
static struct tof_app *service_app;
static char log_text[512];
static size_t log_len;

static void count_start(void *ctx, struct tof_app *app) {
    (void)ctx;
    ++service_starts;
    service_app = app;
}

static void count_poll(void *ctx) {
    (void)ctx;
    ++service_polls;
}

static void log_write(void *ctx, const char *text, size_t len) {
    (void)ctx;
    const size_t n = len < sizeof log_text - 1u - log_len ? len : sizeof log_text - 1u - log_len;
    memcpy(log_text + log_len, text, n);
    log_len += n;
    log_text[log_len] = '\0';
}

static const struct hal_log_ops log_ops = {.write = log_write};

static void test_main_runs_the_link_as_a_service(void **state) {
    (void)state;
    static const struct tof_app_service_ops ops = {.start = count_start, .poll = count_poll};
    const struct tof_app_service svc = {.ops = &ops, .ctx = NULL};
    service_starts = service_polls = 0;
    static struct tof_app app;
    assert_int_equal(tof_app_main(&t.platform, &tof_app_default_config, &app, &svc, 5), 0);
    assert_int_equal(service_starts, 1);
    assert_int_equal(service_polls, 5);
    assert_ptr_equal(service_app, &app);
    static struct tof_app_config bad;
    bad = tof_app_default_config;
    bad.estimator.paper_max_iterations = 0;
    log_len = 0;
    log_text[0] = '\0';
    t.platform.log = (struct hal_log){.ops = &log_ops, .ctx = NULL};
    assert_int_equal(tof_app_main(&t.platform, &bad, &app, &svc, 5), ATTITUDE_ERR_PAPER_ITERATIONS);
    assert_int_equal(service_starts, 1);
    /* the code (-72, ATTITUDE_ERR_PAPER_ITERATIONS), named by docs/reference/errors.md and the host
     */
    char want[64];
    snprintf(want, sizeof want, "init failed: estimator error %d (docs/reference/errors.md)",
             (int)ATTITUDE_ERR_PAPER_ITERATIONS);
    assert_non_null(strstr(log_text, want));
    /* The link's own service ops: start binds and sends a status frame. */
    struct tof_link link;
    tof_link_init(&link, (struct hal_serial){.ops = &serial_ops, .ctx = &t.serial});
    tof_link_service_ops.start(&link, &t.app);
    assert_ptr_equal(link.app, &t.app);
    decode_output();
    assert_int_equal(t.status, 1);
}

/* The estimate frame carries exactly what the estimator said: each value with its sd,
 * the why bits unchanged, a missing value as TLM_NO_VALUE with no sd. A spy between the
 * application and the link keeps the last record to compare with the decoded frames. */
static struct tof_estimate_record spied;
static unsigned spied_count;

static void spy_estimate(void *ctx, const struct tof_estimate_record *record) {
    spied = *record;
    ++spied_count;
    tof_link_output_ops.estimate(ctx, record);
}

static const struct tof_output_ops spy_ops = {
    .estimate = spy_estimate, .sample = NULL, .event = NULL};

static void expect_same_estimate(const struct attitude_estimate *a, const struct tlm_estimate *w) {
    assert_int_equal(w->status, (uint8_t)a->status);
    assert_true(w->why == a->why);
    assert_int_equal(w->alpha_udeg, a->alpha_valid ? a->alpha_udeg : TLM_NO_VALUE);
    assert_int_equal(w->alpha_sd_udeg, a->alpha_valid ? a->alpha_sd_udeg : TLM_NO_VALUE);
    assert_int_equal(w->beta_udeg, a->beta_valid ? a->beta_udeg : TLM_NO_VALUE);
    assert_int_equal(w->beta_sd_udeg, a->beta_valid ? a->beta_sd_udeg : TLM_NO_VALUE);
    assert_int_equal(w->distance_um, a->distance_valid ? a->distance_um : TLM_NO_VALUE);
    assert_int_equal(w->distance_sd_um, a->distance_valid ? a->distance_sd_um : TLM_NO_VALUE);
}

static void test_estimate_frames_carry_the_estimators_sd_and_why(void **state) {
    (void)state;
    t.platform.output = (struct tof_output){.ops = &spy_ops, .ctx = &t.link};
    spied_count = 0;
    /* sensor C reads the VL53L0X no-target value 8190 (setup_no_target): not ok, and why */
    run_ms(100 * 20 + 100);
    decode_output();
    assert_int_equal(spied_count, 1);
    assert_int_equal(t.link.tx_dropped, 0);
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        if (spied.output.est[e].reason == ATTITUDE_REASON_DISABLED) {
            continue;
        }
        expect_same_estimate(&spied.output.est[e], &t.last_estimate[e]);
        assert_int_not_equal(t.last_estimate[e].status, TLM_STATUS_OK);
        assert_true(t.last_estimate[e].why != 0u);
    }
}

/* The temperature a window's record carries (the application's, set here by a spy between it
 * and the link) reaches every estimate frame of that window; the status frame reports the last
 * one while the unit runs, none when stopped; a window without one says so (known 0, value 0). */
static bool spy_temp_known;
static int16_t spy_temp_cdeg;

static void spy_temperature(void *ctx, const struct tof_estimate_record *record) {
    spied = *record;
    spied.temp_known = spy_temp_known;
    spied.temp_cdeg = spy_temp_cdeg;
    ++spied_count;
    tof_link_output_ops.estimate(ctx, &spied);
}

static void pass_sample(void *ctx, const struct tof_sample *sample) {
    tof_link_output_ops.sample(ctx, sample); /* the re-zero's samples */
}

static const struct tof_output_ops temperature_ops = {
    .estimate = spy_temperature, .sample = pass_sample, .event = NULL};

static void test_estimate_and_status_frames_carry_the_temperature(void **state) {
    (void)state;
    t.platform.output = (struct tof_output){.ops = &temperature_ops, .ctx = &t.link};
    spied_count = 0;
    spy_temp_known = true;
    spy_temp_cdeg = -2345; /* -23.45 degC */
    struct tlm_command cmd = {.type = TLM_TYPE_STATUS_REQUEST};
    push_command(&cmd, 1);
    run_ms(30); /* before any window: the unit has no temperature yet */
    decode_output();
    assert_int_equal(t.status, 1);
    assert_false(t.last_status.temp_known);
    assert_int_equal(t.last_status.temp_cdeg, 0);
    t.serial.tx_len = 0;
    t.status = 0;
    run_ms(100 * 20 + 100);
    push_command(&cmd, 2);
    run_ms(30);
    decode_output();
    assert_int_equal(spied_count, 1);
    assert_int_equal(t.link.tx_dropped, 0);
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        if (spied.output.est[e].reason != ATTITUDE_REASON_DISABLED) {
            assert_true(t.last_estimate[e].temp_known);
            assert_int_equal(t.last_estimate[e].temp_cdeg, -2345);
        }
    }
    assert_int_equal(t.status, 1);
    assert_true(t.last_status.temp_known);
    assert_int_equal(t.last_status.temp_cdeg, -2345);
    /* a window without a temperature: none, in the estimates and then the status */
    spy_temp_known = false;
    spy_temp_cdeg = 1234; /* not read when not known */
    t.serial.tx_len = 0;
    t.status = 0;
    run_ms(100 * 20);
    push_command(&cmd, 3);
    run_ms(30);
    decode_output();
    assert_int_equal(spied_count, 2);
    assert_int_equal(t.link.tx_dropped, 0);
    assert_false(t.last_estimate[TLM_ESTIMATOR_CONSENSUS].temp_known);
    assert_int_equal(t.last_estimate[TLM_ESTIMATOR_CONSENSUS].temp_cdeg, 0);
    assert_false(t.last_status.temp_known);
    /* stopped: the unit reads none, whatever the last window had */
    spy_temp_known = true;
    t.serial.tx_len = 0;
    run_ms(100 * 20);
    cmd = (struct tlm_command){.type = TLM_TYPE_STOP};
    push_command(&cmd, 4);
    cmd = (struct tlm_command){.type = TLM_TYPE_STATUS_REQUEST};
    push_command(&cmd, 5);
    t.status = 0;
    run_ms(30);
    decode_output();
    assert_int_equal(spied_count, 3);
    assert_int_equal(t.status, 1);
    assert_false(t.last_status.running);
    assert_false(t.last_status.temp_known);
    assert_int_equal(t.last_status.temp_cdeg, 0);
}

/* The window mode's process noise: sliding mode with Q = 0 runs the Kalman filter
 * with `auto` (a sliding estimate is for a plate that may move), tumbling mode with Q = 0 the
 * paper's static windows; a process noise chosen after the mode wins (Q = 0 in sliding mode
 * by choice), and a fixed Q survives a change of mode. */
static void test_sliding_mode_defaults_to_auto(void **state) {
    (void)state;
    assert_false(t.app.estimator.cfg.kalman_process_noise_auto); /* boot: tumbling, Q = 0 */
    assert_int_equal(tof_app_set_window(&t.app, 50, true), ATTITUDE_ERR_NONE);
    assert_true(t.app.estimator.cfg.kalman_process_noise_auto);
    assert_true(t.app.estimator.kalman.process_noise);
    assert_int_equal(tof_app_set_process_noise(&t.app, 0u, 0u, false), ATTITUDE_ERR_NONE);
    assert_false(t.app.estimator.cfg.kalman_process_noise_auto); /* chosen: Q = 0 */
    assert_false(t.app.estimator.kalman.process_noise);
    assert_int_equal(tof_app_set_window(&t.app, 100, false), ATTITUDE_ERR_NONE);
    assert_false(t.app.estimator.cfg.kalman_process_noise_auto);
    assert_int_equal(tof_app_set_process_noise(&t.app, 2000000u, 500000u, false),
                     ATTITUDE_ERR_NONE);
    assert_int_equal(tof_app_set_window(&t.app, 50, true), ATTITUDE_ERR_NONE);
    assert_false(t.app.estimator.cfg.kalman_process_noise_auto); /* a fixed Q is kept */
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[1], 10000u);
    /* the replay configuration (host_sim, the QEMU replay image) takes the same default */
    static struct tof_app_config cfg;
    assert_int_equal(tof_app_config_for_replay(&cfg, 30000, 20, 100, true, VL53_DISTANCE_SHORT),
                     HAL_OK);
    assert_true(cfg.estimator.kalman_process_noise_auto);
    assert_int_equal(tof_app_config_for_replay(&cfg, 30000, 20, 100, false, VL53_DISTANCE_SHORT),
                     HAL_OK);
    assert_false(cfg.estimator.kalman_process_noise_auto);
}

/* Set-process-noise reaches the application and the Kalman filter runs the new Q (the
 * intensities times the 20 ms period, as --process-noise QD,QT gives them at init); a value
 * the estimator refuses is nacked with its own code and changes nothing. */
static void test_set_process_noise_changes_the_filters_q(void **state) {
    (void)state;
    assert_false(t.app.estimator.kalman.process_noise); /* the default: Q = 0 */
    struct tlm_command cmd = {.type = TLM_TYPE_SET_PROCESS_NOISE};
    cmd.u.process_noise.qd_um2_per_s = 2000000u; /* 2 mm²/s */
    cmd.u.process_noise.qt_um2_per_s = 500000u;  /* 0.5 mm²/s */
    push_command(&cmd, 1);
    run_ms(100);
    decode_output();
    assert_int_equal(t.acks, 1);
    assert_int_equal(t.nacks, 0);
    assert_int_equal(t.last_ack_command, TLM_TYPE_SET_PROCESS_NOISE);
    /* Q per row: 2 mm²/s · 0.02 s = 0.04 mm², 0.5 mm²/s · 0.02 s = 0.01 mm² */
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[0], 40000u);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[1], 10000u);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[2], 10000u);
    assert_true(t.app.estimator.kalman.process_noise);
    fix_q32_t q[KALMAN_STATES];
    kalman_process_noise(&t.app.estimator.kalman, q);
    assert_int_equal(q[0], (fix_q32_t)(((40000ll << 32) + 500000) / 1000000)); /* rounded */
    assert_int_equal(q[1], (fix_q32_t)(((10000ll << 32) + 500000) / 1000000));
    assert_int_equal(q[2], q[1]);

    /* 1 µm²/s is 0.02 µm² per row: it would round to Q = 0, a silent change of setting */
    cmd.u.process_noise.qd_um2_per_s = 1u;
    push_command(&cmd, 2);
    /* auto: accepted (the host builds the tracking form, as the flight image does) */
    cmd.u.process_noise.qd_um2_per_s = 0u;
    cmd.u.process_noise.qt_um2_per_s = 0u;
    cmd.u.process_noise.flags = TLM_PROCESS_NOISE_AUTO;
    push_command(&cmd, 3);
    t.serial.tx_len = 0; /* decode only what answers commands 2 and 3 */
    t.acks = 0;
    run_ms(100);
    decode_output();
    assert_int_equal(t.nacks, 1);
    assert_int_equal(t.last_nack_result, TLM_RESULT_OUT_OF_RANGE);
    assert_int_equal(t.last_nack_error, ATTITUDE_ERR_KALMAN_PROCESS_NOISE); /* unchanged */
    assert_int_equal(t.acks, 1);
    assert_true(t.app.estimator.cfg.kalman_process_noise_auto);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[0], 0u);
    assert_int_equal(t.link.commands_refused, 1);
}

/* The application refuses what the estimator refuses, before it touches the state: the
 * filter keeps its Q and the windows their rows. */
static void test_refused_process_noise_changes_nothing(void **state) {
    (void)state;
    assert_int_equal(tof_app_set_process_noise(&t.app, 3000000u, 0u, false), ATTITUDE_ERR_NONE);
    run_ms(40 * 20);
    static struct attitude_state before;
    memcpy(&before, &t.app.estimator, sizeof before);
    assert_true(before.rows > 0u);
    /* 0.02 µm² per row for either intensity: each would round to Q = 0 */
    assert_int_equal(tof_app_set_process_noise(&t.app, 1u, 0u, false),
                     ATTITUDE_ERR_KALMAN_PROCESS_NOISE);
    assert_int_equal(tof_app_set_process_noise(&t.app, 0u, 1u, true),
                     ATTITUDE_ERR_KALMAN_PROCESS_NOISE);
    assert_memory_equal(&before, &t.app.estimator, sizeof before);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[0], 60000u);
}

/* The record storage of the save tests: outside `t`, so it survives the "reboot" (setup). */
static struct sim_flash saved_flash;
static struct tof_record_store saved_store;

/* Boot the link with the record storage, as tof_app_main() starts its service. */
static void boot_with_records(void) {
    sim_flash_power_on(&saved_flash);
    assert_int_equal(tof_record_init(&saved_store, sim_flash_hal(&saved_flash), 0u, 1u), HAL_OK);
    tof_link_set_records(&t.link, &tof_link_storage, &saved_store);
    tof_link_service_ops.start(&t.link, &t.app);
    decode_output();
    assert_int_equal(t.status, 1);
    t.serial.tx_len = 0;
    t.status = 0;
}

static void test_save_then_reset_brings_the_settings_back(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&saved_flash, 2u, 2048u), HAL_OK);
    boot_with_records();
    assert_int_equal(t.last_status.record, TLM_RECORD_NONE);
    assert_int_equal(t.last_status.calibration, TLM_CAL_NONE);
    struct tlm_command cmd = {.type = TLM_TYPE_SET_WINDOW};
    cmd.u.set_window.window_n = 50u;
    cmd.u.set_window.mode = TLM_WINDOW_SLIDING;
    push_command(&cmd, 1);
    cmd = (struct tlm_command){.type = TLM_TYPE_SELECT_ESTIMATOR, .u.estimator = 2u};
    push_command(&cmd, 2);
    cmd = (struct tlm_command){.type = TLM_TYPE_RAW_STREAM, .u.raw_enable = true};
    push_command(&cmd, 3);
    cmd = (struct tlm_command){.type = TLM_TYPE_SET_PROCESS_NOISE};
    cmd.u.process_noise.qd_um2_per_s = 2000000u;
    cmd.u.process_noise.qt_um2_per_s = 500000u;
    push_command(&cmd, 4);
    cmd = (struct tlm_command){.type = TLM_TYPE_SAVE};
    push_command(&cmd, 5);
    run_ms(100);
    decode_output();
    assert_int_equal(t.nacks, 0);
    assert_int_equal(t.acks, 5);
    assert_int_equal(t.last_ack_command, TLM_TYPE_SAVE);

    setup(NULL); /* a reset: the compiled defaults, then the saved settings */
    assert_int_equal(t.app.estimator.cfg.window, 100u);
    boot_with_records();
    assert_int_equal(t.last_status.record, TLM_RECORD_LOADED);
    assert_int_equal(t.last_status.window_n, 50u);
    assert_int_equal(t.last_status.mode, TLM_WINDOW_SLIDING);
    assert_int_equal(t.last_status.estimator, 2u);
    assert_true(t.last_status.raw_stream);
    assert_true(t.last_status.running);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[0], 40000u);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[1], 10000u);

    /* saved again after the reset: the process noise in force is kept, not forgotten */
    cmd = (struct tlm_command){.type = TLM_TYPE_SAVE};
    push_command(&cmd, 6);
    run_ms(50);
    setup(NULL);
    boot_with_records();
    assert_int_equal(t.last_status.record, TLM_RECORD_LOADED);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[0], 40000u);

    /* damaged (one payload bit): the defaults, and the status frame says why */
    const uint16_t page = (uint16_t)(saved_flash.mem[0][0] != 0xFFu ? 0u : 1u);
    sim_flash_poke(&saved_flash, page, 12u + 5u, 0x01u);
    setup(NULL);
    boot_with_records();
    assert_int_equal(t.last_status.record, TLM_RECORD_CORRUPT);
    assert_int_equal(t.last_status.calibration, TLM_CAL_CORRUPT);
    assert_int_equal(t.last_status.window_n, 100u);
    assert_int_equal(t.last_status.mode, TLM_WINDOW_TUMBLING);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[0], 0u);
}

/* Fresh record storage holding a calibration of offsets +1.5, -0.8, -1.2, +0.6 mm (no gains)
 * bound as `b` says. */
static void store_offsets_calibration(const struct tof_cal_binding *b) {
    const struct calibration_head cal = {.calibrated = true,
                                         .offset_um = {1500, -800, -1200, 600},
                                         .offset_sd_um = {30, 30, 30, 30}};
    uint8_t section[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
    assert_int_equal(tof_cal_encode(&cal, false, b, section), HAL_OK);
    assert_int_equal(tof_section_save(&saved_store, section), HAL_OK);
}

static void open_saved_records(void) {
    assert_int_equal(sim_flash_init(&saved_flash, 2u, 2048u), HAL_OK);
    assert_int_equal(tof_record_init(&saved_store, sim_flash_hal(&saved_flash), 0u, 1u), HAL_OK);
}

/* set-arm and set-period: in force at once (the sensors re-timed and read at the
 * new rate with no sample missing, Q per row rescaled to keep its intensity, the calibration
 * bound to the old timing budget no longer applied, and the status frame says so), refused
 * where no timing fits, kept by `save` and in force after a reset. */
static void test_arm_and_period_by_command_and_kept(void **state) {
    (void)state;
    open_saved_records();
    const struct tof_cal_binding b = tof_cal_binding_of(&t.app.cfg); /* budget 15 ms */
    store_offsets_calibration(&b);
    boot_with_records();
    assert_int_equal(t.last_status.calibration, TLM_CAL_APPLIED);
    assert_int_equal(t.last_status.arm_um, 30000u);
    assert_int_equal(t.last_status.period_ms, 20u);

    struct tlm_command cmd = {.type = TLM_TYPE_SET_PROCESS_NOISE};
    cmd.u.process_noise.qd_um2_per_s = 2000000u; /* 40000 um² per 20 ms row */
    cmd.u.process_noise.qt_um2_per_s = 500000u;
    push_command(&cmd, 1);
    cmd = (struct tlm_command){.type = TLM_TYPE_SET_ARM, .u.arm_um = 45250u};
    push_command(&cmd, 2);
    cmd = (struct tlm_command){.type = TLM_TYPE_SET_PERIOD, .u.period_ms = 33u};
    push_command(&cmd, 3);
    cmd = (struct tlm_command){.type = TLM_TYPE_STATUS_REQUEST};
    push_command(&cmd, 4);
    run_ms(400);
    decode_output();
    assert_int_equal(t.nacks, 0);
    assert_int_equal(t.acks, 4);
    assert_int_equal(t.last_status.arm_um, 45250u);
    assert_int_equal(t.last_status.period_ms, 33u);
    assert_int_equal(t.last_status.calibration, TLM_CAL_OTHER_BUDGET); /* made at budget 15 */
    assert_false(t.app.estimator.cfg.calibration.calibrated);
    assert_int_equal(t.app.estimator.cfg.arm_um, 45250);
    assert_int_equal(t.app.estimator.cfg.period_us, 33000u);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[0], 66000u); /* 2 mm²/s */
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[1], 16500u);
    assert_int_equal(t.app.cfg.timing.budget_ms, 20u); /* the longest short-mode fit */
    assert_int_equal(t.app.cfg.timing.inter_measurement_ms, 33u);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_int_equal(vl53_array_sensor(&t.app.array, i)->timing.inter_measurement_ms, 33u);
    }
    /* the sensors run at the new rate: 3.3 s is 100 slots, every one assembled complete */
    const uint32_t samples = t.app.counters.samples;
    const uint32_t incomplete = t.app.assembler.counters.incomplete;
    run_ms(3300);
    assert_in_range(t.app.counters.samples - samples, 99u, 101u);
    assert_int_equal(t.app.assembler.counters.incomplete, incomplete);

    /* no short-mode timing fits 18 ms (15 ms budget + 4 ms margin): refused, nothing changed */
    t.serial.tx_len = 0;
    t.acks = t.nacks = 0;
    cmd = (struct tlm_command){.type = TLM_TYPE_SET_PERIOD, .u.period_ms = 18u};
    push_command(&cmd, 5);
    run_ms(50);
    decode_output();
    assert_int_equal(t.nacks, 1);
    assert_int_equal(t.last_nack_result, TLM_RESULT_OUT_OF_RANGE);
    assert_int_equal(t.app.cfg.timing.inter_measurement_ms, 33u);

    cmd = (struct tlm_command){.type = TLM_TYPE_SAVE};
    push_command(&cmd, 6);
    run_ms(100);
    setup(NULL); /* a reset: the compiled defaults, then the saved settings */
    assert_int_equal(t.app.cfg.timing.inter_measurement_ms, 20u);
    boot_with_records();
    assert_int_equal(t.last_status.record, TLM_RECORD_LOADED);
    assert_int_equal(t.last_status.arm_um, 45250u);
    assert_int_equal(t.last_status.period_ms, 33u);
    assert_int_equal(t.last_status.calibration, TLM_CAL_OTHER_BUDGET);
    assert_int_equal(t.app.estimator.cfg.kalman_process_noise_um2[0], 66000u);
    const uint32_t after_boot = t.app.counters.samples;
    run_ms(3300);
    assert_in_range(t.app.counters.samples - after_boot, 98u, 101u);
}

static void test_settings_the_image_refuses_fall_back_to_defaults(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&saved_flash, 2u, 2048u), HAL_OK);
    assert_int_equal(tof_record_init(&saved_store, sim_flash_hal(&saved_flash), 0u, 1u), HAL_OK);
    const struct tof_settings s = {.window = 50u, .sliding = true, .primary = 3u, .running = true};
    assert_int_equal(tof_settings_save(&saved_store, &s), HAL_OK);
    t.app.estimator.cfg.estimators &= (uint8_t)~ATTITUDE_EST_BIT(ATTITUDE_EST_MEAN);
    boot_with_records();
    assert_int_equal(t.last_status.record, TLM_RECORD_REJECTED);
    assert_int_equal(t.last_status.window_n, 100u); /* the window applied first is undone */
    assert_int_equal(t.last_status.mode, TLM_WINDOW_TUMBLING);
}

/* A calibration section saved on this head in this mode is in force after boot and the status
 * frame says so; one of another mode is not, and the status frame says why. */
static void test_a_saved_calibration_is_applied_at_boot(void **state) {
    (void)state;
    open_saved_records();
    struct tof_cal_binding b = tof_cal_binding_of(&t.app.cfg);
    store_offsets_calibration(&b);
    assert_false(t.app.estimator.cfg.calibration.calibrated);
    boot_with_records();
    assert_int_equal(t.last_status.calibration, TLM_CAL_APPLIED);
    assert_int_equal(t.last_status.record, TLM_RECORD_NONE); /* no settings section */
    assert_true(t.app.estimator.cfg.calibration.calibrated);
    assert_int_equal(t.app.estimator.cfg.calibration.offset_um[1], -800);

    b.budget_ms = (uint16_t)(b.budget_ms * 2u);
    store_offsets_calibration(&b);
    setup(NULL);
    boot_with_records();
    assert_int_equal(t.last_status.calibration, TLM_CAL_OTHER_BUDGET);
    assert_false(t.app.estimator.cfg.calibration.calibrated);
}

/* write-calibration saves the section and puts it in force at once; read-calibration gives it
 * back as stored; one made in another configuration, or damaged, is refused and changes
 * nothing; the next boot finds what was written. */
static void test_write_and_read_calibration_by_command(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&saved_flash, 2u, 2048u), HAL_OK);
    boot_with_records();
    assert_int_equal(t.last_status.calibration, TLM_CAL_NONE);
    struct tlm_command cmd = {.type = TLM_TYPE_READ_CALIBRATION};
    push_command(&cmd, 1);
    run_ms(30);
    decode_output();
    assert_int_equal(t.calibrations, 1);
    assert_int_equal(t.last_calibration.state, TLM_CAL_NONE);
    assert_int_equal(t.last_calibration.section[0], 0);

    const struct calibration_head cal = {.calibrated = true,
                                         .offset_um = {1500, -800, -1200, 600},
                                         .gain_ppm = {1000, -2000, 0, 500},
                                         .offset_sd_um = {30, 31, 32, 33},
                                         .gain_sd_ppm = {100, 100, 100, 100},
                                         .offset_gain_corr_q15 = {-30000, -30000, 0, 5},
                                         .thermal = true,
                                         .cal_temp_cdeg = 2150,
                                         .temp_coeff_nm_per_c = {12000, -7000, 0, 30000},
                                         .temp_coeff_sd_nm_per_c = {800, 900, 1000, 1100}};
    struct tof_cal_binding b = tof_cal_binding_of(&t.app.cfg);
    b.mode = (uint8_t)(b.mode == 1u ? 2u : 1u); /* another mode: refused */
    cmd = (struct tlm_command){.type = TLM_TYPE_WRITE_CALIBRATION};
    assert_int_equal(tof_cal_encode(&cal, true, &b, cmd.u.cal_section), HAL_OK);
    t.serial.tx_len = 0;
    push_command(&cmd, 2);
    b = tof_cal_binding_of(&t.app.cfg);
    assert_int_equal(tof_cal_encode(&cal, true, &b, cmd.u.cal_section), HAL_OK);
    cmd.u.cal_section[4u + 8u + 3u] = 0x7Fu; /* offset A out of bounds: refused */
    push_command(&cmd, 3);
    run_ms(30);
    decode_output();
    assert_int_equal(t.nacks, 2);
    assert_false(t.app.estimator.cfg.calibration.calibrated);
    assert_int_equal(t.last_nack_result, TLM_RESULT_OUT_OF_RANGE);

    assert_int_equal(tof_cal_encode(&cal, true, &b, cmd.u.cal_section), HAL_OK);
    t.serial.tx_len = 0;
    t.calibrations = t.nacks = t.acks = 0;
    push_command(&cmd, 4);
    cmd = (struct tlm_command){.type = TLM_TYPE_READ_CALIBRATION};
    push_command(&cmd, 5);
    cmd = (struct tlm_command){.type = TLM_TYPE_STATUS_REQUEST};
    push_command(&cmd, 6);
    run_ms(30);
    decode_output();
    assert_int_equal(t.nacks, 0);
    assert_int_equal(t.acks, 3);
    assert_true(t.app.estimator.cfg.calibration.calibrated);
    assert_int_equal(t.app.estimator.cfg.calibration.gain_ppm[1], -2000);
    assert_true(t.app.estimator.cfg.calibration.thermal); /* the thermal fields came along */
    assert_int_equal(t.app.estimator.cfg.calibration.cal_temp_cdeg, 2150);
    assert_int_equal(t.app.estimator.cfg.calibration.temp_coeff_nm_per_c[3], 30000);
    assert_int_equal(t.app.estimator.cfg.calibration.temp_coeff_sd_nm_per_c[1], 900u);
    assert_int_equal(t.last_status.calibration, TLM_CAL_APPLIED);
    assert_int_equal(t.calibrations, 1);
    assert_int_equal(t.last_calibration.state, TLM_CAL_APPLIED);
    uint8_t want[TOF_CAL_WIRE_SIZE]; /* read back in the version-4 form it was sent in */
    assert_int_equal(tof_cal_encode(&cal, true, &b, want), HAL_OK);
    assert_memory_equal(t.last_calibration.section, want, sizeof want);

    setup(NULL); /* a reset: the calibration comes back from the record */
    boot_with_records();
    assert_int_equal(t.last_status.calibration, TLM_CAL_APPLIED);
    assert_int_equal(t.app.estimator.cfg.calibration.offset_um[0], 1500);
    assert_int_equal(t.app.estimator.cfg.calibration.temp_coeff_nm_per_c[0], 12000);
}

/* re-zero at a parallel plate (every sensor reads 100 mm): refused uncalibrated; with a
 * calibration in force, N samples refit the offsets so every corrected reading is the same
 * (attitude zero), their sum kept, gains kept, saved and in force; the raw stream stays off. */
static void test_rezero_refits_the_offsets(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&saved_flash, 2u, 2048u), HAL_OK);
    boot_with_records();
    struct tlm_command cmd = {.type = TLM_TYPE_REZERO, .u.rezero_samples = 50};
    push_command(&cmd, 1);
    run_ms(30);
    decode_output();
    assert_int_equal(t.nacks, 1);
    assert_int_equal(t.last_nack_result, TLM_RESULT_STATE); /* nothing to keep the gains of */

    const struct calibration_head cal = {.calibrated = true,
                                         .offset_um = {1500, -800, -1200, 600},
                                         .gain_ppm = {10000, -10000, 0, 5000},
                                         .offset_sd_um = {40, 40, 40, 40},
                                         .gain_sd_ppm = {300, 300, 300, 300}};
    cmd = (struct tlm_command){.type = TLM_TYPE_WRITE_CALIBRATION};
    const struct tof_cal_binding b = tof_cal_binding_of(&t.app.cfg);
    assert_int_equal(tof_cal_encode(&cal, true, &b, cmd.u.cal_section), HAL_OK);
    push_command(&cmd, 2);
    cmd = (struct tlm_command){.type = TLM_TYPE_REZERO, .u.rezero_samples = 50};
    push_command(&cmd, 3);
    /* a calibration while the re-zero runs: refused as busy (its result would overwrite
     * this one), never acknowledged and then lost */
    cmd = (struct tlm_command){.type = TLM_TYPE_WRITE_CALIBRATION};
    assert_int_equal(tof_cal_encode(&cal, true, &b, cmd.u.cal_section), HAL_OK);
    push_command(&cmd, 4);
    t.raw = t.calibrations = 0;
    run_ms(50u * 20u + 200u);
    decode_output();
    assert_int_equal(t.acks, 2); /* the calibration and the re-zero; not the one during it */
    assert_int_equal(t.last_nack_result, TLM_RESULT_BUSY);
    assert_int_equal(t.raw, 0);
    assert_int_equal(t.calibrations, 1);
    assert_int_equal(t.last_calibration.state, TLM_CAL_APPLIED);
    struct calibration_head now;
    tof_app_get_calibration(&t.app, &now);
    /* x̂ = Σ(100000 − o_i) / Σ g_i = 399900 / 4.005 = 99850.19 µm; o_i' = 100000 − g_i·x̂ */
    const int32_t want[4] = {100000 - 100848, 100000 - 98852, 100000 - 99850, 100000 - 100349};
    int32_t sum = 0;
    for (unsigned i = 0; i < 4u; ++i) {
        assert_true(now.offset_um[i] >= want[i] - 1 && now.offset_um[i] <= want[i] + 1);
        assert_int_equal(now.gain_ppm[i], cal.gain_ppm[i]);
        /* noise-free whole-mm readings: the mean's quantisation floor (1 mm)²/12/50 = 1666
         * µm², halved, plus four of them and four old sd² (1600) over 16: √1649 = 40 µm */
        assert_int_equal(now.offset_sd_um[i], 40);
        sum += now.offset_um[i];
    }
    assert_true(sum >= 100 - 2 && sum <= 100 + 2); /* Σ o_i kept */
    setup(NULL);                                   /* saved: back after a reset */
    boot_with_records();
    assert_int_equal(t.last_status.calibration, TLM_CAL_APPLIED);
    assert_int_equal(t.app.estimator.cfg.calibration.offset_um[2], now.offset_um[2]);
}

/* A thermal calibration re-zeroed (firmware/rezero.h): refitted at the samples' temperature,
 * which becomes the calibration temperature, the coefficients kept and the sum of the offsets
 * in force at that temperature kept; with no temperature the re-zero is rejected and the
 * calibration in force kept. */
static int16_t head_temp_cdeg;

static int read_head_temp(void *ctx, int16_t *cdeg) {
    (void)ctx;
    *cdeg = head_temp_cdeg;
    return HAL_OK;
}

static const struct hal_temp_ops head_temp_ops = {.read_cdeg = read_head_temp};

static void test_rezero_of_a_thermal_calibration_takes_the_temperature(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&saved_flash, 2u, 2048u), HAL_OK);
    boot_with_records();
    t.platform.temp = (struct hal_temp){.ops = NULL, .ctx = NULL}; /* no sensor */
    const struct calibration_head cal = {.calibrated = true,
                                         .offset_um = {1500, -800, -1200, 600},
                                         .offset_sd_um = {40, 40, 40, 40},
                                         .thermal = true,
                                         .cal_temp_cdeg = 2000,
                                         .temp_coeff_nm_per_c = {10000, 20000, 30000, 40000},
                                         .temp_coeff_sd_nm_per_c = {1000, 1000, 1000, 1000}};
    struct tlm_command cmd = {.type = TLM_TYPE_WRITE_CALIBRATION};
    const struct tof_cal_binding b = tof_cal_binding_of(&t.app.cfg);
    assert_int_equal(tof_cal_encode(&cal, false, &b, cmd.u.cal_section), HAL_OK);
    push_command(&cmd, 1);
    cmd = (struct tlm_command){.type = TLM_TYPE_REZERO, .u.rezero_samples = 50};
    push_command(&cmd, 2);
    run_ms(50u * 20u + 200u);
    decode_output();
    assert_int_equal(t.acks, 2);
    assert_int_equal(t.calibrations, 1);
    assert_int_equal(t.last_calibration.state, TLM_CAL_REJECTED);
    struct calibration_head now;
    tof_app_get_calibration(&t.app, &now);
    assert_int_equal(now.offset_um[0], 1500); /* kept */
    assert_int_equal(now.cal_temp_cdeg, 2000);

    head_temp_cdeg = -1575; /* -15.75 degC: 35.75 degC below the calibration's */
    t.platform.temp = (struct hal_temp){.ops = &head_temp_ops, .ctx = NULL};
    push_command(&cmd, 3);
    t.serial.tx_len = 0;
    t.calibrations = 0;
    run_ms(50u * 20u + 200u);
    decode_output();
    assert_int_equal(t.calibrations, 1);
    assert_int_equal(t.last_calibration.state, TLM_CAL_APPLIED);
    tof_app_get_calibration(&t.app, &now);
    assert_true(now.thermal);
    assert_int_equal(now.cal_temp_cdeg, -1575);
    assert_int_equal(now.temp_coeff_nm_per_c[3], 40000);
    /* the offsets in force at -15.75 degC summed 100 + (-358 - 715 - 1073 - 1430) um */
    int32_t sum = 0;
    for (unsigned i = 0; i < 4u; ++i) {
        sum += now.offset_um[i];
    }
    assert_true(sum >= -3476 - 2 && sum <= -3476 + 2);
    /* and read back so */
    assert_int_equal(t.last_calibration.section[4 + 80], (uint8_t)((uint16_t)-1575 & 0xFFu));
    assert_int_equal(t.last_calibration.section[4 + 81], (uint8_t)((uint16_t)-1575 >> 8));
}

/* The arm is part of the calibration: one written at 30 mm is bound to it; set-arm 40 takes
 * it out of force (the status frame after the ack says other-arm, the head uncalibrated),
 * set-arm 30 puts it back. */
static void test_set_arm_takes_the_calibration_out_of_force(void **state) {
    (void)state;
    assert_int_equal(sim_flash_init(&saved_flash, 2u, 2048u), HAL_OK);
    boot_with_records();
    const struct calibration_head cal = {.calibrated = true,
                                         .offset_um = {1500, -800, -1200, 600},
                                         .offset_sd_um = {40, 40, 40, 40}};
    struct tlm_command cmd = {.type = TLM_TYPE_WRITE_CALIBRATION};
    const struct tof_cal_binding b = tof_cal_binding_of(&t.app.cfg);
    assert_int_equal(tof_cal_encode(&cal, false, &b, cmd.u.cal_section), HAL_OK);
    push_command(&cmd, 1);
    cmd = (struct tlm_command){.type = TLM_TYPE_SET_ARM, .u.arm_um = 40000u};
    push_command(&cmd, 2);
    run_ms(100);
    decode_output();
    assert_int_equal(t.nacks, 0);
    assert_int_equal(t.acks, 2);
    assert_int_equal(t.last_status.arm_um, 40000u);
    assert_int_equal(t.last_status.calibration, TLM_CAL_OTHER_ARM);
    assert_false(t.app.estimator.cfg.calibration.calibrated);
    cmd = (struct tlm_command){.type = TLM_TYPE_SET_ARM, .u.arm_um = 30000u};
    push_command(&cmd, 3);
    run_ms(100);
    decode_output();
    assert_int_equal(t.last_status.calibration, TLM_CAL_APPLIED);
    assert_true(t.app.estimator.cfg.calibration.calibrated);
}

/* A link without storage (a board that names no tof_link_storage) refuses `save` and
 * write-calibration as state errors, never acknowledging what it could not keep; the
 * configuration's calibration stays in force. */
static void test_save_without_storage_is_refused(void **state) {
    (void)state;
    tof_link_service_ops.start(&t.link, &t.app);
    struct tlm_command cmd = {.type = TLM_TYPE_SAVE};
    push_command(&cmd, 1);
    run_ms(50);
    decode_output();
    assert_int_equal(t.last_status.record, TLM_RECORD_NO_STORAGE);
    assert_int_equal(t.last_status.calibration, TLM_CAL_NO_STORAGE);
    assert_int_equal(t.nacks, 1);
    assert_int_equal(t.last_nack_result, TLM_RESULT_STATE);
    assert_int_equal(t.last_nack_error, HAL_ERR_STATE);
    cmd = (struct tlm_command){.type = TLM_TYPE_WRITE_CALIBRATION};
    struct calibration_head cal = {.calibrated = true, .offset_sd_um = {30, 30, 30, 30}};
    const struct tof_cal_binding bind = tof_cal_binding_of(&t.app.cfg);
    assert_int_equal(tof_cal_encode(&cal, false, &bind, cmd.u.cal_section), HAL_OK);
    push_command(&cmd, 2);
    run_ms(50);
    decode_output(); /* the whole output again: the save's nack, then both */
    assert_int_equal(t.nacks, 3);
    assert_int_equal(t.last_nack_result, TLM_RESULT_STATE);
    assert_int_equal(t.last_nack_error, HAL_ERR_STATE);
    assert_false(t.app.estimator.cfg.calibration.calibrated);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_default_windows_report_a_parallel_plate, setup),
        cmocka_unit_test_setup(test_estimate_and_status_frames_carry_the_temperature, setup),
        cmocka_unit_test_setup(test_rezero_of_a_thermal_calibration_takes_the_temperature, setup),
        cmocka_unit_test_setup(test_commands_are_applied_and_acknowledged, setup),
        cmocka_unit_test_setup(test_a_retried_command_is_answered_but_applied_once, setup),
        cmocka_unit_test_setup(test_health_is_rate_limited_and_counts_uart_overruns, setup),
        cmocka_unit_test_setup(test_selecting_an_estimator_that_does_not_run_is_refused, setup),
        cmocka_unit_test_setup(test_primary_is_an_estimator_that_runs, setup_kalman_only),
        cmocka_unit_test_setup(test_stop_silences_estimates_and_raw_stream_sends_samples, setup),
        cmocka_unit_test_setup(test_sensor_hardware_fault_reinits_that_sensor, setup),
        cmocka_unit_test_setup(test_malformed_frames_are_counted_and_refused, setup),
        cmocka_unit_test_setup(test_estimator_errors_pass_up_unchanged, setup),
        cmocka_unit_test_setup(test_main_runs_the_link_as_a_service, setup),
        cmocka_unit_test_setup(test_estimate_frames_carry_the_estimators_sd_and_why,
                               setup_no_target),
        cmocka_unit_test_setup(test_sliding_mode_defaults_to_auto, setup),
        cmocka_unit_test_setup(test_set_process_noise_changes_the_filters_q, setup),
        cmocka_unit_test_setup(test_refused_process_noise_changes_nothing, setup),
        cmocka_unit_test_setup(test_save_then_reset_brings_the_settings_back, setup),
        cmocka_unit_test_setup(test_arm_and_period_by_command_and_kept, setup),
        cmocka_unit_test_setup(test_settings_the_image_refuses_fall_back_to_defaults, setup),
        cmocka_unit_test_setup(test_a_saved_calibration_is_applied_at_boot, setup),
        cmocka_unit_test_setup(test_write_and_read_calibration_by_command, setup),
        cmocka_unit_test_setup(test_rezero_refits_the_offsets, setup),
        cmocka_unit_test_setup(test_set_arm_takes_the_calibration_out_of_force, setup),
        cmocka_unit_test_setup(test_save_without_storage_is_refused, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
