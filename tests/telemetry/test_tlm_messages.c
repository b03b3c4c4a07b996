/*
 * Telemetry messages and commands: byte layouts, encode -> decoder -> parse
 * round trips of every type, every validation rule on both sides, and every
 * command in range, out of range and with the wrong length.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "hal/hal_err.h"
#include "telemetry/tlm_frame.h"
#include "telemetry/tlm_messages.h"
#include "tlm_test_sink.h"

/* --- fixtures ------------------------------------------------------------- */

static struct tlm_estimate sample_estimate(void) {
    return (struct tlm_estimate){.t_ms = 20000,
                                 .window_index = 199,
                                 .estimator = TLM_ESTIMATOR_CONSENSUS,
                                 .status = TLM_STATUS_OK,
                                 .sensors_used = TLM_SENSOR_MASK_ALL,
                                 .alpha_udeg = 1500000,
                                 .beta_udeg = -250000,
                                 .distance_um = 123456000,
                                 .flatness_um = -12,
                                 .alpha_sd_udeg = 270000,
                                 .beta_sd_udeg = 5000,
                                 .distance_sd_um = 1500,
                                 .why = 0,
                                 .temp_known = true,
                                 .temp_cdeg = -1234};
}

static struct tlm_raw_sample sample_raw(void) {
    return (struct tlm_raw_sample){.t_ms = 0x01020304u,
                                   .range_mm = {98, 101, 0, 4000},
                                   .range_status = {0, 4, 0, 7},
                                   .present_mask = 0x0B}; /* A, B, D */
}

static struct tlm_health sample_health(void) {
    struct tlm_health h;
    memset(&h, 0, sizeof h);
    h.uptime_ms = 3600000u;
    h.sensor_state[0] = TLM_HEALTH_HEALTHY;
    h.sensor_state[1] = TLM_HEALTH_SUSPECT;
    h.sensor_state[2] = TLM_HEALTH_LOST;
    h.sensor_state[3] = TLM_HEALTH_RECOVERING;
    /* Distinct values everywhere, so a swapped field cannot go unnoticed. */
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        h.sensor[i].comm_errors = 100u * i + 1u;
        h.sensor[i].timeouts = 100u * i + 2u;
        h.sensor[i].flagged = 100u * i + 3u;
        h.sensor[i].reinits = 100u * i + 4u;
    }
    h.bus = (struct tlm_bus_counters){.addr_nack = 1001,
                                      .data_nack = 1002,
                                      .busy = 1003,
                                      .timeout = 1004,
                                      .stuck = 1005,
                                      .other = 1006,
                                      .recoveries = 1007};
    h.watchdog_resets = 2001;
    h.loop_overruns = 2002;
    h.loop_max_us = 2003;
    h.tx_dropped = 0xFFFFFFFFu;
    h.link = (struct tlm_rx_counters){.frames_ok = 3001,
                                      .bad_crc = 3002,
                                      .bad_length = 3003,
                                      .unknown_type = 3004,
                                      .truncated = 3005,
                                      .out_of_range = 3006,
                                      .discarded_bytes = 3007};
    h.uart_overruns = 4001;
    return h;
}

static struct tlm_status sample_status(void) {
    return (struct tlm_status){.fw_major = 0,
                               .fw_minor = 1,
                               .fw_patch = 2,
                               .uptime_ms = 123456,
                               .window_n = 100,
                               .mode = TLM_WINDOW_SLIDING,
                               .estimator = TLM_ESTIMATOR_KALMAN,
                               .running = true,
                               .raw_stream = false,
                               .period_ms = 20,
                               .record = TLM_RECORD_CORRUPT,
                               .calibration = TLM_CAL_OTHER_MODE,
                               .arm_um = 30000u,
                               .cal_age_s = 90061u,
                               .cal_age = TLM_CAL_AGE_KEPT,
                               .temp_known = true,
                               .temp_cdeg = 4567};
}

/* Decode exactly one accepted frame from `bytes` through a real decoder. */
static struct tlm_frame decode_one(struct recorder *rec, const uint8_t *bytes, size_t len,
                                   uint8_t accept) {
    struct tlm_decoder dec;
    const struct tlm_frame_sink sink = recorder_sink(rec);
    tlm_decoder_init(&dec, tlm_message_types(accept));
    tlm_decoder_feed(&dec, bytes, len, &sink);
    assert_int_equal(rec->frame_count, 1);
    assert_int_equal(dec.counters.frames_ok, 1);
    assert_int_equal(dec.counters.discarded_bytes, 0);
    assert_int_equal(tlm_decoder_pending(&dec), 0);
    return recorder_frame(rec, 0);
}

/* Re-frame a payload (e.g. after patching a byte) with a valid CRC. */
static struct tlm_frame raw_frame(uint8_t type, const uint8_t *payload, uint8_t length) {
    return (struct tlm_frame){.type = type, .seq = 0, .length = length, .payload = payload};
}

/* --- layouts -------------------------------------------------------------- */

static void test_estimate_layout_matches_reference_bytes(void **state) {
    (void)state;
    /* Computed independently in Python with struct.pack('<IIBBBiiiiiiiQBh', ...) and
     * tools/tof_telemetry.py's encode_frame(). */
    static const uint8_t expected[] = {
        0xA5, 0x5A, 0x32, 0x01, 0x2A, 0x20, 0x4E, 0x00, 0x00, 0xC7, 0x00, 0x00, 0x00, 0x00,
        0x00, 0x0F, 0x60, 0xE3, 0x16, 0x00, 0x70, 0x2F, 0xFC, 0xFF, 0x00, 0xCA, 0x5B, 0x07,
        0xF4, 0xFF, 0xFF, 0xFF, 0xB0, 0x1E, 0x04, 0x00, 0x88, 0x13, 0x00, 0x00, 0xDC, 0x05,
        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x2E, 0xFB, /* -12.34 C */
        0x98, 0x4F};
    const struct tlm_estimate est = sample_estimate();
    uint8_t out[TLM_FRAME_MAX];
    assert_int_equal(tlm_encode_estimate(42, &est, out, sizeof out), sizeof expected);
    assert_memory_equal(out, expected, sizeof expected);
}

static void test_every_type_has_its_documented_length(void **state) {
    (void)state;
    uint8_t out[TLM_FRAME_MAX];
    const struct tlm_estimate est = sample_estimate();
    const struct tlm_raw_sample raw = sample_raw();
    const struct tlm_health health = sample_health();
    const struct tlm_ack ack = {.echo_seq = 1, .command = TLM_TYPE_START, .result = 0};
    const struct tlm_status status = sample_status();
    assert_int_equal(tlm_encode_estimate(0, &est, out, sizeof out), 50 + 7);
    assert_int_equal(tlm_encode_raw_sample(0, &raw, out, sizeof out), 17 + 7);
    assert_int_equal(tlm_encode_health(0, &health, out, sizeof out), 148 + 7);
    assert_int_equal(tlm_encode_ack(0, &ack, out, sizeof out), 4 + 7);
    assert_int_equal(tlm_encode_status(0, &status, out, sizeof out), 30 + 7);
    assert_int_equal(tlm_type_payload_length(TLM_TYPE_HEALTH, TLM_ACCEPT_TELEMETRY), 148);
    assert_int_equal(tlm_type_payload_length(TLM_TYPE_HEALTH, TLM_ACCEPT_COMMANDS), -1);
    assert_int_equal(tlm_type_payload_length(TLM_TYPE_SET_WINDOW, TLM_ACCEPT_ALL), 3);
    assert_int_equal(tlm_type_payload_length(0x00, TLM_ACCEPT_ALL), -1);
    assert_int_equal(tlm_type_payload_length(TLM_TYPE_SET_PROCESS_NOISE, TLM_ACCEPT_COMMANDS), 9);
    assert_int_equal(tlm_type_payload_length(TLM_TYPE_SET_PROCESS_NOISE, TLM_ACCEPT_TELEMETRY), -1);
    assert_int_equal(tlm_type_payload_length(TLM_TYPE_SAVE, TLM_ACCEPT_COMMANDS), 0);
    assert_int_equal(tlm_type_payload_length(TLM_TYPE_SET_ARM, TLM_ACCEPT_COMMANDS), 4);
    assert_int_equal(tlm_type_payload_length(TLM_TYPE_SET_PERIOD, TLM_ACCEPT_COMMANDS), 2);
    assert_int_equal(tlm_type_payload_length(0x8B, TLM_ACCEPT_ALL), -1);
    assert_true(tlm_type_is_command(TLM_TYPE_RAW_STREAM));
    assert_true(tlm_type_is_command(TLM_TYPE_SET_PROCESS_NOISE));
    assert_false(tlm_type_is_command(TLM_TYPE_ACK));
}

