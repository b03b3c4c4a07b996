/*
 * libFuzzer target: the streaming frame decoder plus the message and command
 * parsers, on arbitrary bytes. Beyond "no crash, no sanitizer report" it
 * checks properties that hold for every input:
 *  - every byte is accounted for: delivered in a frame, discarded, or pending;
 *  - byte-at-a-time and whole-buffer feeding give identical counters;
 *  - every frame a parser accepts re-encodes to exactly the bytes received.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_input.h" /* FUZZ_CHECK */
#include "telemetry/tlm_frame.h"
#include "telemetry/tlm_messages.h"

struct fuzz_ctx {
    struct tlm_decoder dec;
    size_t frame_bytes;
    size_t frames;
    size_t rejects;
};

static int encode_telemetry(const struct tlm_telemetry *msg, uint8_t seq, uint8_t *out,
                            size_t cap) {
    switch (msg->type) {
    case TLM_TYPE_ESTIMATE:
        return tlm_encode_estimate(seq, &msg->u.estimate, out, cap);
    case TLM_TYPE_RAW_SAMPLE:
        return tlm_encode_raw_sample(seq, &msg->u.raw, out, cap);
    case TLM_TYPE_HEALTH:
        return tlm_encode_health(seq, &msg->u.health, out, cap);
    case TLM_TYPE_ACK:
        return tlm_encode_ack(seq, &msg->u.ack, out, cap);
    case TLM_TYPE_STATUS:
        return tlm_encode_status(seq, &msg->u.status, out, cap);
    case TLM_TYPE_CALIBRATION:
        return tlm_encode_calibration(seq, &msg->u.calibration, out, cap);
    default:
        return -1;
    }
}

static void on_frame(void *ctx, const struct tlm_frame *frame) {
    struct fuzz_ctx *f = ctx;
    f->frames++;
    f->frame_bytes += (size_t)frame->length + TLM_FRAME_OVERHEAD;
    FUZZ_CHECK(frame->length == tlm_type_payload_length(frame->type, TLM_ACCEPT_ALL));

    uint8_t original[TLM_FRAME_MAX];
    const int n = tlm_frame_encode(frame->type, frame->seq, frame->payload, frame->length, original,
                                   sizeof original);
    FUZZ_CHECK(n == (int)(frame->length + TLM_FRAME_OVERHEAD));

    uint8_t again[TLM_FRAME_MAX];
    int k = -1;
    enum tlm_result result;
    if (tlm_type_is_command(frame->type)) {
        struct tlm_command cmd;
        result = tlm_parse_command(frame, &cmd, &f->dec.counters);
        if (result == TLM_RESULT_OK) {
            k = tlm_encode_command(frame->seq, &cmd, again, sizeof again);
        }
    } else {
        struct tlm_telemetry msg;
        result = tlm_parse_telemetry(frame, &msg, &f->dec.counters);
        if (result == TLM_RESULT_OK) {
            k = encode_telemetry(&msg, frame->seq, again, sizeof again);
        }
    }
    /* The decoder already checked type and length: only field values can fail. */
    FUZZ_CHECK(result == TLM_RESULT_OK || result == TLM_RESULT_OUT_OF_RANGE);
    if (result == TLM_RESULT_OK) {
        FUZZ_CHECK(k == n);
        FUZZ_CHECK(memcmp(again, original, (size_t)n) == 0);
    }
}

static void on_reject(void *ctx, const struct tlm_reject *reject) {
    struct fuzz_ctx *f = ctx;
    f->rejects++;
    const int expected = tlm_type_payload_length(reject->type, TLM_ACCEPT_ALL);
    if (reject->reason == TLM_RESULT_UNKNOWN_TYPE) {
        FUZZ_CHECK(expected < 0);
    } else {
        FUZZ_CHECK(reject->reason == TLM_RESULT_BAD_LENGTH);
        FUZZ_CHECK(expected >= 0 && expected != reject->length);
    }
}

/* Run the decoder over `data` twice (byte by byte and whole) and check the properties. */
static void check_stream(const uint8_t *data, size_t size) {
    static struct fuzz_ctx bytewise, whole;
    memset(&bytewise, 0, sizeof bytewise);
    memset(&whole, 0, sizeof whole);
    const struct tlm_frame_sink sink1 = {
        .on_frame = on_frame, .on_reject = on_reject, .ctx = &bytewise};
    const struct tlm_frame_sink sink2 = {
        .on_frame = on_frame, .on_reject = on_reject, .ctx = &whole};
    tlm_decoder_init(&bytewise.dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_init(&whole.dec, tlm_message_types(TLM_ACCEPT_ALL));

    for (size_t i = 0; i < size; ++i) {
        tlm_decoder_push(&bytewise.dec, data[i], &sink1);
        FUZZ_CHECK(tlm_decoder_pending(&bytewise.dec) < TLM_FRAME_MAX);
        FUZZ_CHECK(bytewise.frame_bytes + bytewise.dec.counters.discarded_bytes +
                       tlm_decoder_pending(&bytewise.dec) ==
                   i + 1);
    }
    tlm_decoder_feed(&whole.dec, data, size, &sink2);
    FUZZ_CHECK(memcmp(&bytewise.dec.counters, &whole.dec.counters, sizeof whole.dec.counters) == 0);

    tlm_decoder_flush(&bytewise.dec, &sink1);
    FUZZ_CHECK(tlm_decoder_pending(&bytewise.dec) == 0);
    FUZZ_CHECK(bytewise.frame_bytes + bytewise.dec.counters.discarded_bytes == size);
    FUZZ_CHECK(bytewise.dec.counters.frames_ok == bytewise.frames);
    FUZZ_CHECK(bytewise.dec.counters.unknown_type + bytewise.dec.counters.bad_length >=
               bytewise.rejects);
}

/*
 * Random bytes almost never carry a valid CRC, so the parsers behind the
 * decoder would go unexplored. The second pass reads the input as records:
 * a control byte c, then either (c & 0x80) noise of (c & 0x3F) raw bytes, or
 * a frame of type = next byte and (c & 0x7F) payload bytes, encoded with a
 * valid CRC. Bit 6 of a noise control byte cuts the previous frame short.
 */
#define FRAMED_MAX 8192

static size_t build_framed(const uint8_t *data, size_t size, uint8_t *out) {
    size_t at = 0, n = 0, last_frame = 0;
    uint8_t seq = 0;
    while (at < size && n + TLM_FRAME_MAX <= FRAMED_MAX) {
        const uint8_t control = data[at++];
        if (control & 0x80u) {
            if ((control & 0x40u) && last_frame < n) {
                n = last_frame + (n - last_frame) / 2u; /* truncate the last frame */
            }
            size_t len = control & 0x3Fu;
            len = len < size - at ? len : size - at;
            memcpy(&out[n], &data[at], len);
            at += len;
            n += len;
        } else if (at < size) {
            const uint8_t type = data[at++];
            size_t len = control & 0x7Fu;
            len = len < size - at ? len : size - at;
            last_frame = n;
            const int k = tlm_frame_encode(type, seq++, &data[at], len, &out[n], FRAMED_MAX - n);
            FUZZ_CHECK(k == (int)(len + TLM_FRAME_OVERHEAD));
            at += len;
            n += (size_t)k;
        }
    }
    return n;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    check_stream(data, size);
    static uint8_t framed[FRAMED_MAX];
    const size_t n = build_framed(data, size, framed);
    check_stream(framed, n);
    return 0;
}
