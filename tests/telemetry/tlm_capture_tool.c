/*
 * Test helper for the C <-> Python agreement tests (run_capture_check.cmake).
 *
 *   tlm_capture_tool write CAPTURE.bin EXPECTED.txt
 *       Encode a known stream with the firmware's encoders: every message
 *       type and command, a boot banner and noise between frames, and one of
 *       each malformed frame class. EXPECTED.txt gets the canonical text
 *       (tlm_text.h) of each message from the structs it was encoded from,
 *       and the counter line the construction implies.
 *   tlm_capture_tool dump FILE
 *       Decode FILE with the firmware's decoder and print the same text.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimator/attitude.h" /* the why bits */
#include "telemetry/tlm_frame.h"
#include "telemetry/tlm_messages.h"
#include "tlm_text.h"

#define STREAM_MAX 8192

struct builder {
    uint8_t bytes[STREAM_MAX];
    size_t len;
    FILE *expected;
    struct tlm_rx_counters counters; /* what a decoder must count */
    uint8_t seq;
};

static void fail(const char *what) {
    fprintf(stderr, "tlm_capture_tool: %s\n", what);
    exit(1);
}

static void append(struct builder *b, const uint8_t *data, size_t len) {
    if (b->len + len > STREAM_MAX) {
        fail("stream buffer too small");
    }
    memcpy(&b->bytes[b->len], data, len);
    b->len += len;
}

/* Bytes no decoder may take for a frame: they are counted as discarded. */
static void append_garbage(struct builder *b, const uint8_t *data, size_t len) {
    append(b, data, len);
    b->counters.discarded_bytes += (uint32_t)len;
}

static void check_encoded(int n) {
    if (n <= 0) {
        fail("encoder refused a message the tool built");
    }
}

static void add_telemetry(struct builder *b, const struct tlm_telemetry *msg) {
    uint8_t frame[TLM_FRAME_MAX];
    int n = -1;
    switch (msg->type) {
    case TLM_TYPE_ESTIMATE:
        n = tlm_encode_estimate(b->seq, &msg->u.estimate, frame, sizeof frame);
        break;
    case TLM_TYPE_RAW_SAMPLE:
        n = tlm_encode_raw_sample(b->seq, &msg->u.raw, frame, sizeof frame);
        break;
    case TLM_TYPE_HEALTH:
        n = tlm_encode_health(b->seq, &msg->u.health, frame, sizeof frame);
        break;
    case TLM_TYPE_ACK:
        n = tlm_encode_ack(b->seq, &msg->u.ack, frame, sizeof frame);
        break;
    case TLM_TYPE_STATUS:
        n = tlm_encode_status(b->seq, &msg->u.status, frame, sizeof frame);
        break;
    case TLM_TYPE_CALIBRATION:
        n = tlm_encode_calibration(b->seq, &msg->u.calibration, frame, sizeof frame);
        break;
    default:
        fail("unknown telemetry type");
    }
    check_encoded(n);
    append(b, frame, (size_t)n);
    tlm_text_telemetry(b->expected, b->seq, msg);
    b->counters.frames_ok += 1u;
    b->seq = (uint8_t)(b->seq + 1u);
}

static void add_command(struct builder *b, const struct tlm_command *cmd) {
    uint8_t frame[TLM_FRAME_MAX];
    const int n = tlm_encode_command(b->seq, cmd, frame, sizeof frame);
    check_encoded(n);
    append(b, frame, (size_t)n);
    tlm_text_command(b->expected, b->seq, cmd);
    b->counters.frames_ok += 1u;
    b->seq = (uint8_t)(b->seq + 1u);
}

static struct tlm_telemetry estimate(uint32_t t_ms, uint8_t estimator, int32_t alpha_udeg,
                                     int32_t beta_udeg, int32_t distance_um) {
    struct tlm_telemetry m;
    memset(&m, 0, sizeof m);
    m.type = TLM_TYPE_ESTIMATE;
    m.u.estimate = (struct tlm_estimate){.t_ms = t_ms,
                                         .window_index = t_ms / 2000u,
                                         .estimator = estimator,
                                         .status = TLM_STATUS_OK,
                                         .sensors_used = TLM_SENSOR_MASK_ALL,
                                         .alpha_udeg = alpha_udeg,
                                         .beta_udeg = beta_udeg,
                                         .distance_um = distance_um,
                                         .flatness_um = -37,
                                         .alpha_sd_udeg = 270123,
                                         .beta_sd_udeg = 1,
                                         .distance_sd_um = 1414,
                                         .why = 0};
    return m;
}