static void test_status_layout(void **state) {
    (void)state;
    const struct tlm_status status = sample_status();
    uint8_t out[TLM_FRAME_MAX];
    assert_int_equal(tlm_encode_status(3, &status, out, sizeof out), 37);
    const uint8_t *p = &out[TLM_HEADER_SIZE];
    const uint8_t expected[] = {0,    1,    2,    TLM_PROTOCOL_VERSION,
                                0x40, 0xE2, 0x01, 0x00,
                                100,  0,    1,    2,
                                1,    0,    20,   0,
                                2,    5,    0x30, 0x75,
                                0x00, 0x00, /* arm 30000 um */
                                0xCD, 0x5F, 0x01, 0x00,
                                1,                 /* calibration age 90061 s, kept */
                                1,    0xD7, 0x11}; /* 45.67 degC */
    assert_memory_equal(p, expected, sizeof expected);
    /* an arm or a period outside the protocol's ranges is not encoded */
    struct tlm_status bad = status;
    bad.arm_um = TLM_ARM_MIN_UM - 1u;
    assert_int_equal(tlm_encode_status(3, &bad, out, sizeof out), HAL_ERR_INVALID);
    bad = status;
    bad.period_ms = 0u;
    assert_int_equal(tlm_encode_status(3, &bad, out, sizeof out), HAL_ERR_INVALID);
    /* a temperature beyond -100..200 degC, or one not known with a value */
    bad = status;
    bad.temp_cdeg = TLM_TEMP_MAX_CDEG + 1;
    assert_int_equal(tlm_encode_status(3, &bad, out, sizeof out), HAL_ERR_INVALID);
    bad.temp_cdeg = TLM_TEMP_MIN_CDEG - 1;
    assert_int_equal(tlm_encode_status(3, &bad, out, sizeof out), HAL_ERR_INVALID);
    bad = status;
    bad.temp_known = false;
    assert_int_equal(tlm_encode_status(3, &bad, out, sizeof out), HAL_ERR_INVALID);
    bad.temp_cdeg = 0;
    assert_int_equal(tlm_encode_status(3, &bad, out, sizeof out), 37);
    assert_memory_equal(&out[TLM_HEADER_SIZE + 27], ((const uint8_t[]){0, 0, 0}), 3);
}

/* --- round trips ---------------------------------------------------------- */

static void test_estimate_round_trips(void **state) {
    (void)state;
    struct tlm_estimate cases[4];
    cases[0] = sample_estimate();
    cases[1] = sample_estimate();
    cases[1].estimator = TLM_ESTIMATOR_KALMAN;
    cases[1].status = TLM_STATUS_DEGRADED;
    cases[1].why = 0x8000000000700F01u; /* any bits travel unchanged, the top one too */
    cases[1].sensors_used = 0x07;
    cases[1].alpha_udeg = INT32_MAX;
    cases[1].beta_udeg = INT32_MIN + 1;
    cases[1].distance_um = -1;
    cases[1].flatness_um = TLM_NO_VALUE;
    cases[1].alpha_sd_udeg = INT32_MAX;
    cases[1].beta_sd_udeg = 1;
    cases[2] = sample_estimate();
    cases[2].estimator = TLM_ESTIMATOR_MEAN;
    cases[2].status = TLM_STATUS_INVALID;
    cases[2].why = 1u;
    cases[2].sensors_used = 0x01;
    cases[2].alpha_udeg = TLM_NO_VALUE;
    cases[2].beta_udeg = TLM_NO_VALUE;
    cases[2].distance_um = TLM_NO_VALUE;
    cases[2].flatness_um = TLM_NO_VALUE;
    cases[2].alpha_sd_udeg = TLM_NO_VALUE;
    cases[2].beta_sd_udeg = TLM_NO_VALUE;
    cases[2].distance_sd_um = TLM_NO_VALUE;
    cases[3] = sample_estimate();
    cases[3].estimator = TLM_ESTIMATOR_CONSENSUS_PAPER;
    cases[3].t_ms = UINT32_MAX;
    cases[3].window_index = UINT32_MAX;
    cases[3].flatness_um = INT32_MAX;
    cases[3].temp_known = false; /* no temperature: known 0, value 0 */
    cases[3].temp_cdeg = 0;
    cases[1].temp_cdeg = TLM_TEMP_MAX_CDEG;
    cases[2].temp_cdeg = TLM_TEMP_MIN_CDEG;
    for (size_t i = 0; i < 4; ++i) {
        uint8_t out[TLM_FRAME_MAX];
        const int n = tlm_encode_estimate((uint8_t)(200 + i), &cases[i], out, sizeof out);
        assert_int_equal(n, 57);
        struct recorder rec;
        const struct tlm_frame frame = decode_one(&rec, out, (size_t)n, TLM_ACCEPT_TELEMETRY);
        assert_int_equal(frame.seq, 200 + i);
        struct tlm_telemetry msg;
        assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OK);
        assert_int_equal(msg.type, TLM_TYPE_ESTIMATE);
        const struct tlm_estimate *e = &msg.u.estimate;
        assert_int_equal(e->t_ms, cases[i].t_ms);
        assert_int_equal(e->window_index, cases[i].window_index);
        assert_int_equal(e->estimator, cases[i].estimator);
        assert_int_equal(e->status, cases[i].status);
        assert_true(e->why == cases[i].why);
        assert_int_equal(e->temp_known, cases[i].temp_known);
        assert_int_equal(e->temp_cdeg, cases[i].temp_cdeg);
        assert_int_equal(e->alpha_sd_udeg, cases[i].alpha_sd_udeg);
        assert_int_equal(e->beta_sd_udeg, cases[i].beta_sd_udeg);
        assert_int_equal(e->distance_sd_um, cases[i].distance_sd_um);
        assert_int_equal(e->sensors_used, cases[i].sensors_used);
        assert_int_equal(e->alpha_udeg, cases[i].alpha_udeg);
        assert_int_equal(e->beta_udeg, cases[i].beta_udeg);
        assert_int_equal(e->distance_um, cases[i].distance_um);
        assert_int_equal(e->flatness_um, cases[i].flatness_um);
        /* Canonical: re-encoding gives the same bytes. */
        uint8_t again[TLM_FRAME_MAX];
        assert_int_equal(tlm_encode_estimate(frame.seq, e, again, sizeof again), n);
        assert_memory_equal(again, out, (size_t)n);
    }
}

