/* Telemetry messages: encoders and validating parsers (commands: tlm_commands.c; types:
 * tlm_types.c). */
#include "telemetry/tlm_messages.h"

#include <string.h>

#include "hal/hal_err.h"

#include "tlm_wire.h"

/* A temperature (TLM_TEMP_*): within range when known, 0 when not, so a parsed message
 * re-encodes to the bytes it came from. One copy for the estimate and the status. */
static __attribute__((noinline)) bool temp_is_valid(bool known, int16_t cdeg) {
    return known ? cdeg >= TLM_TEMP_MIN_CDEG && cdeg <= TLM_TEMP_MAX_CDEG : cdeg == 0;
}

/* --- estimate ------------------------------------------------------------- */

/* A value and its sd are present together; a present sd is at least 1 (never 0). */
static bool value_and_sd_agree(int32_t value, int32_t sd) {
    return (value == TLM_NO_VALUE) == (sd == TLM_NO_VALUE) && (sd == TLM_NO_VALUE || sd >= 1);
}

static bool estimate_is_valid(const struct tlm_estimate *m) {
    if (m->estimator > TLM_ESTIMATOR_LAST || m->status > TLM_STATUS_LAST ||
        (m->sensors_used & ~TLM_SENSOR_MASK_ALL) != 0u ||
        !temp_is_valid(m->temp_known, m->temp_cdeg)) {
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
    put_temp(&w, msg->temp_known, msg->temp_cdeg);
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
    const bool temp_ok = get_temp(r, &m->temp_known, &m->temp_cdeg);
    return temp_ok && estimate_is_valid(m) ? TLM_RESULT_OK : TLM_RESULT_OUT_OF_RANGE;
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

static bool status_is_valid(const struct tlm_status *m) {
    return window_is_valid(m->window_n, m->mode) && m->estimator <= TLM_ESTIMATOR_LAST &&
           m->record <= TLM_RECORD_STATE_LAST &&   /* enum tlm_record_state */
           m->calibration <= TLM_CAL_STATE_LAST && /* enum tlm_cal_state */
           m->cal_age <= TLM_CAL_AGE_STATE_LAST && /* enum tlm_cal_age_state */
           arm_is_valid(m->arm_um) && period_is_valid(m->period_ms) &&
           temp_is_valid(m->temp_known, m->temp_cdeg);
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
    put_u32(&w, msg->arm_um);
    put_u32(&w, msg->cal_age_s);
    put_u8(&w, msg->cal_age);
    put_temp(&w, msg->temp_known, msg->temp_cdeg);
    return finish_frame(TLM_TYPE_STATUS, seq, out, w.at, cap);
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
    m->arm_um = get_u32(r);
    m->cal_age_s = get_u32(r);
    m->cal_age = get_u8(r);
    const bool temp_ok = get_temp(r, &m->temp_known, &m->temp_cdeg);
    if (protocol != TLM_PROTOCOL_VERSION || !running_ok || !raw_ok || !temp_ok ||
        !status_is_valid(m)) {
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