static void build(struct builder *b) {
    /* A boot banner on the same UART before the first frame. */
    static const char banner[] = "tof-attitude 0.1.0\r\nnucleo-l476rg\r\n";
    append_garbage(b, (const uint8_t *)banner, sizeof banner - 1);

    struct tlm_telemetry status;
    memset(&status, 0, sizeof status);
    status.type = TLM_TYPE_STATUS;
    status.u.status = (struct tlm_status){.fw_major = 0,
                                          .fw_minor = 1,
                                          .fw_patch = 0,
                                          .uptime_ms = 1234,
                                          .window_n = 100,
                                          .mode = TLM_WINDOW_TUMBLING,
                                          .estimator = TLM_ESTIMATOR_CONSENSUS,
                                          .running = true,
                                          .raw_stream = true,
                                          .period_ms = 20,
                                          .record = TLM_RECORD_LOADED,
                                          .arm_um = 30000u,
                                          .temp_known = true,
                                          .temp_cdeg = -5}; /* -0.05 degC */
    add_telemetry(b, &status);
    status.u.status.temp_known = false; /* a unit without a temperature */
    status.u.status.temp_cdeg = 0;
    add_telemetry(b, &status);

    /* Estimates of every estimator, signs and sizes across the range. */
    struct tlm_telemetry m = estimate(2000, TLM_ESTIMATOR_CONSENSUS, 1000000, 0, 100000000);
    add_telemetry(b, &m);
    m = estimate(2000, TLM_ESTIMATOR_KALMAN, 999871, -1234, 99998765);
    m.u.estimate.temp_known = true; /* the window's temperature, both ends of the range */
    m.u.estimate.temp_cdeg = TLM_TEMP_MIN_CDEG;
    add_telemetry(b, &m);
    m = estimate(4000, TLM_ESTIMATOR_CONSENSUS_PAPER, -2500000, 1500001, 250000);
    m.u.estimate.temp_known = true;
    m.u.estimate.temp_cdeg = TLM_TEMP_MAX_CDEG;
    add_telemetry(b, &m);
    m = estimate(4000, TLM_ESTIMATOR_MEAN, INT32_MAX, INT32_MIN + 1, 7);
    add_telemetry(b, &m);
    m = estimate(6000, TLM_ESTIMATOR_CONSENSUS, -1, 1, -1);
    m.u.estimate.status = TLM_STATUS_DEGRADED;
    /* the estimator's why bits (estimator/integrity.h), every group once */
    m.u.estimate.why = ATTITUDE_WHY_NO_TARGET(1) | ATTITUDE_WHY_RANGE(2) | ATTITUDE_WHY_FLAGGED(0) |
                       ATTITUDE_WHY_MISSING(3) | ATTITUDE_WHY_REJECTED(1) | ATTITUDE_WHY_PARITY |
                       ATTITUDE_WHY_MOTION | ATTITUDE_WHY_DRIFT |
                       ATTITUDE_WHY_REASON(ATTITUDE_REASON_KALMAN_RESTARTED);
    m.u.estimate.sensors_used = 0x0D; /* A, C, D */
    m.u.estimate.flatness_um = TLM_NO_VALUE;
    m.u.estimate.alpha_sd_udeg = 2000000000;
    add_telemetry(b, &m);
    m = estimate(8000, TLM_ESTIMATOR_KALMAN, TLM_NO_VALUE, 250, 100000);
    m.u.estimate.status = TLM_STATUS_INVALID;
    m.u.estimate.why = ATTITUDE_WHY_REASON(ATTITUDE_REASON_ALPHA_UNOBSERVABLE) |
                       ATTITUDE_WHY_REASON(ATTITUDE_REASON_PAPER_INCONSISTENT);
    m.u.estimate.sensors_used = 0x01;
    m.u.estimate.flatness_um = TLM_NO_VALUE;
    m.u.estimate.alpha_sd_udeg = TLM_NO_VALUE;
    add_telemetry(b, &m);
    m = estimate(10000, TLM_ESTIMATOR_MEAN, TLM_NO_VALUE, TLM_NO_VALUE, TLM_NO_VALUE);
    m.u.estimate.status = TLM_STATUS_INVALID;
    m.u.estimate.why = ATTITUDE_WHY_REASON(ATTITUDE_REASON_UNOBSERVABLE);
    m.u.estimate.sensors_used = 0;
    m.u.estimate.flatness_um = TLM_NO_VALUE;
    m.u.estimate.alpha_sd_udeg = TLM_NO_VALUE;
    m.u.estimate.beta_sd_udeg = TLM_NO_VALUE;
    m.u.estimate.distance_sd_um = TLM_NO_VALUE;
    add_telemetry(b, &m);

    /* Noise with a lone sync byte: discarded, no candidate frame. */
    static const uint8_t noise[] = {0x00, 0xFF, 0xA5, 0x00, 0x5A, 0x13};
    append_garbage(b, noise, sizeof noise);

    struct tlm_telemetry raw;
    memset(&raw, 0, sizeof raw);
    raw.type = TLM_TYPE_RAW_SAMPLE;
    raw.u.raw = (struct tlm_raw_sample){.t_ms = 8020,
                                        .range_mm = {98, 101, 0, 65535},
                                        .range_status = {0, 2, 0, 255},
                                        .present_mask = 0x0B};
    add_telemetry(b, &raw);

    struct tlm_telemetry health;
    memset(&health, 0, sizeof health);
    health.type = TLM_TYPE_HEALTH;
    struct tlm_health *h = &health.u.health;
    h->uptime_ms = 8100;
    h->sensor_state[0] = TLM_HEALTH_HEALTHY;
    h->sensor_state[1] = TLM_HEALTH_SUSPECT;
    h->sensor_state[2] = TLM_HEALTH_LOST;
    h->sensor_state[3] = TLM_HEALTH_RECOVERING;
    for (uint32_t i = 0; i < TLM_SENSOR_COUNT; ++i) {
        h->sensor[i] = (struct tlm_sensor_counters){.comm_errors = 10u * i + 1u,
                                                    .timeouts = 10u * i + 2u,
                                                    .flagged = 10u * i + 3u,
                                                    .reinits = 10u * i + 4u};
    }
    h->bus = (struct tlm_bus_counters){.addr_nack = 101,
                                       .data_nack = 102,
                                       .busy = 103,
                                       .timeout = 104,
                                       .stuck = 105,
                                       .other = 106,
                                       .recoveries = 107};
    h->watchdog_resets = 1;
    h->loop_overruns = 2;
    h->loop_max_us = 1999;
    h->tx_dropped = 4000000000u;
    h->link = (struct tlm_rx_counters){.frames_ok = 11,
                                       .bad_crc = 12,
                                       .bad_length = 13,
                                       .unknown_type = 14,
                                       .truncated = 15,
                                       .out_of_range = 16,
                                       .discarded_bytes = 17};
    h->uart_overruns = 18;
    add_telemetry(b, &health);

    struct tlm_telemetry ack;
    memset(&ack, 0, sizeof ack);
    ack.type = TLM_TYPE_ACK;
    ack.u.ack = (struct tlm_ack){.echo_seq = 4, .command = TLM_TYPE_SET_WINDOW, .result = 0};
    add_telemetry(b, &ack);
    ack.u.ack = (struct tlm_ack){.echo_seq = 5,
                                 .command = TLM_TYPE_SET_WINDOW,
                                 .result = TLM_RESULT_OUT_OF_RANGE,
                                 .error = ATTITUDE_ERR_WINDOW}; /* unchanged */
    add_telemetry(b, &ack);
    ack.u.ack = (struct tlm_ack){.echo_seq = 6, .command = 0x99, .result = 1};
    add_telemetry(b, &ack);

    /* Malformed 1: a bad CRC (one payload bit of an estimate flipped). */
    uint8_t frame[TLM_FRAME_MAX];
    m = estimate(10000, TLM_ESTIMATOR_CONSENSUS, 1000, 2000, 3000);
    int n = tlm_encode_estimate(b->seq, &m.u.estimate, frame, sizeof frame);
    check_encoded(n);
    frame[TLM_HEADER_SIZE + 12] ^= 0x04;
    append_garbage(b, frame, (size_t)n);
    b->counters.bad_crc += 1u;
    b->seq = (uint8_t)(b->seq + 1u);

    /* Malformed 2: a frame cut short after 12 bytes, then a good status frame:
     * the status is recovered and the cut frame counted as truncated. */
    n = tlm_encode_estimate(b->seq, &m.u.estimate, frame, sizeof frame);
    check_encoded(n);
    append_garbage(b, frame, 12);
    b->counters.truncated += 1u;
    b->seq = (uint8_t)(b->seq + 1u);
    status.u.status.running = false;
    status.u.status.uptime_ms = 10500;
    add_telemetry(b, &status);

    /* Malformed 3: a length byte above the maximum (the 3 header bytes). */
    static const uint8_t too_long[] = {TLM_SYNC0, TLM_SYNC1, 0xF0};
    append_garbage(b, too_long, sizeof too_long);
    b->counters.bad_length += 1u;

    /* Malformed 4: a CRC-valid frame of an undefined type, answered by a nack. */
    static const uint8_t payload[4] = {1, 2, 3, 4};
    n = tlm_frame_encode(0x42, b->seq, payload, sizeof payload, frame, sizeof frame);
    check_encoded(n);
    append_garbage(b, frame, (size_t)n);
    b->counters.unknown_type += 1u;
    tlm_text_reject(b->expected, b->seq, 0x42, sizeof payload, TLM_RESULT_UNKNOWN_TYPE);
    b->seq = (uint8_t)(b->seq + 1u);

    /* Malformed 5: a CRC-valid estimate with 4 payload bytes. */
    n = tlm_frame_encode(TLM_TYPE_ESTIMATE, b->seq, payload, sizeof payload, frame, sizeof frame);
    check_encoded(n);
    append_garbage(b, frame, (size_t)n);
    b->counters.bad_length += 1u;
    tlm_text_reject(b->expected, b->seq, TLM_TYPE_ESTIMATE, sizeof payload, TLM_RESULT_BAD_LENGTH);
    b->seq = (uint8_t)(b->seq + 1u);

    /* Malformed 6: a well-framed set-window of N = 1 (out of range). It passes
     * the link checks (frames_ok) and the parser rejects it. */
    static const uint8_t window_one[3] = {1, 0, 0};
    n = tlm_frame_encode(TLM_TYPE_SET_WINDOW, b->seq, window_one, sizeof window_one, frame,
                         sizeof frame);
    check_encoded(n);
    append(b, frame, (size_t)n);
    b->counters.frames_ok += 1u;
    b->counters.out_of_range += 1u;
    tlm_text_reject(b->expected, b->seq, TLM_TYPE_SET_WINDOW, sizeof window_one,
                    TLM_RESULT_OUT_OF_RANGE);
    b->seq = (uint8_t)(b->seq + 1u);

    /* The head's calibration as the firmware answers read-calibration: none stored, then a
     * section (the protocol checks its header; bytes of every value). */
    struct tlm_telemetry cal = {.type = TLM_TYPE_CALIBRATION};
    add_telemetry(b, &cal);
    cal.u.calibration.state = TLM_CAL_OTHER_HEAD;
    cal.u.calibration.section[0] = TLM_CAL_SECTION_ID;
    cal.u.calibration.section[1] = 4;
    cal.u.calibration.section[2] = TLM_CAL_SECTION_LEN - 4u;
    for (size_t i = 4; i < TLM_CAL_SECTION_LEN; ++i) {
        cal.u.calibration.section[i] = (uint8_t)(i * 37u);
    }
    add_telemetry(b, &cal);

    /* Every command, as a host would send them. */
    struct tlm_command cmd;
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SET_WINDOW;
    cmd.u.set_window.window_n = 255;
    cmd.u.set_window.mode = TLM_WINDOW_SLIDING;
    add_command(b, &cmd);
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SELECT_ESTIMATOR;
    cmd.u.estimator = TLM_ESTIMATOR_CONSENSUS_PAPER;
    add_command(b, &cmd);
    const uint8_t plain[] = {TLM_TYPE_START, TLM_TYPE_STOP, TLM_TYPE_STATUS_REQUEST, TLM_TYPE_SAVE,
                             TLM_TYPE_READ_CALIBRATION};
    for (size_t i = 0; i < sizeof plain; ++i) {
        memset(&cmd, 0, sizeof cmd);
        cmd.type = plain[i];
        add_command(b, &cmd);
    }
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_RAW_STREAM;
    cmd.u.raw_enable = true;
    add_command(b, &cmd);
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SET_PROCESS_NOISE;
    cmd.u.process_noise.qd_um2_per_s = 4294967295u; /* 4294.967295 mm²/s, the largest */
    cmd.u.process_noise.qt_um2_per_s = 10000u;      /* 0.01 mm²/s */
    add_command(b, &cmd);
    cmd.u.process_noise.flags = TLM_PROCESS_NOISE_AUTO;
    add_command(b, &cmd);
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SET_ARM;
    cmd.u.arm_um = 45250u;
    add_command(b, &cmd);
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_SET_PERIOD;
    cmd.u.period_ms = 33u;
    add_command(b, &cmd);
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_WRITE_CALIBRATION;
    cmd.u.cal_section[0] = TLM_CAL_SECTION_ID;
    cmd.u.cal_section[1] = 4;
    cmd.u.cal_section[2] = TLM_CAL_SECTION_LEN - 4u;
    for (size_t i = 4; i < TLM_CAL_SECTION_LEN; ++i) {
        cmd.u.cal_section[i] = (uint8_t)(255u - i);
    }
    add_command(b, &cmd);
    memset(&cmd, 0, sizeof cmd);
    cmd.type = TLM_TYPE_REZERO;
    cmd.u.rezero_samples = TLM_REZERO_MAX;
    add_command(b, &cmd);

    /* Malformed 7: the capture ends inside a frame (truncated at the flush). */
    m = estimate(12000, TLM_ESTIMATOR_MEAN, 5, 6, 7);
    n = tlm_encode_estimate(b->seq, &m.u.estimate, frame, sizeof frame);
    check_encoded(n);
    append_garbage(b, frame, 20);
    b->counters.truncated += 1u;

    tlm_text_counters(b->expected, &b->counters);
}