static void test_raw_sample_round_trips(void **state) {
    (void)state;
    const struct tlm_raw_sample raw = sample_raw();
    uint8_t out[TLM_FRAME_MAX];
    const int n = tlm_encode_raw_sample(7, &raw, out, sizeof out);
    assert_int_equal(n, 24);
    struct recorder rec;
    const struct tlm_frame frame = decode_one(&rec, out, (size_t)n, TLM_ACCEPT_TELEMETRY);
    struct tlm_telemetry msg;
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OK);
    assert_int_equal(msg.type, TLM_TYPE_RAW_SAMPLE);
    assert_int_equal(msg.u.raw.t_ms, raw.t_ms);
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        assert_int_equal(msg.u.raw.range_mm[i], raw.range_mm[i]);
        assert_int_equal(msg.u.raw.range_status[i], raw.range_status[i]);
    }
    assert_int_equal(msg.u.raw.present_mask, raw.present_mask);
    /* Little-endian on the wire: t_ms first, low byte first. */
    assert_int_equal(out[5], 0x04);
    assert_int_equal(out[8], 0x01);
    assert_int_equal(out[5 + 4 + 6], 0xA0); /* 4000 = 0x0FA0, sensor D */
    assert_int_equal(out[5 + 4 + 7], 0x0F);
}

static void test_health_round_trips(void **state) {
    (void)state;
    const struct tlm_health health = sample_health();
    uint8_t out[TLM_FRAME_MAX];
    const int n = tlm_encode_health(8, &health, out, sizeof out);
    assert_int_equal(n, 155);
    struct recorder rec;
    const struct tlm_frame frame = decode_one(&rec, out, (size_t)n, TLM_ACCEPT_TELEMETRY);
    struct tlm_telemetry msg;
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OK);
    assert_int_equal(msg.type, TLM_TYPE_HEALTH);
    /* Field by field (the structs have no padding holes, but be explicit). */
    const struct tlm_health *h = &msg.u.health;
    assert_int_equal(h->uptime_ms, health.uptime_ms);
    assert_memory_equal(h->sensor_state, health.sensor_state, 4);
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        assert_int_equal(h->sensor[i].comm_errors, health.sensor[i].comm_errors);
        assert_int_equal(h->sensor[i].timeouts, health.sensor[i].timeouts);
        assert_int_equal(h->sensor[i].flagged, health.sensor[i].flagged);
        assert_int_equal(h->sensor[i].reinits, health.sensor[i].reinits);
    }
    assert_int_equal(h->bus.addr_nack, 1001);
    assert_int_equal(h->bus.data_nack, 1002);
    assert_int_equal(h->bus.busy, 1003);
    assert_int_equal(h->bus.timeout, 1004);
    assert_int_equal(h->bus.stuck, 1005);
    assert_int_equal(h->bus.other, 1006);
    assert_int_equal(h->bus.recoveries, 1007);
    assert_int_equal(h->watchdog_resets, 2001);
    assert_int_equal(h->loop_overruns, 2002);
    assert_int_equal(h->loop_max_us, 2003);
    assert_int_equal(h->tx_dropped, 0xFFFFFFFFu);
    assert_int_equal(h->link.frames_ok, 3001);
    assert_int_equal(h->link.bad_crc, 3002);
    assert_int_equal(h->link.bad_length, 3003);
    assert_int_equal(h->link.unknown_type, 3004);
    assert_int_equal(h->link.truncated, 3005);
    assert_int_equal(h->link.out_of_range, 3006);
    assert_int_equal(h->link.discarded_bytes, 3007);
    /* The link counters close the payload: the last 28 bytes, discarded last. */
    assert_int_equal(out[5 + 140], 3007 & 0xFF);
    assert_int_equal(out[5 + 141], 3007 >> 8);
}

static void test_ack_and_status_round_trip(void **state) {
    (void)state;
    uint8_t out[TLM_FRAME_MAX];
    struct recorder rec;
    struct tlm_telemetry msg;
    for (uint8_t result = 0; result <= TLM_RESULT_LAST; ++result) {
        const struct tlm_ack ack = {.echo_seq = 250, .command = 0x99, .result = result};
        const int n = tlm_encode_ack(1, &ack, out, sizeof out);
        const struct tlm_frame frame = decode_one(&rec, out, (size_t)n, TLM_ACCEPT_TELEMETRY);
        assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OK);
        assert_int_equal(msg.type, TLM_TYPE_ACK);
        assert_int_equal(msg.u.ack.echo_seq, 250);
        assert_int_equal(msg.u.ack.command, 0x99);
        assert_int_equal(msg.u.ack.result, result);
    }
    const struct tlm_status status = sample_status();
    const int n = tlm_encode_status(2, &status, out, sizeof out);
    const struct tlm_frame frame = decode_one(&rec, out, (size_t)n, TLM_ACCEPT_TELEMETRY);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OK);
    assert_int_equal(msg.type, TLM_TYPE_STATUS);
    const struct tlm_status *s = &msg.u.status;
    assert_int_equal(s->fw_major, 0);
    assert_int_equal(s->fw_minor, 1);
    assert_int_equal(s->fw_patch, 2);
    assert_int_equal(s->uptime_ms, 123456);
    assert_int_equal(s->window_n, 100);
    assert_int_equal(s->mode, TLM_WINDOW_SLIDING);
    assert_int_equal(s->estimator, TLM_ESTIMATOR_KALMAN);
    assert_true(s->running);
    assert_false(s->raw_stream);
    assert_int_equal(s->period_ms, 20);
    assert_int_equal(s->cal_age_s, 90061u);
    assert_int_equal(s->cal_age, TLM_CAL_AGE_KEPT);
    assert_true(s->temp_known);
    assert_int_equal(s->temp_cdeg, 4567);
}

/* --- telemetry validation ------------------------------------------------- */

static void assert_estimate_rejected(const struct tlm_estimate *bad) {
    uint8_t out[TLM_FRAME_MAX];
    assert_int_equal(tlm_encode_estimate(0, bad, out, sizeof out), HAL_ERR_INVALID);
    /* The same bytes forced onto the wire are refused by the parser. */
    const struct tlm_estimate good = sample_estimate();
    assert_int_equal(tlm_encode_estimate(0, &good, out, sizeof out), 57);
    uint8_t *p = &out[TLM_HEADER_SIZE];
    p[8] = bad->estimator;
    p[9] = bad->status;
    p[10] = bad->sensors_used;
    const int32_t values[7] = {bad->alpha_udeg,    bad->beta_udeg,     bad->distance_um,
                               bad->flatness_um,   bad->alpha_sd_udeg, bad->beta_sd_udeg,
                               bad->distance_sd_um};
    for (size_t v = 0; v < 7; ++v) {
        const uint32_t u = (uint32_t)values[v];
        for (size_t b = 0; b < 4; ++b) {
            p[11 + 4 * v + b] = (uint8_t)(u >> (8 * b));
        }
    }
    for (size_t b = 0; b < 8; ++b) {
        p[39 + b] = (uint8_t)(bad->why >> (8 * b));
    }
    p[47] = bad->temp_known ? 1u : 0u;
    p[48] = (uint8_t)((uint16_t)bad->temp_cdeg & 0xFFu);
    p[49] = (uint8_t)((uint16_t)bad->temp_cdeg >> 8);
    const struct tlm_frame frame = raw_frame(TLM_TYPE_ESTIMATE, p, TLM_LEN_ESTIMATE);
    struct tlm_telemetry msg;
    struct tlm_rx_counters counters;
    memset(&counters, 0, sizeof counters);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, &counters), TLM_RESULT_OUT_OF_RANGE);
    assert_int_equal(counters.out_of_range, 1);
}

