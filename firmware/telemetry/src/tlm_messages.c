/* Telemetry messages and commands: encoders and validating parsers (types: tlm_types.c). */
#include "telemetry/tlm_messages.h"

#include <string.h>

#include "hal/hal_err.h"
#include "telemetry/tlm_crc.h"

/* --- little-endian byte order helpers ------------------------------------ */

struct writer {
    uint8_t *buf;
    size_t at;
};

static void put_u8(struct writer *w, uint8_t value) {
    w->buf[w->at] = value;
    w->at += 1u;
}

static void put_u16(struct writer *w, uint16_t value) {
    put_u8(w, (uint8_t)(value & 0xFFu));
    put_u8(w, (uint8_t)(value >> 8));
}

static void put_u32(struct writer *w, uint32_t value) {
    put_u16(w, (uint16_t)(value & 0xFFFFu));
    put_u16(w, (uint16_t)(value >> 16));
}

static void put_i32(struct writer *w, int32_t value) {
    put_u32(w, (uint32_t)value); /* two's complement by definition of the conversion */
}

struct reader {
    const uint8_t *buf;
    size_t at;
};

static uint8_t get_u8(struct reader *r) {
    uint8_t value = r->buf[r->at];
    r->at += 1u;
    return value;
}

static uint16_t get_u16(struct reader *r) {
    uint16_t low = get_u8(r);
    uint16_t high = get_u8(r);
    return (uint16_t)(low | (uint16_t)(high << 8));
}

static uint32_t get_u32(struct reader *r) {
    uint32_t low = get_u16(r);
    uint32_t high = get_u16(r);
    return low | (high << 16);
}

static int32_t get_i32(struct reader *r) {
    uint32_t value = get_u32(r);
    if (value <= (uint32_t)INT32_MAX) {
        return (int32_t)value;
    }
    /* value - 2^32 without implementation-defined unsigned-to-signed conversion. */
    return (int32_t)(value - 0x80000000u) + INT32_MIN;
}

/*
 * Write the header and CRC around a payload already built at out +
 * TLM_HEADER_SIZE. The caller checked the capacity.
 */
static int finish_frame(uint8_t type, uint8_t seq, uint8_t *out, size_t payload_len, size_t cap) {
    return tlm_frame_encode(type, seq, &out[TLM_HEADER_SIZE], payload_len, out, cap);
}

static bool has_room(const uint8_t *out, size_t cap, size_t payload_len) {
    return out != NULL && cap >= payload_len + TLM_FRAME_OVERHEAD;
}

static void count_result(struct tlm_rx_counters *counters, enum tlm_result result) {
    if (counters == NULL) {
        return;
    }
    switch (result) {
    case TLM_RESULT_UNKNOWN_TYPE:
        counters->unknown_type += 1u;
        break;
    case TLM_RESULT_BAD_LENGTH:
        counters->bad_length += 1u;
        break;
    case TLM_RESULT_OUT_OF_RANGE:
        counters->out_of_range += 1u;
        break;
    case TLM_RESULT_OK:
    case TLM_RESULT_STATE:
    default:
        break;
    }
}

/* --- estimate ------------------------------------------------------------- */

/* A value and its sd are present together; a present sd is at least 1 (never 0). */
static bool value_and_sd_agree(int32_t value, int32_t sd) {
    return (value == TLM_NO_VALUE) == (sd == TLM_NO_VALUE) && (sd == TLM_NO_VALUE || sd >= 1);
}

static bool estimate_is_valid(const struct tlm_estimate *m) {
    if (m->estimator > TLM_ESTIMATOR_LAST || m->status > TLM_STATUS_LAST ||
        (m->sensors_used & ~TLM_SENSOR_MASK_ALL) != 0u) {
        return false;
    }
    if (!value_and_sd_agree(m->alpha_udeg, m->alpha_sd_udeg) ||
        !value_and_sd_agree(m->beta_udeg, m->beta_sd_udeg) ||
        !value_and_sd_agree(m->distance_um, m->distance_sd_um)) {
        return false;
    }
    const bool alpha = m->alpha_udeg != TLM_NO_VALUE;
    const bool beta = m->beta_udeg != TLM_NO_VALUE;
    /* A status says why it is not ok: exactly the non-ok statuses carry a reason. */
    const bool ok = m->status == TLM_STATUS_OK;
    if (ok != (m->why == 0u)) {
        return false;
    }
    if (ok) {
        return m->sensors_used == TLM_SENSOR_MASK_ALL && m->flatness_um != TLM_NO_VALUE && alpha &&
               beta && m->distance_um != TLM_NO_VALUE;
    }
    /* invalid: at least one angle could not be estimated; degraded: both were */
    return (m->status == TLM_STATUS_INVALID) == !(alpha && beta);
}

