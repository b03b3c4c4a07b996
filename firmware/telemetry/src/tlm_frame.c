/* Telemetry framing: the frame encoder and the resynchronising byte-stream decoder. */
#include "telemetry/tlm_frame.h"

#include <string.h>

#include "hal/hal_err.h"
#include "telemetry/tlm_crc.h"

/* Offsets inside a frame (tlm_frame.h). */
#define OFFSET_LENGTH  2u
#define OFFSET_TYPE    3u
#define OFFSET_SEQ     4u
#define OFFSET_PAYLOAD TLM_HEADER_SIZE

int tlm_frame_encode(uint8_t type, uint8_t seq, const uint8_t *payload, size_t length, uint8_t *out,
                     size_t cap) {
    if (out == NULL || length > TLM_MAX_PAYLOAD || (payload == NULL && length > 0u) ||
        cap < length + TLM_FRAME_OVERHEAD) {
        return HAL_ERR_INVALID;
    }
    if (length > 0u) {
        memmove(&out[OFFSET_PAYLOAD], payload, length); /* payload may already sit there */
    }
    out[0] = TLM_SYNC0;
    out[1] = TLM_SYNC1;
    out[OFFSET_LENGTH] = (uint8_t)length;
    out[OFFSET_TYPE] = type;
    out[OFFSET_SEQ] = seq;
    /* The CRC covers length, type, sequence and payload; the sync bytes are constant. */
    uint16_t crc = tlm_crc16(TLM_CRC_INIT, &out[OFFSET_LENGTH], length + 3u);
    out[OFFSET_PAYLOAD + length] = (uint8_t)(crc & 0xFFu);
    out[OFFSET_PAYLOAD + length + 1u] = (uint8_t)(crc >> 8);
    return (int)(length + TLM_FRAME_OVERHEAD);
}

void tlm_decoder_init(struct tlm_decoder *dec, const struct tlm_type_table *types) {
    memset(dec, 0, sizeof *dec);
    if (types != NULL) {
        dec->types = *types;
    }
}

/* The accepted length of `type`, -1 if not accepted (no table: nothing is). */
static int type_length(const struct tlm_decoder *dec, uint8_t type) {
    return dec->types.payload_length != NULL ? dec->types.payload_length(dec->types.ctx, type) : -1;
}

size_t tlm_decoder_pending(const struct tlm_decoder *dec) {
    return (size_t)dec->end - dec->start;
}

bool tlm_result_is_valid(uint8_t result) {
    return result <= (uint8_t)TLM_RESULT_LAST;
}

/*
 * Move the window start past `count` bytes. A CRC-failed frame still pending
 * (suspect_left > 0) whose span is now behind us had no good frame inside it:
 * it counts as a bad CRC.
 */
static void advance(struct tlm_decoder *dec, uint16_t count, bool discarded) {
    dec->start = (uint16_t)(dec->start + count);
    if (discarded) {
        dec->counters.discarded_bytes += count;
    }
    if (dec->suspect_left > 0u) {
        if (count >= dec->suspect_left) {
            dec->suspect_left = 0u;
            dec->counters.bad_crc += 1u;
        } else {
            dec->suspect_left = (uint16_t)(dec->suspect_left - count);
        }
    }
    if (dec->start == dec->end) {
        dec->start = 0u;
        dec->end = 0u;
    }
}

/*
 * A frame whose CRC is valid begins at the window start. If it begins inside
 * the span of an earlier CRC-failed frame, that frame was cut short (or its
 * length byte corrupted, which looks the same): count it as truncated.
 */
static void note_genuine_frame(struct tlm_decoder *dec) {
    if (dec->suspect_left > 0u) {
        dec->suspect_left = 0u;
        dec->counters.truncated += 1u;
    }
}

static void reject(struct tlm_decoder *dec, const struct tlm_frame_sink *sink,
                   enum tlm_result reason, uint8_t length) {
    const uint8_t *frame = &dec->window[dec->start];
    if (reason == TLM_RESULT_UNKNOWN_TYPE) {
        dec->counters.unknown_type += 1u;
    } else {
        dec->counters.bad_length += 1u;
    }
    if (sink != NULL && sink->on_reject != NULL) {
        const struct tlm_reject rejected = {.reason = reason,
                                            .type = frame[OFFSET_TYPE],
                                            .seq = frame[OFFSET_SEQ],
                                            .length = length};
        sink->on_reject(sink->ctx, &rejected);
    }
}

/* Outcome of examining the candidate at the window start. */
enum candidate {
    CANDIDATE_NEED_MORE, /* an incomplete but so far plausible frame */
    CANDIDATE_CONSUMED,  /* bytes were consumed; look at the new window start */
};