static void test_estimate_validation(void **state) {
    (void)state;
    struct tlm_estimate e;
    e = sample_estimate();
    e.estimator = TLM_ESTIMATOR_LAST + 1;
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.status = TLM_STATUS_LAST + 1;
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.why = 1u; /* ok with a reason */
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.status = TLM_STATUS_DEGRADED; /* degraded without one */
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.sensors_used = 0x07; /* ok needs all four sensors */
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.status = TLM_STATUS_DEGRADED;
    e.why = 1u;
    e.sensors_used = 0x1F; /* no fifth sensor */
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.flatness_um = TLM_NO_VALUE; /* ok has all four, so a flatness */
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.beta_udeg = TLM_NO_VALUE; /* ok has every value ... */
    e.beta_sd_udeg = TLM_NO_VALUE;
    assert_estimate_rejected(&e);
    e.status = TLM_STATUS_DEGRADED; /* ... and so has degraded: a missing angle is invalid */
    e.why = 1u;
    assert_estimate_rejected(&e);
    e.status = TLM_STATUS_INVALID;
    assert_int_equal(tlm_encode_estimate(0, &e, (uint8_t[TLM_FRAME_MAX]){0}, TLM_FRAME_MAX), 57);
    /* An sd comes with its value and is never 0: no claimed certainty without data. */
    e = sample_estimate();
    e.alpha_sd_udeg = 0;
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.distance_sd_um = -5;
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.beta_sd_udeg = TLM_NO_VALUE; /* a value without its sd */
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.status = TLM_STATUS_INVALID;
    e.why = 1u;
    e.alpha_udeg = TLM_NO_VALUE; /* an sd without its value */
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.status = TLM_STATUS_INVALID; /* invalid with both angles */
    e.why = 1u;
    assert_estimate_rejected(&e);
    /* a temperature outside -100..200 degC, or a value where none is known */
    e = sample_estimate();
    e.temp_cdeg = TLM_TEMP_MAX_CDEG + 1;
    assert_estimate_rejected(&e);
    e.temp_cdeg = TLM_TEMP_MIN_CDEG - 1;
    assert_estimate_rejected(&e);
    e = sample_estimate();
    e.temp_known = false;
    assert_estimate_rejected(&e);
}

/* One whole frame in, the estimate out (the twin's and a capture reader's call). */
static void test_decode_estimate_from_frame_bytes(void **state) {
    (void)state;
    const struct tlm_estimate est = sample_estimate();
    uint8_t out[TLM_FRAME_MAX];
    const int n = tlm_encode_estimate(9, &est, out, sizeof out);
    assert_int_equal(n, 57);
    struct tlm_estimate got;
    assert_int_equal(tlm_decode_estimate(out, (size_t)n, &got), TLM_RESULT_OK);
    assert_int_equal(got.alpha_udeg, est.alpha_udeg);
    assert_int_equal(got.alpha_sd_udeg, est.alpha_sd_udeg);
    assert_int_equal(got.distance_sd_um, est.distance_sd_um);
    assert_true(got.why == 0u);
    assert_int_equal(tlm_decode_estimate(out, (size_t)n - 1u, &got), TLM_RESULT_BAD_LENGTH);
    assert_int_equal(tlm_decode_estimate(NULL, (size_t)n, &got), TLM_RESULT_BAD_LENGTH);
    out[20] ^= 0x01u; /* a payload bit: the CRC fails */
    assert_int_equal(tlm_decode_estimate(out, (size_t)n, &got), TLM_RESULT_OUT_OF_RANGE);
    out[20] ^= 0x01u;
    out[0] = 0x00; /* not a frame start */
    assert_int_equal(tlm_decode_estimate(out, (size_t)n, &got), TLM_RESULT_BAD_LENGTH);
    out[0] = TLM_SYNC0;
    /* Another type of the same length is not an estimate (CRC made valid again). */
    uint8_t other[TLM_FRAME_MAX];
    const int m = tlm_frame_encode(TLM_TYPE_STATUS, 9, &out[TLM_HEADER_SIZE], TLM_LEN_ESTIMATE,
                                   other, sizeof other);
    assert_int_equal(m, n);
    assert_int_equal(tlm_decode_estimate(other, (size_t)m, &got), TLM_RESULT_UNKNOWN_TYPE);
    /* A CRC-valid frame with a field out of range. */
    struct tlm_estimate bad = est;
    bad.alpha_sd_udeg = 0;
    uint8_t payload[TLM_LEN_ESTIMATE];
    memcpy(payload, &out[TLM_HEADER_SIZE], sizeof payload);
    payload[27] = 0; /* alpha_sd_udeg = 0 at payload offset 27..30 */
    payload[28] = 0;
    payload[29] = 0;
    payload[30] = 0;
    (void)bad;
    const int k =
        tlm_frame_encode(TLM_TYPE_ESTIMATE, 9, payload, sizeof payload, other, sizeof other);
    assert_int_equal(tlm_decode_estimate(other, (size_t)k, &got), TLM_RESULT_OUT_OF_RANGE);
}