static int write_capture(const char *capture_path, const char *expected_path) {
    static struct builder b;
    b.expected = fopen(expected_path, "w");
    if (b.expected == NULL) {
        perror(expected_path);
        return 1;
    }
    build(&b);
    FILE *capture = fopen(capture_path, "wb");
    if (capture == NULL) {
        perror(capture_path);
        return 1;
    }
    const size_t written = fwrite(b.bytes, 1, b.len, capture);
    const int close_capture = fclose(capture);
    const int close_expected = fclose(b.expected);
    if (written != b.len || close_capture != 0 || close_expected != 0) {
        fprintf(stderr, "tlm_capture_tool: writing %s or %s failed\n", capture_path, expected_path);
        return 1;
    }
    return 0;
}

struct dump_ctx {
    struct tlm_decoder dec;
};

static void dump_frame(void *ctx, const struct tlm_frame *frame) {
    struct dump_ctx *d = ctx;
    tlm_text_frame(stdout, frame, &d->dec.counters);
}

static void dump_reject(void *ctx, const struct tlm_reject *reject) {
    (void)ctx;
    tlm_text_reject(stdout, reject->seq, reject->type, reject->length, reject->reason);
}

static int dump(const char *path) {
    FILE *in = fopen(path, "rb");
    if (in == NULL) {
        perror(path);
        return 1;
    }
    static struct dump_ctx d;
    const struct tlm_frame_sink sink = {
        .on_frame = dump_frame, .on_reject = dump_reject, .ctx = &d};
    tlm_decoder_init(&d.dec, tlm_message_types(TLM_ACCEPT_ALL));
    uint8_t chunk[4096];
    size_t got;
    while ((got = fread(chunk, 1, sizeof chunk, in)) > 0) {
        tlm_decoder_feed(&d.dec, chunk, got, &sink);
    }
    const int read_error = ferror(in);
    fclose(in);
    if (read_error) {
        fprintf(stderr, "tlm_capture_tool: reading %s failed\n", path);
        return 1;
    }
    tlm_decoder_flush(&d.dec, &sink);
    tlm_text_counters(stdout, &d.dec.counters);
    return 0;
}

int main(int argc, char **argv) {
    if (argc == 4 && strcmp(argv[1], "write") == 0) {
        return write_capture(argv[2], argv[3]);
    }
    if (argc == 3 && strcmp(argv[1], "dump") == 0) {
        return dump(argv[2]);
    }
    fprintf(stderr, "usage: tlm_capture_tool write CAPTURE.bin EXPECTED.txt\n"
                    "       tlm_capture_tool dump FILE\n");
    return 2;
}