static enum candidate examine_candidate(struct tlm_decoder *dec,
                                        const struct tlm_frame_sink *sink) {
    const uint16_t available = (uint16_t)(dec->end - dec->start);
    const uint8_t *frame = &dec->window[dec->start];

    if (frame[0] != TLM_SYNC0) {
        advance(dec, 1u, true);
        return CANDIDATE_CONSUMED;
    }
    if (available < 2u) {
        return CANDIDATE_NEED_MORE;
    }
    if (frame[1] != TLM_SYNC1) {
        advance(dec, 1u, true);
        return CANDIDATE_CONSUMED;
    }
    if (available <= OFFSET_LENGTH) {
        return CANDIDATE_NEED_MORE;
    }
    const uint8_t length = frame[OFFSET_LENGTH];
    if (length > TLM_MAX_PAYLOAD) {
        /* Rejected before its CRC could be read: the sync may have been noise. */
        dec->counters.bad_length += 1u;
        advance(dec, 1u, true);
        return CANDIDATE_CONSUMED;
    }
    const uint16_t size = (uint16_t)(length + TLM_FRAME_OVERHEAD);
    if (available < size) {
        return CANDIDATE_NEED_MORE;
    }
    const uint16_t crc_received =
        (uint16_t)(frame[OFFSET_PAYLOAD + length] | (frame[OFFSET_PAYLOAD + length + 1u] << 8));
    const uint16_t crc = tlm_crc16(TLM_CRC_INIT, &frame[OFFSET_LENGTH], length + 3u);
    if (crc != crc_received) {
        /*
         * Whether this is a corrupted frame or one cut short by the next frame
         * is only known after rescanning its span; start that rescan one byte
         * in. A failure still pending from before is settled as a bad CRC.
         */
        const uint16_t span_left = (uint16_t)(size - 1u);
        advance(dec, 1u, true);
        if (dec->suspect_left > 0u) {
            dec->counters.bad_crc += 1u;
        }
        dec->suspect_left = span_left;
        return CANDIDATE_CONSUMED;
    }
    note_genuine_frame(dec);
    const int expected = type_length(dec, frame[OFFSET_TYPE]);
    if (expected < 0) {
        reject(dec, sink, TLM_RESULT_UNKNOWN_TYPE, length);
        advance(dec, size, true);
        return CANDIDATE_CONSUMED;
    }
    if ((uint8_t)expected != length) {
        reject(dec, sink, TLM_RESULT_BAD_LENGTH, length);
        advance(dec, size, true);
        return CANDIDATE_CONSUMED;
    }
    dec->counters.frames_ok += 1u;
    if (sink != NULL && sink->on_frame != NULL) {
        const struct tlm_frame accepted = {.type = frame[OFFSET_TYPE],
                                           .seq = frame[OFFSET_SEQ],
                                           .length = length,
                                           .payload = &frame[OFFSET_PAYLOAD]};
        sink->on_frame(sink->ctx, &accepted);
    }
    advance(dec, size, false);
    return CANDIDATE_CONSUMED;
}

/*
 * Examine candidates until the window is empty or holds an incomplete one.
 * Each pass consumes at least one byte, so the window size bounds the passes.
 */
static void scan(struct tlm_decoder *dec, const struct tlm_frame_sink *sink) {
    for (uint16_t pass = 0; pass <= TLM_FRAME_MAX && dec->start < dec->end; ++pass) {
        if (examine_candidate(dec, sink) == CANDIDATE_NEED_MORE) {
            return;
        }
    }
}

void tlm_decoder_push(struct tlm_decoder *dec, uint8_t byte, const struct tlm_frame_sink *sink) {
    if (dec->end == TLM_FRAME_MAX) {
        /* Slide the pending candidate to the front; it is shorter than a frame. */
        const uint16_t pending = (uint16_t)(dec->end - dec->start);
        memmove(dec->window, &dec->window[dec->start], pending);
        dec->start = 0u;
        dec->end = pending;
    }
    if (dec->end == TLM_FRAME_MAX) {
        /*
         * Unreachable: scan() resolves any candidate as soon as it is a full
         * frame long. Kept so that no input can write past the window; the
         * byte is then counted as discarded, not lost silently.
         */
        dec->counters.discarded_bytes += 1u;
        return;
    }
    dec->window[dec->end] = byte;
    dec->end = (uint16_t)(dec->end + 1u);
    scan(dec, sink);
}

void tlm_decoder_feed(struct tlm_decoder *dec, const uint8_t *data, size_t len,
                      const struct tlm_frame_sink *sink) {
    for (size_t i = 0; i < len; ++i) {
        tlm_decoder_push(dec, data[i], sink);
    }
}

void tlm_decoder_flush(struct tlm_decoder *dec, const struct tlm_frame_sink *sink) {
    for (uint16_t pass = 0; pass <= TLM_FRAME_MAX && dec->start < dec->end; ++pass) {
        const uint16_t available = (uint16_t)(dec->end - dec->start);
        /* A lone sync byte at the end may be noise; a full sync pair began a frame. */
        if (available >= 2u) {
            dec->counters.truncated += 1u;
        }
        advance(dec, 1u, true);
        scan(dec, sink);
    }
    if (dec->suspect_left > 0u) {
        dec->suspect_left = 0u;
        dec->counters.bad_crc += 1u;
    }
}