static void test_raw_health_ack_status_validation(void **state) {
    (void)state;
    uint8_t out[TLM_FRAME_MAX];
    struct tlm_raw_sample raw = sample_raw();
    raw.range_mm[2] = 5; /* sensor C absent but carries a range */
    assert_int_equal(tlm_encode_raw_sample(0, &raw, out, sizeof out), HAL_ERR_INVALID);
    raw = sample_raw();
    raw.range_status[2] = 1;
    assert_int_equal(tlm_encode_raw_sample(0, &raw, out, sizeof out), HAL_ERR_INVALID);
    raw = sample_raw();
    raw.present_mask = 0x1B;
    assert_int_equal(tlm_encode_raw_sample(0, &raw, out, sizeof out), HAL_ERR_INVALID);

    struct tlm_health health = sample_health();
    health.sensor_state[2] = TLM_HEALTH_LAST + 1;
    assert_int_equal(tlm_encode_health(0, &health, out, sizeof out), HAL_ERR_INVALID);

    const struct tlm_ack ack = {
        .echo_seq = 0, .command = TLM_TYPE_STOP, .result = TLM_RESULT_LAST + 1};
    assert_int_equal(tlm_encode_ack(0, &ack, out, sizeof out), HAL_ERR_INVALID);

    struct tlm_status status = sample_status();
    status.window_n = TLM_WINDOW_MAX + 1;
    assert_int_equal(tlm_encode_status(0, &status, out, sizeof out), HAL_ERR_INVALID);
    status = sample_status();
    status.mode = 2;
    assert_int_equal(tlm_encode_status(0, &status, out, sizeof out), HAL_ERR_INVALID);
    status = sample_status();
    status.estimator = 4;
    assert_int_equal(tlm_encode_status(0, &status, out, sizeof out), HAL_ERR_INVALID);

    /* Parser side: patch single bytes of good payloads. */
    struct tlm_telemetry msg;
    raw = sample_raw();
    assert_int_equal(tlm_encode_raw_sample(0, &raw, out, sizeof out), 24);
    out[5 + 4 + 4] = 1; /* range of absent sensor C */
    struct tlm_frame frame = raw_frame(TLM_TYPE_RAW_SAMPLE, &out[5], TLM_LEN_RAW_SAMPLE);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OUT_OF_RANGE);

    health = sample_health();
    assert_int_equal(tlm_encode_health(0, &health, out, sizeof out), 155);
    out[5 + 4 + 3] = 4; /* sensor D state */
    frame = raw_frame(TLM_TYPE_HEALTH, &out[5], TLM_LEN_HEALTH);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OUT_OF_RANGE);

    const struct tlm_ack good_ack = {.echo_seq = 0, .command = TLM_TYPE_STOP, .result = 0};
    assert_int_equal(tlm_encode_ack(0, &good_ack, out, sizeof out), 11);
    out[5 + 2] = TLM_RESULT_LAST + 1; /* result */
    frame = raw_frame(TLM_TYPE_ACK, &out[5], TLM_LEN_ACK);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OUT_OF_RANGE);
    /* The error code: negative, carried unchanged by a nack, never in an ack. */
    const struct tlm_ack nack = {
        .echo_seq = 3, .command = TLM_TYPE_SET_WINDOW, .result = 3, .error = -2};
    assert_int_equal(tlm_encode_ack(0, &nack, out, sizeof out), 11);
    assert_int_equal(out[5 + 3], 0xFE);
    frame = raw_frame(TLM_TYPE_ACK, &out[5], TLM_LEN_ACK);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OK);
    assert_int_equal(msg.u.ack.error, -2);
    assert_int_equal(msg.u.ack.result, 3);
    out[5 + 3] = 0x05; /* a positive code is not a firmware error */
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OUT_OF_RANGE);
    out[5 + 2] = 0;
    out[5 + 3] = 0xFE; /* an ack with an error */
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OUT_OF_RANGE);
    const struct tlm_ack ack_with_error = {.result = 0, .error = -1};
    assert_int_equal(tlm_encode_ack(0, &ack_with_error, out, sizeof out), HAL_ERR_INVALID);

    const size_t status_bytes[] = {3, 10, 11, 12, 13, 16, 17, 20, 26, 27, 29};
    const uint8_t status_bad[] = {TLM_PROTOCOL_VERSION + 1u, 2,    4, 2, 2,   6,
                                  TLM_CAL_STATE_LAST + 1u,   0x10, 4, 2, 0x80}; /* protocol,
mode, estimator, bools, record state, calibration state, arm > 1000 mm, age state, the
temperature's known byte, a temperature below -100 degC */
    for (size_t i = 0; i < sizeof status_bytes / sizeof status_bytes[0]; ++i) {
        status = sample_status();
        assert_int_equal(tlm_encode_status(0, &status, out, sizeof out), 37);
        out[5 + status_bytes[i]] = status_bad[i];
        frame = raw_frame(TLM_TYPE_STATUS, &out[5], TLM_LEN_STATUS);
        assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OUT_OF_RANGE);
    }
    status = sample_status();
    status.temp_known = false;
    status.temp_cdeg = 0;
    assert_int_equal(tlm_encode_status(0, &status, out, sizeof out), 37);
    out[5 + 28] = 1; /* not known, with a value */
    frame = raw_frame(TLM_TYPE_STATUS, &out[5], TLM_LEN_STATUS);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OUT_OF_RANGE);
    status = sample_status();
    assert_int_equal(tlm_encode_status(0, &status, out, sizeof out), 37);
    out[5 + 8] = 1; /* window_n = 1 */
    frame = raw_frame(TLM_TYPE_STATUS, &out[5], TLM_LEN_STATUS);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, NULL), TLM_RESULT_OUT_OF_RANGE);
}

static void test_encoders_check_capacity(void **state) {
    (void)state;
    uint8_t out[TLM_FRAME_MAX];
    const struct tlm_estimate est = sample_estimate();
    const struct tlm_health health = sample_health();
    const struct tlm_command start = {.type = TLM_TYPE_START};
    assert_int_equal(tlm_encode_estimate(0, &est, out, 56), HAL_ERR_INVALID);
    assert_int_equal(tlm_encode_estimate(0, &est, out, 57), 57);
    assert_int_equal(tlm_encode_health(0, &health, out, 150), HAL_ERR_INVALID);
    assert_int_equal(tlm_encode_health(0, &health, NULL, sizeof out), HAL_ERR_INVALID);
    assert_int_equal(tlm_encode_estimate(0, NULL, out, sizeof out), HAL_ERR_INVALID);
    assert_int_equal(tlm_encode_command(0, &start, out, 6), HAL_ERR_INVALID);
    assert_int_equal(tlm_encode_command(0, &start, out, 7), 7);
}

static void test_telemetry_parser_type_and_length(void **state) {
    (void)state;
    const uint8_t payload[TLM_MAX_PAYLOAD] = {0};
    struct tlm_telemetry msg;
    struct tlm_rx_counters counters;
    memset(&counters, 0, sizeof counters);
    struct tlm_frame frame = raw_frame(TLM_TYPE_START, payload, 0);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, &counters), TLM_RESULT_UNKNOWN_TYPE);
    frame = raw_frame(TLM_TYPE_ESTIMATE, payload, TLM_LEN_ESTIMATE - 1);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, &counters), TLM_RESULT_BAD_LENGTH);
    frame = raw_frame(TLM_TYPE_ACK, NULL, TLM_LEN_ACK);
    assert_int_equal(tlm_parse_telemetry(&frame, &msg, &counters), TLM_RESULT_BAD_LENGTH);
    assert_int_equal(counters.unknown_type, 1);
    assert_int_equal(counters.bad_length, 2);
}

/* --- commands ------------------------------------------------------------- */

static enum tlm_result parse_bytes(uint8_t type, const uint8_t *payload, uint8_t length,
                                   struct tlm_command *cmd, struct tlm_rx_counters *counters) {
    const struct tlm_frame frame = raw_frame(type, payload, length);
    return tlm_parse_command(&frame, cmd, counters);
}

static void test_set_window_command(void **state) {
    (void)state;
    struct tlm_command cmd;
    struct tlm_rx_counters c;
    memset(&c, 0, sizeof c);
    const uint8_t min_tumbling[] = {2, 0, 0};
    assert_int_equal(parse_bytes(TLM_TYPE_SET_WINDOW, min_tumbling, 3, &cmd, &c), TLM_RESULT_OK);
    assert_int_equal(cmd.type, TLM_TYPE_SET_WINDOW);
    assert_int_equal(cmd.u.set_window.window_n, 2);
    assert_int_equal(cmd.u.set_window.mode, TLM_WINDOW_TUMBLING);
    const uint8_t max_sliding[] = {255, 0, 1};
    assert_int_equal(parse_bytes(TLM_TYPE_SET_WINDOW, max_sliding, 3, &cmd, &c), TLM_RESULT_OK);
    assert_int_equal(cmd.u.set_window.window_n, 255);
    assert_int_equal(cmd.u.set_window.mode, TLM_WINDOW_SLIDING);

    const uint8_t out_of_range[][3] = {{1, 0, 0},       {0, 0, 0},   {0, 1, 0},
                                       {0xFF, 0xFF, 0}, {100, 0, 2}, {100, 0, 0xFF}};
    for (size_t i = 0; i < sizeof out_of_range / sizeof out_of_range[0]; ++i) {
        assert_int_equal(parse_bytes(TLM_TYPE_SET_WINDOW, out_of_range[i], 3, &cmd, &c),
                         TLM_RESULT_OUT_OF_RANGE);
    }
    assert_int_equal(parse_bytes(TLM_TYPE_SET_WINDOW, min_tumbling, 2, &cmd, &c),
                     TLM_RESULT_BAD_LENGTH);
    const uint8_t four[] = {100, 0, 0, 0};
    assert_int_equal(parse_bytes(TLM_TYPE_SET_WINDOW, four, 4, &cmd, &c), TLM_RESULT_BAD_LENGTH);
    assert_int_equal(parse_bytes(TLM_TYPE_SET_WINDOW, NULL, 3, &cmd, &c), TLM_RESULT_BAD_LENGTH);
    assert_int_equal(c.out_of_range, 6);
    assert_int_equal(c.bad_length, 3);
    assert_int_equal(c.unknown_type, 0);
}