int tlm_encode_estimate(uint8_t seq, const struct tlm_estimate *msg, uint8_t *out, size_t cap) {
    if (msg == NULL || !has_room(out, cap, TLM_LEN_ESTIMATE) || !estimate_is_valid(msg)) {
        return HAL_ERR_INVALID;
    }
    struct writer w = {.buf = &out[TLM_HEADER_SIZE], .at = 0};
    put_u32(&w, msg->t_ms);
    put_u32(&w, msg->window_index);
    put_u8(&w, msg->estimator);
    put_u8(&w, msg->status);
    put_u8(&w, msg->sensors_used);
    put_i32(&w, msg->alpha_udeg);
    put_i32(&w, msg->beta_udeg);
    put_i32(&w, msg->distance_um);
    put_i32(&w, msg->flatness_um);
    put_i32(&w, msg->alpha_sd_udeg);
    put_i32(&w, msg->beta_sd_udeg);
    put_i32(&w, msg->distance_sd_um);
    put_u32(&w, (uint32_t)(msg->why & 0xFFFFFFFFu));
    put_u32(&w, (uint32_t)(msg->why >> 32));
    return finish_frame(TLM_TYPE_ESTIMATE, seq, out, w.at, cap);
}

static enum tlm_result parse_estimate(struct reader *r, struct tlm_estimate *m) {
    m->t_ms = get_u32(r);
    m->window_index = get_u32(r);
    m->estimator = get_u8(r);
    m->status = get_u8(r);
    m->sensors_used = get_u8(r);
    m->alpha_udeg = get_i32(r);
    m->beta_udeg = get_i32(r);
    m->distance_um = get_i32(r);
    m->flatness_um = get_i32(r);
    m->alpha_sd_udeg = get_i32(r);
    m->beta_sd_udeg = get_i32(r);
    m->distance_sd_um = get_i32(r);
    const uint64_t low = get_u32(r);
    const uint64_t high = get_u32(r);
    m->why = low | (high << 32);
    return estimate_is_valid(m) ? TLM_RESULT_OK : TLM_RESULT_OUT_OF_RANGE;
}

enum tlm_result tlm_decode_estimate(const uint8_t *bytes, size_t len, struct tlm_estimate *out) {
    memset(out, 0, sizeof *out);
    if (bytes == NULL || len != TLM_LEN_ESTIMATE + TLM_FRAME_OVERHEAD || bytes[0] != TLM_SYNC0 ||
        bytes[1] != TLM_SYNC1 || bytes[2] != TLM_LEN_ESTIMATE) {
        return TLM_RESULT_BAD_LENGTH;
    }
    if (bytes[3] != TLM_TYPE_ESTIMATE) {
        return TLM_RESULT_UNKNOWN_TYPE;
    }
    /* CRC over length, type, sequence and payload (tlm_frame.h) */
    const uint16_t crc = tlm_crc16(TLM_CRC_INIT, &bytes[2], TLM_LEN_ESTIMATE + 3u);
    const size_t at = TLM_HEADER_SIZE + TLM_LEN_ESTIMATE;
    if (crc != (uint16_t)(bytes[at] | (bytes[at + 1u] << 8))) {
        return TLM_RESULT_OUT_OF_RANGE;
    }
    struct reader r = {.buf = &bytes[TLM_HEADER_SIZE], .at = 0};
    return parse_estimate(&r, out);
}

/* --- raw sample ----------------------------------------------------------- */

