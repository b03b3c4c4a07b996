/*
 * The telemetry codecs' shared wire helpers (internal to firmware/telemetry/src): little-endian
 * writer and reader, the frame's finishing, the parse counters, and the field ranges that
 * messages and commands share (docs/reference/telemetry-protocol.md).
 */
#ifndef TELEMETRY_TLM_WIRE_H
#define TELEMETRY_TLM_WIRE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "telemetry/tlm_crc.h"
#include "telemetry/tlm_messages.h"

/* --- little-endian byte order helpers ------------------------------------ */

struct writer {
    uint8_t *buf;
    size_t at;
};

static inline void put_u8(struct writer *w, uint8_t value) {
    w->buf[w->at] = value;
    w->at += 1u;
}

static inline void put_u16(struct writer *w, uint16_t value) {
    put_u8(w, (uint8_t)(value & 0xFFu));
    put_u8(w, (uint8_t)(value >> 8));
}

static inline void put_u32(struct writer *w, uint32_t value) {
    put_u16(w, (uint16_t)(value & 0xFFFFu));
    put_u16(w, (uint16_t)(value >> 16));
}

static inline void put_i32(struct writer *w, int32_t value) {
    put_u32(w, (uint32_t)value); /* two's complement by definition of the conversion */
}

struct reader {
    const uint8_t *buf;
    size_t at;
};

static inline uint8_t get_u8(struct reader *r) {
    uint8_t value = r->buf[r->at];
    r->at += 1u;
    return value;
}

static inline uint16_t get_u16(struct reader *r) {
    uint16_t low = get_u8(r);
    uint16_t high = get_u8(r);
    return (uint16_t)(low | (uint16_t)(high << 8));
}

static inline uint32_t get_u32(struct reader *r) {
    uint32_t low = get_u16(r);
    uint32_t high = get_u16(r);
    return low | (high << 16);
}

static inline int32_t get_i32(struct reader *r) {
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
static inline int finish_frame(uint8_t type, uint8_t seq, uint8_t *out, size_t payload_len,
                               size_t cap) {
    return tlm_frame_encode(type, seq, &out[TLM_HEADER_SIZE], payload_len, out, cap);
}

static inline bool has_room(const uint8_t *out, size_t cap, size_t payload_len) {
    return out != NULL && cap >= payload_len + TLM_FRAME_OVERHEAD;
}

static inline void count_result(struct tlm_rx_counters *counters, enum tlm_result result) {
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

/* --- field ranges shared by messages and commands ------------------------ */

static inline bool window_is_valid(uint16_t window_n, uint8_t mode) {
    return window_n >= TLM_WINDOW_MIN && window_n <= TLM_WINDOW_MAX && mode <= TLM_WINDOW_MODE_LAST;
}

static inline bool arm_is_valid(uint32_t arm_um) {
    return arm_um >= TLM_ARM_MIN_UM && arm_um <= TLM_ARM_MAX_UM;
}

static inline bool period_is_valid(uint16_t period_ms) {
    return period_ms >= TLM_PERIOD_MIN_MS && period_ms <= TLM_PERIOD_MAX_MS;
}

/* A wire boolean is 0 or 1; anything else is out of range, not "true". */
static inline bool get_bool(struct reader *r, bool *value) {
    uint8_t raw = get_u8(r);
    *value = raw == 1u;
    return raw <= 1u;
}

static inline void put_temp(struct writer *w, bool known, int16_t cdeg) {
    put_u8(w, known ? 1u : 0u);
    put_u16(w, (uint16_t)cdeg); /* two's complement by definition of the conversion */
}

/* The known byte and the temperature; false for a known byte other than 0 or 1. */
static inline bool get_temp(struct reader *r, bool *known, int16_t *cdeg) {
    const bool byte_ok = get_bool(r, known);
    const uint16_t raw = get_u16(r);
    *cdeg = (int16_t)(raw <= 0x7FFFu ? (int32_t)raw : (int32_t)raw - 65536);
    return byte_ok;
}

#endif /* TELEMETRY_TLM_WIRE_H */