static void test_select_estimator_command(void **state) {
    (void)state;
    struct tlm_command cmd;
    struct tlm_rx_counters c;
    memset(&c, 0, sizeof c);
    for (uint8_t id = 0; id <= TLM_ESTIMATOR_LAST; ++id) {
        assert_int_equal(parse_bytes(TLM_TYPE_SELECT_ESTIMATOR, &id, 1, &cmd, &c), TLM_RESULT_OK);
        assert_int_equal(cmd.type, TLM_TYPE_SELECT_ESTIMATOR);
        assert_int_equal(cmd.u.estimator, id);
    }
    const uint8_t bad[] = {4, 0x80, 0xFF};
    for (size_t i = 0; i < 3; ++i) {
        assert_int_equal(parse_bytes(TLM_TYPE_SELECT_ESTIMATOR, &bad[i], 1, &cmd, &c),
                         TLM_RESULT_OUT_OF_RANGE);
    }
    const uint8_t two[] = {0, 0};
    assert_int_equal(parse_bytes(TLM_TYPE_SELECT_ESTIMATOR, two, 0, &cmd, &c),
                     TLM_RESULT_BAD_LENGTH);
    assert_int_equal(parse_bytes(TLM_TYPE_SELECT_ESTIMATOR, two, 2, &cmd, &c),
                     TLM_RESULT_BAD_LENGTH);
    assert_int_equal(c.out_of_range, 3);
    assert_int_equal(c.bad_length, 2);
}

static void test_empty_commands(void **state) {
    (void)state;
    struct tlm_command cmd;
    struct tlm_rx_counters c;
    memset(&c, 0, sizeof c);
    const uint8_t types[] = {TLM_TYPE_START, TLM_TYPE_STOP, TLM_TYPE_STATUS_REQUEST};
    const uint8_t extra = 0;
    for (size_t i = 0; i < 3; ++i) {
        assert_int_equal(parse_bytes(types[i], NULL, 0, &cmd, &c), TLM_RESULT_OK);
        assert_int_equal(cmd.type, types[i]);
        assert_int_equal(parse_bytes(types[i], &extra, 1, &cmd, &c), TLM_RESULT_BAD_LENGTH);
    }
    assert_int_equal(c.bad_length, 3);
    assert_int_equal(c.out_of_range, 0);
}

static void test_raw_stream_command(void **state) {
    (void)state;
    struct tlm_command cmd;
    struct tlm_rx_counters c;
    memset(&c, 0, sizeof c);
    const uint8_t on = 1, off = 0, two = 2;
    assert_int_equal(parse_bytes(TLM_TYPE_RAW_STREAM, &on, 1, &cmd, &c), TLM_RESULT_OK);
    assert_true(cmd.u.raw_enable);
    assert_int_equal(parse_bytes(TLM_TYPE_RAW_STREAM, &off, 1, &cmd, &c), TLM_RESULT_OK);
    assert_false(cmd.u.raw_enable);
    assert_int_equal(parse_bytes(TLM_TYPE_RAW_STREAM, &two, 1, &cmd, &c), TLM_RESULT_OUT_OF_RANGE);
    assert_int_equal(parse_bytes(TLM_TYPE_RAW_STREAM, NULL, 0, &cmd, &c), TLM_RESULT_BAD_LENGTH);
    assert_int_equal(c.out_of_range, 1);
    assert_int_equal(c.bad_length, 1);
}

static void test_set_process_noise_command(void **state) {
    (void)state;
    struct tlm_command cmd;
    struct tlm_rx_counters c;
    memset(&c, 0, sizeof c);
    /* qd 0.5 mm²/s = 500000 µm²/s, qt 0xFFFFFFFF µm²/s (the largest), no flags */
    const uint8_t fixed[9] = {0x20, 0xA1, 0x07, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0x00};
    assert_int_equal(parse_bytes(TLM_TYPE_SET_PROCESS_NOISE, fixed, 9, &cmd, &c), TLM_RESULT_OK);
    assert_int_equal(cmd.type, TLM_TYPE_SET_PROCESS_NOISE);
    assert_int_equal(cmd.u.process_noise.qd_um2_per_s, 500000u);
    assert_int_equal(cmd.u.process_noise.qt_um2_per_s, UINT32_MAX);
    assert_int_equal(cmd.u.process_noise.flags, 0);
    const uint8_t automatic[9] = {0, 0, 0, 0, 0, 0, 0, 0, TLM_PROCESS_NOISE_AUTO};
    assert_int_equal(parse_bytes(TLM_TYPE_SET_PROCESS_NOISE, automatic, 9, &cmd, &c),
                     TLM_RESULT_OK);
    assert_int_equal(cmd.u.process_noise.flags, TLM_PROCESS_NOISE_AUTO);
    assert_int_equal(cmd.u.process_noise.qd_um2_per_s, 0u);
    /* every undefined flag bit is out of range, not ignored */
    for (unsigned bit = 1; bit < 8u; ++bit) {
        uint8_t bad[9] = {0};
        bad[8] = (uint8_t)(1u << bit);
        assert_int_equal(parse_bytes(TLM_TYPE_SET_PROCESS_NOISE, bad, 9, &cmd, &c),
                         TLM_RESULT_OUT_OF_RANGE);
    }
    assert_int_equal(parse_bytes(TLM_TYPE_SET_PROCESS_NOISE, fixed, 8, &cmd, &c),
                     TLM_RESULT_BAD_LENGTH);
    const uint8_t ten[10] = {0};
    assert_int_equal(parse_bytes(TLM_TYPE_SET_PROCESS_NOISE, ten, 10, &cmd, &c),
                     TLM_RESULT_BAD_LENGTH);
    assert_int_equal(parse_bytes(TLM_TYPE_SET_PROCESS_NOISE, NULL, 9, &cmd, &c),
                     TLM_RESULT_BAD_LENGTH);
    assert_int_equal(c.out_of_range, 7);
    assert_int_equal(c.bad_length, 3);

    /* the encoder writes exactly that layout, and refuses undefined flags */
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SET_PROCESS_NOISE;
    cmd.u.process_noise.qd_um2_per_s = 500000u;
    cmd.u.process_noise.qt_um2_per_s = UINT32_MAX;
    uint8_t out[TLM_FRAME_MAX];
    assert_int_equal(tlm_encode_command(7, &cmd, out, sizeof out), 9 + 7);
    assert_int_equal(out[3], TLM_TYPE_SET_PROCESS_NOISE);
    assert_memory_equal(&out[TLM_HEADER_SIZE], fixed, 9);
    cmd.u.process_noise.flags = 0x02;
    assert_int_equal(tlm_encode_command(7, &cmd, out, sizeof out), HAL_ERR_INVALID);
    cmd.u.process_noise.flags = 0x81;
    assert_int_equal(tlm_encode_command(7, &cmd, out, sizeof out), HAL_ERR_INVALID);
    cmd.u.process_noise.flags = TLM_PROCESS_NOISE_AUTO;
    assert_int_equal(tlm_encode_command(7, &cmd, out, 9 + 6), HAL_ERR_INVALID); /* no room */
}

/* set-arm (u32 µm, 1..1000 mm) and set-period (u16 ms, 1..10000): exact layouts, the
 * protocol's ranges refused both ways. */