static bool raw_sample_is_valid(const struct tlm_raw_sample *m) {
    if ((m->present_mask & ~TLM_SENSOR_MASK_ALL) != 0u) {
        return false;
    }
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        const bool present = (m->present_mask & (1u << i)) != 0u;
        if (!present && (m->range_mm[i] != 0u || m->range_status[i] != 0u)) {
            return false; /* an absent reading has no value to report */
        }
    }
    return true;
}

int tlm_encode_raw_sample(uint8_t seq, const struct tlm_raw_sample *msg, uint8_t *out, size_t cap) {
    if (msg == NULL || !has_room(out, cap, TLM_LEN_RAW_SAMPLE) || !raw_sample_is_valid(msg)) {
        return HAL_ERR_INVALID;
    }
    struct writer w = {.buf = &out[TLM_HEADER_SIZE], .at = 0};
    put_u32(&w, msg->t_ms);
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        put_u16(&w, msg->range_mm[i]);
    }
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        put_u8(&w, msg->range_status[i]);
    }
    put_u8(&w, msg->present_mask);
    return finish_frame(TLM_TYPE_RAW_SAMPLE, seq, out, w.at, cap);
}

static enum tlm_result parse_raw_sample(struct reader *r, struct tlm_raw_sample *m) {
    m->t_ms = get_u32(r);
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        m->range_mm[i] = get_u16(r);
    }
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        m->range_status[i] = get_u8(r);
    }
    m->present_mask = get_u8(r);
    return raw_sample_is_valid(m) ? TLM_RESULT_OK : TLM_RESULT_OUT_OF_RANGE;
}

/* --- health --------------------------------------------------------------- */

static bool health_is_valid(const struct tlm_health *m) {
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        if (m->sensor_state[i] > TLM_HEALTH_LAST) {
            return false;
        }
    }
    return true;
}

static void put_rx_counters(struct writer *w, const struct tlm_rx_counters *c) {
    put_u32(w, c->frames_ok);
    put_u32(w, c->bad_crc);
    put_u32(w, c->bad_length);
    put_u32(w, c->unknown_type);
    put_u32(w, c->truncated);
    put_u32(w, c->out_of_range);
    put_u32(w, c->discarded_bytes);
}

static void get_rx_counters(struct reader *r, struct tlm_rx_counters *c) {
    c->frames_ok = get_u32(r);
    c->bad_crc = get_u32(r);
    c->bad_length = get_u32(r);
    c->unknown_type = get_u32(r);
    c->truncated = get_u32(r);
    c->out_of_range = get_u32(r);
    c->discarded_bytes = get_u32(r);
}

int tlm_encode_health(uint8_t seq, const struct tlm_health *msg, uint8_t *out, size_t cap) {
    if (msg == NULL || !has_room(out, cap, TLM_LEN_HEALTH) || !health_is_valid(msg)) {
        return HAL_ERR_INVALID;
    }
    struct writer w = {.buf = &out[TLM_HEADER_SIZE], .at = 0};
    put_u32(&w, msg->uptime_ms);
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        put_u8(&w, msg->sensor_state[i]);
    }
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        put_u32(&w, msg->sensor[i].comm_errors);
        put_u32(&w, msg->sensor[i].timeouts);
        put_u32(&w, msg->sensor[i].flagged);
        put_u32(&w, msg->sensor[i].reinits);
    }
    put_u32(&w, msg->bus.addr_nack);
    put_u32(&w, msg->bus.data_nack);
    put_u32(&w, msg->bus.busy);
    put_u32(&w, msg->bus.timeout);
    put_u32(&w, msg->bus.stuck);
    put_u32(&w, msg->bus.other);
    put_u32(&w, msg->bus.recoveries);
    put_u32(&w, msg->watchdog_resets);
    put_u32(&w, msg->loop_overruns);
    put_u32(&w, msg->loop_max_us);
    put_u32(&w, msg->tx_dropped);
    put_rx_counters(&w, &msg->link);
    put_u32(&w, msg->uart_overruns);
    return finish_frame(TLM_TYPE_HEALTH, seq, out, w.at, cap);
}

static enum tlm_result parse_health(struct reader *r, struct tlm_health *m) {
    m->uptime_ms = get_u32(r);
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        m->sensor_state[i] = get_u8(r);
    }
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        m->sensor[i].comm_errors = get_u32(r);
        m->sensor[i].timeouts = get_u32(r);
        m->sensor[i].flagged = get_u32(r);
        m->sensor[i].reinits = get_u32(r);
    }
    m->bus.addr_nack = get_u32(r);
    m->bus.data_nack = get_u32(r);
    m->bus.busy = get_u32(r);
    m->bus.timeout = get_u32(r);
    m->bus.stuck = get_u32(r);
    m->bus.other = get_u32(r);
    m->bus.recoveries = get_u32(r);
    m->watchdog_resets = get_u32(r);
    m->loop_overruns = get_u32(r);
    m->loop_max_us = get_u32(r);
    m->tx_dropped = get_u32(r);
    get_rx_counters(r, &m->link);
    m->uart_overruns = get_u32(r);
    return health_is_valid(m) ? TLM_RESULT_OK : TLM_RESULT_OUT_OF_RANGE;
}

/* --- ack ------------------------------------------------------------------ */

static bool ack_is_valid(const struct tlm_ack *m) {
    return tlm_result_is_valid(m->result) && m->error <= 0 &&
           (m->result != (uint8_t)TLM_RESULT_OK || m->error == 0);
}

int tlm_encode_ack(uint8_t seq, const struct tlm_ack *msg, uint8_t *out, size_t cap) {
    if (msg == NULL || !has_room(out, cap, TLM_LEN_ACK) || !ack_is_valid(msg)) {
        return HAL_ERR_INVALID;
    }
    struct writer w = {.buf = &out[TLM_HEADER_SIZE], .at = 0};
    put_u8(&w, msg->echo_seq);
    put_u8(&w, msg->command);
    put_u8(&w, msg->result);
    put_u8(&w, (uint8_t)msg->error); /* two's complement by definition of the conversion */
    return finish_frame(TLM_TYPE_ACK, seq, out, w.at, cap);
}

static enum tlm_result parse_ack(struct reader *r, struct tlm_ack *m) {
    m->echo_seq = get_u8(r);
    m->command = get_u8(r);
    m->result = get_u8(r);
    const uint8_t raw = get_u8(r);
    m->error = (int8_t)(raw <= 127u ? (int)raw : (int)raw - 256);
    return ack_is_valid(m) ? TLM_RESULT_OK : TLM_RESULT_OUT_OF_RANGE;
}

/* --- status --------------------------------------------------------------- */

static bool window_is_valid(uint16_t window_n, uint8_t mode) {
    return window_n >= TLM_WINDOW_MIN && window_n <= TLM_WINDOW_MAX && mode <= TLM_WINDOW_MODE_LAST;
}

static bool status_is_valid(const struct tlm_status *m) {
    return window_is_valid(m->window_n, m->mode) && m->estimator <= TLM_ESTIMATOR_LAST &&
           m->record <= TLM_RECORD_STATE_LAST && /* enum tlm_record_state */
           m->calibration <= TLM_CAL_STATE_LAST; /* enum tlm_cal_state */
}

int tlm_encode_status(uint8_t seq, const struct tlm_status *msg, uint8_t *out, size_t cap) {
    if (msg == NULL || !has_room(out, cap, TLM_LEN_STATUS) || !status_is_valid(msg)) {
        return HAL_ERR_INVALID;
    }
    struct writer w = {.buf = &out[TLM_HEADER_SIZE], .at = 0};
    put_u8(&w, msg->fw_major);
    put_u8(&w, msg->fw_minor);
    put_u8(&w, msg->fw_patch);
    put_u8(&w, TLM_PROTOCOL_VERSION);
    put_u32(&w, msg->uptime_ms);
    put_u16(&w, msg->window_n);
    put_u8(&w, msg->mode);
    put_u8(&w, msg->estimator);
    put_u8(&w, msg->running ? 1u : 0u);
    put_u8(&w, msg->raw_stream ? 1u : 0u);
    put_u16(&w, msg->period_ms);
    put_u8(&w, msg->record);
    put_u8(&w, msg->calibration);
    return finish_frame(TLM_TYPE_STATUS, seq, out, w.at, cap);
}