static void test_set_arm_and_set_period_commands(void **state) {
    (void)state;
    struct tlm_command cmd;
    struct tlm_rx_counters c;
    memset(&c, 0, sizeof c);
    const uint8_t arm[4] = {0xC2, 0xB0, 0x00, 0x00}; /* 45250 um */
    assert_int_equal(parse_bytes(TLM_TYPE_SET_ARM, arm, 4, &cmd, &c), TLM_RESULT_OK);
    assert_int_equal(cmd.u.arm_um, 45250u);
    const uint8_t period[2] = {0x21, 0x00}; /* 33 ms */
    assert_int_equal(parse_bytes(TLM_TYPE_SET_PERIOD, period, 2, &cmd, &c), TLM_RESULT_OK);
    assert_int_equal(cmd.u.period_ms, 33u);
    const uint8_t arm_small[4] = {0xE7, 0x03, 0, 0};     /* 999 um */
    const uint8_t arm_big[4] = {0x41, 0x42, 0x0F, 0x00}; /* 1000001 um */
    const uint8_t period_zero[2] = {0, 0};
    const uint8_t period_big[2] = {0x11, 0x27}; /* 10001 ms */
    assert_int_equal(parse_bytes(TLM_TYPE_SET_ARM, arm_small, 4, &cmd, &c),
                     TLM_RESULT_OUT_OF_RANGE);
    assert_int_equal(parse_bytes(TLM_TYPE_SET_ARM, arm_big, 4, &cmd, &c), TLM_RESULT_OUT_OF_RANGE);
    assert_int_equal(parse_bytes(TLM_TYPE_SET_PERIOD, period_zero, 2, &cmd, &c),
                     TLM_RESULT_OUT_OF_RANGE);
    assert_int_equal(parse_bytes(TLM_TYPE_SET_PERIOD, period_big, 2, &cmd, &c),
                     TLM_RESULT_OUT_OF_RANGE);
    assert_int_equal(parse_bytes(TLM_TYPE_SET_ARM, arm, 3, &cmd, &c), TLM_RESULT_BAD_LENGTH);
    assert_int_equal(c.out_of_range, 4);
    assert_int_equal(c.bad_length, 1);
    uint8_t out[TLM_FRAME_MAX];
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SET_ARM;
    cmd.u.arm_um = 45250u;
    assert_int_equal(tlm_encode_command(1, &cmd, out, sizeof out), 4 + 7);
    assert_memory_equal(&out[TLM_HEADER_SIZE], arm, 4);
    cmd.u.arm_um = 999u;
    assert_int_equal(tlm_encode_command(1, &cmd, out, sizeof out), HAL_ERR_INVALID);
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SET_PERIOD;
    cmd.u.period_ms = 33u;
    assert_int_equal(tlm_encode_command(1, &cmd, out, sizeof out), 2 + 7);
    assert_memory_equal(&out[TLM_HEADER_SIZE], period, 2);
    cmd.u.period_ms = 10001u;
    assert_int_equal(tlm_encode_command(1, &cmd, out, sizeof out), HAL_ERR_INVALID);
}

/* The calibration commands and message carry record section 2 in its version-4 form; the
 * protocol checks its header (id 2, length 114; all zero for "none stored"), the firmware its
 * version and content. */
static void test_calibration_messages(void **state) {
    (void)state;
    uint8_t out[TLM_FRAME_MAX];
    struct tlm_command cmd = {.type = TLM_TYPE_WRITE_CALIBRATION};
    cmd.u.cal_section[0] = 2;
    cmd.u.cal_section[1] = 4;
    cmd.u.cal_section[2] = 114;
    for (unsigned i = 4; i < TLM_CAL_SECTION_LEN; ++i) {
        cmd.u.cal_section[i] = (uint8_t)(i * 7u);
    }
    const int n = tlm_encode_command(9, &cmd, out, sizeof out);
    assert_int_equal(n, (int)(TLM_CAL_SECTION_LEN + TLM_FRAME_OVERHEAD));
    struct tlm_command back;
    assert_int_equal(parse_bytes(TLM_TYPE_WRITE_CALIBRATION, &out[TLM_HEADER_SIZE],
                                 TLM_CAL_SECTION_LEN, &back, NULL),
                     TLM_RESULT_OK);
    assert_memory_equal(back.u.cal_section, cmd.u.cal_section, TLM_CAL_SECTION_LEN);
    out[TLM_HEADER_SIZE] = 1; /* the settings' section id */
    assert_int_equal(parse_bytes(TLM_TYPE_WRITE_CALIBRATION, &out[TLM_HEADER_SIZE],
                                 TLM_CAL_SECTION_LEN, &back, NULL),
                     TLM_RESULT_OUT_OF_RANGE);
    cmd.u.cal_section[2] = 80; /* a length other than 114 (version 1's) */
    assert_int_equal(tlm_encode_command(9, &cmd, out, sizeof out), HAL_ERR_INVALID);
    cmd.u.cal_section[2] = 114;
    cmd.u.cal_section[1] = 0; /* version 0 */
    assert_int_equal(tlm_encode_command(9, &cmd, out, sizeof out), HAL_ERR_INVALID);
    cmd.u.cal_section[1] = 4;
    /* the previous protocol's 84-byte section is not this command's length */
    assert_int_equal(
        parse_bytes(TLM_TYPE_WRITE_CALIBRATION, &out[TLM_HEADER_SIZE], 84u, &back, NULL),
        TLM_RESULT_BAD_LENGTH);

    struct tlm_calibration msg = {.state = TLM_CAL_NONE}; /* nothing stored: all zero */
    assert_int_equal(tlm_encode_calibration(3, &msg, out, sizeof out),
                     (int)(TLM_LEN_CALIBRATION + TLM_FRAME_OVERHEAD));
    struct tlm_frame frame = raw_frame(TLM_TYPE_CALIBRATION, &out[5], TLM_LEN_CALIBRATION);
    struct tlm_telemetry m;
    assert_int_equal(tlm_parse_telemetry(&frame, &m, NULL), TLM_RESULT_OK);
    msg.section[7] = 1; /* a byte without a header */
    assert_int_equal(tlm_encode_calibration(3, &msg, out, sizeof out), HAL_ERR_INVALID);
    msg.section[7] = 0;
    msg.state = TLM_CAL_STATE_LAST + 1u;
    assert_int_equal(tlm_encode_calibration(3, &msg, out, sizeof out), HAL_ERR_INVALID);
    msg.state = TLM_CAL_APPLIED;
    memcpy(msg.section, cmd.u.cal_section, TLM_CAL_SECTION_LEN);
    msg.section[2] = 114;
    assert_int_equal(tlm_encode_calibration(3, &msg, out, sizeof out),
                     (int)(TLM_LEN_CALIBRATION + TLM_FRAME_OVERHEAD));
    frame = raw_frame(TLM_TYPE_CALIBRATION, &out[5], TLM_LEN_CALIBRATION);
    assert_int_equal(tlm_parse_telemetry(&frame, &m, NULL), TLM_RESULT_OK);
    assert_int_equal(m.u.calibration.state, TLM_CAL_APPLIED);
    assert_memory_equal(m.u.calibration.section, msg.section, TLM_CAL_SECTION_LEN);
    out[5] = TLM_CAL_STATE_LAST + 1u;
    assert_int_equal(tlm_parse_telemetry(&frame, &m, NULL), TLM_RESULT_OUT_OF_RANGE);

    /* re-zero: u16 samples, 10..5000 */
    cmd = (struct tlm_command){.type = TLM_TYPE_REZERO, .u.rezero_samples = 500};
    assert_int_equal(tlm_encode_command(1, &cmd, out, sizeof out), 2 + TLM_FRAME_OVERHEAD);
    assert_int_equal(out[TLM_HEADER_SIZE], 0xF4);
    assert_int_equal(out[TLM_HEADER_SIZE + 1], 0x01);
    const uint8_t nine[2] = {9, 0};
    assert_int_equal(parse_bytes(TLM_TYPE_REZERO, nine, 2, &back, NULL), TLM_RESULT_OUT_OF_RANGE);
    cmd.u.rezero_samples = 5001;
    assert_int_equal(tlm_encode_command(1, &cmd, out, sizeof out), HAL_ERR_INVALID);
}