/* A wire boolean is 0 or 1; anything else is out of range, not "true". */
static bool get_bool(struct reader *r, bool *value) {
    uint8_t raw = get_u8(r);
    *value = raw == 1u;
    return raw <= 1u;
}

static enum tlm_result parse_status(struct reader *r, struct tlm_status *m) {
    m->fw_major = get_u8(r);
    m->fw_minor = get_u8(r);
    m->fw_patch = get_u8(r);
    const uint8_t protocol = get_u8(r);
    m->uptime_ms = get_u32(r);
    m->window_n = get_u16(r);
    m->mode = get_u8(r);
    m->estimator = get_u8(r);
    const bool running_ok = get_bool(r, &m->running);
    const bool raw_ok = get_bool(r, &m->raw_stream);
    m->period_ms = get_u16(r);
    m->record = get_u8(r);
    m->calibration = get_u8(r);
    if (protocol != TLM_PROTOCOL_VERSION || !running_ok || !raw_ok || !status_is_valid(m)) {
        return TLM_RESULT_OUT_OF_RANGE;
    }
    return TLM_RESULT_OK;
}

/* --- calibration ---------------------------------------------------------- */

static enum tlm_result parse_calibration(const uint8_t *p, struct tlm_calibration *m) {
    m->state = p[0];
    memcpy(m->section, &p[1], TLM_CAL_SECTION_LEN);
    return m->state <= TLM_CAL_STATE_LAST && tlm_cal_section_is_valid(m->section, true)
               ? TLM_RESULT_OK
               : TLM_RESULT_OUT_OF_RANGE;
}

/* --- commands ------------------------------------------------------------- */

/* The protocol's range of set-process-noise: only the defined flag bits. The intensities
 * are any uint32; what Q per row they give at the sample period is the estimator's to
 * accept or refuse (the nack then carries its code). */
static bool process_noise_is_valid(uint8_t flags) {
    return (flags & ~TLM_PROCESS_NOISE_AUTO) == 0u;
}

int tlm_encode_command(uint8_t seq, const struct tlm_command *cmd, uint8_t *out, size_t cap) {
    if (cmd == NULL || out == NULL) {
        return HAL_ERR_INVALID;
    }
    const int length = tlm_type_payload_length(cmd->type, TLM_ACCEPT_COMMANDS);
    if (length < 0 || !has_room(out, cap, (size_t)length)) {
        return HAL_ERR_INVALID;
    }
    struct writer w = {.buf = &out[TLM_HEADER_SIZE], .at = 0};
    switch (cmd->type) {
    case TLM_TYPE_SET_WINDOW:
        if (!window_is_valid(cmd->u.set_window.window_n, cmd->u.set_window.mode)) {
            return HAL_ERR_INVALID;
        }
        put_u16(&w, cmd->u.set_window.window_n);
        put_u8(&w, cmd->u.set_window.mode);
        break;
    case TLM_TYPE_SELECT_ESTIMATOR:
        if (cmd->u.estimator > TLM_ESTIMATOR_LAST) {
            return HAL_ERR_INVALID;
        }
        put_u8(&w, cmd->u.estimator);
        break;
    case TLM_TYPE_RAW_STREAM:
        put_u8(&w, cmd->u.raw_enable ? 1u : 0u);
        break;
    case TLM_TYPE_SET_PROCESS_NOISE:
        if (!process_noise_is_valid(cmd->u.process_noise.flags)) {
            return HAL_ERR_INVALID;
        }
        put_u32(&w, cmd->u.process_noise.qd_um2_per_s);
        put_u32(&w, cmd->u.process_noise.qt_um2_per_s);
        put_u8(&w, cmd->u.process_noise.flags);
        break;
    case TLM_TYPE_WRITE_CALIBRATION:
        if (!tlm_cal_section_is_valid(cmd->u.cal_section, false)) {
            return HAL_ERR_INVALID;
        }
        memcpy(w.buf, cmd->u.cal_section, TLM_CAL_SECTION_LEN);
        w.at = TLM_CAL_SECTION_LEN;
        break;
    case TLM_TYPE_REZERO:
        if (cmd->u.rezero_samples < TLM_REZERO_MIN || cmd->u.rezero_samples > TLM_REZERO_MAX) {
            return HAL_ERR_INVALID;
        }
        put_u16(&w, cmd->u.rezero_samples);
        break;
    default: /* start, stop, status request, save, read-calibration: no payload */
        break;
    }
    return finish_frame(cmd->type, seq, out, w.at, cap);
}

enum tlm_result tlm_parse_command(const struct tlm_frame *frame, struct tlm_command *out,
                                  struct tlm_rx_counters *counters) {
    enum tlm_result result = TLM_RESULT_OK;
    const int length = tlm_type_payload_length(frame->type, TLM_ACCEPT_COMMANDS);
    memset(out, 0, sizeof *out);
    if (length < 0) {
        result = TLM_RESULT_UNKNOWN_TYPE;
    } else if (frame->length != (size_t)length || (frame->length > 0u && frame->payload == NULL)) {
        result = TLM_RESULT_BAD_LENGTH;
    } else {
        struct reader r = {.buf = frame->payload, .at = 0};
        out->type = frame->type;
        switch (frame->type) {
        case TLM_TYPE_SET_WINDOW:
            out->u.set_window.window_n = get_u16(&r);
            out->u.set_window.mode = get_u8(&r);
            if (!window_is_valid(out->u.set_window.window_n, out->u.set_window.mode)) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_SELECT_ESTIMATOR:
            out->u.estimator = get_u8(&r);
            if (out->u.estimator > TLM_ESTIMATOR_LAST) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_RAW_STREAM:
            if (!get_bool(&r, &out->u.raw_enable)) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_SET_PROCESS_NOISE:
            out->u.process_noise.qd_um2_per_s = get_u32(&r);
            out->u.process_noise.qt_um2_per_s = get_u32(&r);
            out->u.process_noise.flags = get_u8(&r);
            if (!process_noise_is_valid(out->u.process_noise.flags)) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_WRITE_CALIBRATION:
            memcpy(out->u.cal_section, frame->payload, TLM_CAL_SECTION_LEN);
            if (!tlm_cal_section_is_valid(out->u.cal_section, false)) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_REZERO:
            out->u.rezero_samples = get_u16(&r);
            if (out->u.rezero_samples < TLM_REZERO_MIN || out->u.rezero_samples > TLM_REZERO_MAX) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        default: /* start, stop, status request, save, read-calibration: length only */
            break;
        }
    }
    count_result(counters, result);
    return result;
}

/* --- telemetry parse ------------------------------------------------------ */

enum tlm_result tlm_parse_telemetry(const struct tlm_frame *frame, struct tlm_telemetry *out,
                                    struct tlm_rx_counters *counters) {
    enum tlm_result result = TLM_RESULT_OK;
    const int length = tlm_type_payload_length(frame->type, TLM_ACCEPT_TELEMETRY);
    memset(out, 0, sizeof *out);
    if (length < 0) {
        result = TLM_RESULT_UNKNOWN_TYPE;
    } else if (frame->length != (size_t)length || frame->payload == NULL) {
        result = TLM_RESULT_BAD_LENGTH; /* every telemetry type has a payload */
    } else {
        struct reader r = {.buf = frame->payload, .at = 0};
        out->type = frame->type;
        switch (frame->type) {
        case TLM_TYPE_ESTIMATE:
            result = parse_estimate(&r, &out->u.estimate);
            break;
        case TLM_TYPE_RAW_SAMPLE:
            result = parse_raw_sample(&r, &out->u.raw);
            break;
        case TLM_TYPE_HEALTH:
            result = parse_health(&r, &out->u.health);
            break;
        case TLM_TYPE_ACK:
            result = parse_ack(&r, &out->u.ack);
            break;
        case TLM_TYPE_CALIBRATION:
            result = parse_calibration(frame->payload, &out->u.calibration);
            break;
        default: /* TLM_TYPE_STATUS */
            result = parse_status(&r, &out->u.status);
            break;
        }
    }
    count_result(counters, result);
    return result;
}