static void test_unknown_commands(void **state) {
    (void)state;
    struct tlm_command cmd;
    struct tlm_rx_counters c;
    memset(&c, 0, sizeof c);
    /* Every byte that is not one of the thirteen command types is an unknown command,
     * telemetry types included. */
    unsigned unknown = 0;
    for (unsigned type = 0; type <= 0xFF; ++type) {
        const enum tlm_result r = parse_bytes((uint8_t)type, NULL, 0, &cmd, NULL);
        if ((type >= TLM_TYPE_SET_WINDOW && type <= TLM_TYPE_SET_PERIOD) ||
            type == TLM_TYPE_WRITE_CALIBRATION || type == TLM_TYPE_READ_CALIBRATION ||
            type == TLM_TYPE_REZERO) {
            assert_int_not_equal(r, TLM_RESULT_UNKNOWN_TYPE);
        } else {
            assert_int_equal(r, TLM_RESULT_UNKNOWN_TYPE);
            unknown++;
        }
    }
    assert_int_equal(unknown, 243);
    assert_int_equal(parse_bytes(TLM_TYPE_ESTIMATE, NULL, 0, &cmd, &c), TLM_RESULT_UNKNOWN_TYPE);
    assert_int_equal(c.unknown_type, 1);
}

static void test_commands_round_trip_through_the_firmware_decoder(void **state) {
    (void)state;
    struct tlm_command cmds[10];
    memset(cmds, 0, sizeof cmds);
    cmds[0].type = TLM_TYPE_SET_WINDOW;
    cmds[0].u.set_window.window_n = 100;
    cmds[0].u.set_window.mode = TLM_WINDOW_TUMBLING;
    cmds[1].type = TLM_TYPE_SET_WINDOW;
    cmds[1].u.set_window.window_n = 255;
    cmds[1].u.set_window.mode = TLM_WINDOW_SLIDING;
    cmds[2].type = TLM_TYPE_SELECT_ESTIMATOR;
    cmds[2].u.estimator = TLM_ESTIMATOR_CONSENSUS_PAPER;
    cmds[3].type = TLM_TYPE_START;
    cmds[4].type = TLM_TYPE_STOP;
    cmds[5].type = TLM_TYPE_STATUS_REQUEST;
    cmds[6].type = TLM_TYPE_RAW_STREAM;
    cmds[6].u.raw_enable = true;
    cmds[7].type = TLM_TYPE_RAW_STREAM;
    cmds[7].u.raw_enable = false;
    cmds[8].type = TLM_TYPE_SET_PROCESS_NOISE;
    cmds[8].u.process_noise.qd_um2_per_s = 1234567u;
    cmds[8].u.process_noise.qt_um2_per_s = 89u;
    cmds[9].type = TLM_TYPE_SET_PROCESS_NOISE;
    cmds[9].u.process_noise.qd_um2_per_s = UINT32_MAX;
    cmds[9].u.process_noise.flags = TLM_PROCESS_NOISE_AUTO;
    uint8_t stream[10 * 16];
    size_t n = 0;
    for (size_t i = 0; i < 10; ++i) {
        const int k = tlm_encode_command((uint8_t)i, &cmds[i], &stream[n], sizeof stream - n);
        assert_true(k > 0);
        n += (size_t)k;
    }
    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_COMMANDS));
    tlm_decoder_feed(&dec, stream, n, &sink);
    assert_int_equal(rec.frame_count, 10);
    for (size_t i = 0; i < 10; ++i) {
        const struct tlm_frame frame = recorder_frame(&rec, i);
        struct tlm_command got;
        assert_int_equal(tlm_parse_command(&frame, &got, &dec.counters), TLM_RESULT_OK);
        assert_int_equal(frame.seq, i);
        assert_int_equal(got.type, cmds[i].type);
        if (got.type == TLM_TYPE_SET_WINDOW) {
            assert_int_equal(got.u.set_window.window_n, cmds[i].u.set_window.window_n);
            assert_int_equal(got.u.set_window.mode, cmds[i].u.set_window.mode);
        } else if (got.type == TLM_TYPE_SELECT_ESTIMATOR) {
            assert_int_equal(got.u.estimator, cmds[i].u.estimator);
        } else if (got.type == TLM_TYPE_RAW_STREAM) {
            assert_int_equal(got.u.raw_enable, cmds[i].u.raw_enable);
        } else if (got.type == TLM_TYPE_SET_PROCESS_NOISE) {
            assert_int_equal(got.u.process_noise.qd_um2_per_s,
                             cmds[i].u.process_noise.qd_um2_per_s);
            assert_int_equal(got.u.process_noise.qt_um2_per_s,
                             cmds[i].u.process_noise.qt_um2_per_s);
            assert_int_equal(got.u.process_noise.flags, cmds[i].u.process_noise.flags);
        }
    }
    assert_int_equal(dec.counters.frames_ok, 10);
    assert_int_equal(dec.counters.out_of_range, 0);
}

static void test_encode_command_validates(void **state) {
    (void)state;
    uint8_t out[TLM_FRAME_MAX];
    struct tlm_command cmd;
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SET_WINDOW;
    cmd.u.set_window.window_n = 1;
    assert_int_equal(tlm_encode_command(0, &cmd, out, sizeof out), HAL_ERR_INVALID);
    cmd.u.set_window.window_n = 256;
    assert_int_equal(tlm_encode_command(0, &cmd, out, sizeof out), HAL_ERR_INVALID);
    cmd.u.set_window.window_n = 50;
    cmd.u.set_window.mode = 2;
    assert_int_equal(tlm_encode_command(0, &cmd, out, sizeof out), HAL_ERR_INVALID);
    cmd.type = TLM_TYPE_SELECT_ESTIMATOR;
    cmd.u.estimator = 4;
    assert_int_equal(tlm_encode_command(0, &cmd, out, sizeof out), HAL_ERR_INVALID);
    cmd.type = TLM_TYPE_ESTIMATE; /* not a command */
    assert_int_equal(tlm_encode_command(0, &cmd, out, sizeof out), HAL_ERR_INVALID);
    assert_int_equal(tlm_encode_command(0, NULL, out, sizeof out), HAL_ERR_INVALID);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_estimate_layout_matches_reference_bytes),
        cmocka_unit_test(test_every_type_has_its_documented_length),
        cmocka_unit_test(test_status_layout),
        cmocka_unit_test(test_estimate_round_trips),
        cmocka_unit_test(test_raw_sample_round_trips),
        cmocka_unit_test(test_health_round_trips),
        cmocka_unit_test(test_ack_and_status_round_trip),
        cmocka_unit_test(test_estimate_validation),
        cmocka_unit_test(test_decode_estimate_from_frame_bytes),
        cmocka_unit_test(test_raw_health_ack_status_validation),
        cmocka_unit_test(test_encoders_check_capacity),
        cmocka_unit_test(test_telemetry_parser_type_and_length),
        cmocka_unit_test(test_set_window_command),
        cmocka_unit_test(test_select_estimator_command),
        cmocka_unit_test(test_empty_commands),
        cmocka_unit_test(test_raw_stream_command),
        cmocka_unit_test(test_set_process_noise_command),
        cmocka_unit_test(test_set_arm_and_set_period_commands),
        cmocka_unit_test(test_calibration_messages),
        cmocka_unit_test(test_unknown_commands),
        cmocka_unit_test(test_commands_round_trip_through_the_firmware_decoder),
        cmocka_unit_test(test_encode_command_validates),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
