/*
 * Telemetry link layer: frame encoding byte for byte, and the streaming
 * decoder: resynchronisation after garbage and partial frames, every class of
 * malformed frame counted once, frames split across arbitrary boundaries.
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

/* Expected frames computed independently (bitwise CRC in Python), as in
 * docs/reference/telemetry-protocol.md. */
static const uint8_t start_seq0[] = {0xA5, 0x5A, 0x00, 0x83, 0x00, 0x57, 0x82};
static const uint8_t set_window_100_seq1[] = {0xA5, 0x5A, 0x03, 0x81, 0x01,
                                              0x64, 0x00, 0x00, 0x6E, 0x79};
static const uint8_t ack_seq9[] = {0xA5, 0x5A, 0x04, 0x04, 0x09, 0x01,
                                   0x81, 0x00, 0x00, 0x0B, 0xE4};

static struct tlm_rx_counters zero_counters(void) {
    struct tlm_rx_counters c;
    memset(&c, 0, sizeof c);
    return c;
}

static void assert_counters(const struct tlm_rx_counters *got, const struct tlm_rx_counters *want) {
    assert_int_equal(got->frames_ok, want->frames_ok);
    assert_int_equal(got->bad_crc, want->bad_crc);
    assert_int_equal(got->bad_length, want->bad_length);
    assert_int_equal(got->unknown_type, want->unknown_type);
    assert_int_equal(got->truncated, want->truncated);
    assert_int_equal(got->out_of_range, want->out_of_range);
    assert_int_equal(got->discarded_bytes, want->discarded_bytes);
}

/* Every byte pushed is in a delivered frame, discarded, or still pending. */
static void assert_bytes_accounted(const struct tlm_decoder *dec, const struct recorder *rec,
                                   size_t pushed) {
    assert_int_equal(rec->frame_bytes + dec->counters.discarded_bytes + tlm_decoder_pending(dec),
                     pushed);
}

static void test_encode_matches_reference_bytes(void **state) {
    (void)state;
    uint8_t out[TLM_FRAME_MAX];
    assert_int_equal(tlm_frame_encode(0x83, 0, NULL, 0, out, sizeof out), sizeof start_seq0);
    assert_memory_equal(out, start_seq0, sizeof start_seq0);

    const uint8_t window_payload[] = {0x64, 0x00, 0x00};
    assert_int_equal(tlm_frame_encode(0x81, 1, window_payload, 3, out, sizeof out),
                     sizeof set_window_100_seq1);
    assert_memory_equal(out, set_window_100_seq1, sizeof set_window_100_seq1);

    const uint8_t ack_payload[] = {0x01, 0x81, 0x00, 0x00};
    assert_int_equal(tlm_frame_encode(0x04, 9, ack_payload, 4, out, sizeof out), sizeof ack_seq9);
    assert_memory_equal(out, ack_seq9, sizeof ack_seq9);
}

static void test_encode_rejects_bad_arguments(void **state) {
    (void)state;
    uint8_t payload[TLM_MAX_PAYLOAD + 1] = {0};
    uint8_t out[TLM_FRAME_MAX + 1];
    /* Too long a payload, a buffer one byte short, missing pointers. */
    assert_int_equal(tlm_frame_encode(1, 0, payload, TLM_MAX_PAYLOAD + 1, out, sizeof out),
                     HAL_ERR_INVALID);
    assert_int_equal(tlm_frame_encode(1, 0, payload, 10, out, 10 + TLM_FRAME_OVERHEAD - 1),
                     HAL_ERR_INVALID);
    assert_int_equal(tlm_frame_encode(1, 0, NULL, 1, out, sizeof out), HAL_ERR_INVALID);
    assert_int_equal(tlm_frame_encode(1, 0, payload, 1, NULL, sizeof out), HAL_ERR_INVALID);
    /* The limits themselves are fine. */
    assert_int_equal(tlm_frame_encode(1, 0, payload, TLM_MAX_PAYLOAD, out, TLM_FRAME_MAX),
                     TLM_FRAME_MAX);
    assert_int_equal(tlm_frame_encode(1, 0, payload, 10, out, 10 + TLM_FRAME_OVERHEAD),
                     10 + TLM_FRAME_OVERHEAD);
}

static void test_decodes_a_single_frame(void **state) {
    (void)state;
    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    for (size_t i = 0; i < sizeof set_window_100_seq1; ++i) {
        assert_int_equal(rec.frame_count, 0); /* nothing before the last byte */
        tlm_decoder_push(&dec, set_window_100_seq1[i], &sink);
    }
    assert_int_equal(rec.frame_count, 1);
    assert_int_equal(rec.frames[0].type, 0x81);
    assert_int_equal(rec.frames[0].seq, 1);
    assert_int_equal(rec.frames[0].length, 3);
    assert_memory_equal(rec.frames[0].payload, &set_window_100_seq1[5], 3);
    struct tlm_rx_counters want = zero_counters();
    want.frames_ok = 1;
    assert_counters(&dec.counters, &want);
    assert_int_equal(tlm_decoder_pending(&dec), 0);
}

static void test_decoder_sink_may_have_no_callbacks(void **state) {
    (void)state;
    struct tlm_decoder dec;
    const struct tlm_frame_sink quiet = {.on_frame = NULL, .on_reject = NULL, .ctx = NULL};
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_COMMANDS));
    tlm_decoder_feed(&dec, start_seq0, sizeof start_seq0, &quiet);
    tlm_decoder_feed(&dec, ack_seq9, sizeof ack_seq9, NULL); /* telemetry: unknown here */
    assert_int_equal(dec.counters.frames_ok, 1);
    assert_int_equal(dec.counters.unknown_type, 1);
}

static void test_resynchronises_after_garbage(void **state) {
    (void)state;
    /* Garbage with sync look-alikes: a lone A5, A5 A5 5A (second A5 is the real
     * start of a pair), and 5A A5 reversed. */
    uint8_t stream[128];
    size_t n = 0;
    const uint8_t garbage1[] = {0x00, 0xFF, 0xA5, 0x13, 0x5A, 0xA5, 0x77};
    memcpy(&stream[n], garbage1, sizeof garbage1);
    n += sizeof garbage1;
    memcpy(&stream[n], start_seq0, sizeof start_seq0);
    n += sizeof start_seq0;
    const uint8_t garbage2[] = {0x5A, 0xA5, 0xA5};
    memcpy(&stream[n], garbage2, sizeof garbage2);
    n += sizeof garbage2;
    memcpy(&stream[n], ack_seq9, sizeof ack_seq9);
    n += sizeof ack_seq9;

    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, stream, n, &sink);
    assert_int_equal(rec.frame_count, 2);
    assert_int_equal(rec.frames[0].type, TLM_TYPE_START);
    assert_int_equal(rec.frames[1].type, TLM_TYPE_ACK);
    assert_int_equal(rec.frames[1].seq, 9);
    struct tlm_rx_counters want = zero_counters();
    want.frames_ok = 2;
    want.discarded_bytes = sizeof garbage1 + sizeof garbage2;
    assert_counters(&dec.counters, &want);
    assert_bytes_accounted(&dec, &rec, n);
}

static void test_bad_crc_is_counted_and_next_frame_kept(void **state) {
    (void)state;
    uint8_t stream[64];
    memcpy(stream, set_window_100_seq1, sizeof set_window_100_seq1);
    stream[6] ^= 0x01; /* one payload bit */
    memcpy(&stream[sizeof set_window_100_seq1], start_seq0, sizeof start_seq0);
    const size_t n = sizeof set_window_100_seq1 + sizeof start_seq0;

    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, stream, n, &sink);
    assert_int_equal(rec.frame_count, 1);
    assert_int_equal(rec.frames[0].type, TLM_TYPE_START);
    assert_int_equal(rec.reject_count, 0); /* a bad CRC is never answered: seq untrustworthy */
    struct tlm_rx_counters want = zero_counters();
    want.frames_ok = 1;
    want.bad_crc = 1;
    want.discarded_bytes = sizeof set_window_100_seq1;
    assert_counters(&dec.counters, &want);
    assert_bytes_accounted(&dec, &rec, n);
}

static void test_corrupt_crc_bytes_are_a_bad_crc(void **state) {
    (void)state;
    for (size_t byte = 5; byte < 7; ++byte) {
        uint8_t frame[sizeof start_seq0];
        memcpy(frame, start_seq0, sizeof frame);
        frame[byte] ^= 0x80;
        struct tlm_decoder dec;
        struct recorder rec;
        const struct tlm_frame_sink sink = recorder_sink(&rec);
        tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
        tlm_decoder_feed(&dec, frame, sizeof frame, &sink);
        tlm_decoder_flush(&dec, &sink);
        assert_int_equal(rec.frame_count, 0);
        assert_int_equal(dec.counters.bad_crc, 1);
        assert_int_equal(dec.counters.truncated, 0);
        assert_int_equal(dec.counters.discarded_bytes, sizeof frame);
    }
}

static void test_length_above_maximum_is_bad_length(void **state) {
    (void)state;
    const uint8_t stream[] = {0xA5, 0x5A, (uint8_t)(TLM_MAX_PAYLOAD + 1u), 0x01, 0x00};
    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, stream, sizeof stream, &sink);
    tlm_decoder_feed(&dec, start_seq0, sizeof start_seq0, &sink);
    assert_int_equal(rec.frame_count, 1);
    struct tlm_rx_counters want = zero_counters();
    want.frames_ok = 1;
    want.bad_length = 1;
    want.discarded_bytes = sizeof stream;
    assert_counters(&dec.counters, &want);
    /* Exactly the maximum is a legal length: it waits for the rest of the frame. */
    const uint8_t max_header[] = {0xA5, 0x5A, (uint8_t)TLM_MAX_PAYLOAD};
    tlm_decoder_feed(&dec, max_header, sizeof max_header, &sink);
    assert_int_equal(tlm_decoder_pending(&dec), 3);
    assert_int_equal(dec.counters.bad_length, 1);
}

static void test_unknown_type_is_counted_and_reported(void **state) {
    (void)state;
    uint8_t frame[16];
    const int n = tlm_frame_encode(0x42, 77, NULL, 0, frame, sizeof frame);
    assert_int_equal(n, 7);

    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, frame, (size_t)n, &sink);
    assert_int_equal(rec.frame_count, 0);
    assert_int_equal(rec.reject_count, 1);
    assert_int_equal(rec.rejects[0].reason, TLM_RESULT_UNKNOWN_TYPE);
    assert_int_equal(rec.rejects[0].type, 0x42);
    assert_int_equal(rec.rejects[0].seq, 77);
    struct tlm_rx_counters want = zero_counters();
    want.unknown_type = 1;
    want.discarded_bytes = 7;
    assert_counters(&dec.counters, &want);
}

static void test_direction_filter(void **state) {
    (void)state;
    /* The firmware's decoder accepts commands only; a host decoder telemetry only. */
    struct tlm_decoder fw, host;
    struct recorder fw_rec, host_rec;
    const struct tlm_frame_sink fw_sink = recorder_sink(&fw_rec);
    const struct tlm_frame_sink host_sink = recorder_sink(&host_rec);
    tlm_decoder_init(&fw, tlm_message_types(TLM_ACCEPT_COMMANDS));
    tlm_decoder_init(&host, tlm_message_types(TLM_ACCEPT_TELEMETRY));
    for (int pass = 0; pass < 2; ++pass) {
        tlm_decoder_feed(&fw, start_seq0, sizeof start_seq0, &fw_sink);
        tlm_decoder_feed(&fw, ack_seq9, sizeof ack_seq9, &fw_sink);
        tlm_decoder_feed(&host, start_seq0, sizeof start_seq0, &host_sink);
        tlm_decoder_feed(&host, ack_seq9, sizeof ack_seq9, &host_sink);
    }
    assert_int_equal(fw_rec.frame_count, 2);
    assert_int_equal(fw_rec.frames[0].type, TLM_TYPE_START);
    assert_int_equal(fw.counters.unknown_type, 2);
    assert_int_equal(fw_rec.rejects[0].type, TLM_TYPE_ACK);
    assert_int_equal(host_rec.frame_count, 2);
    assert_int_equal(host_rec.frames[0].type, TLM_TYPE_ACK);
    assert_int_equal(host.counters.unknown_type, 2);
    assert_int_equal(host_rec.rejects[1].type, TLM_TYPE_START);
}

static void test_wrong_payload_length_for_type_is_bad_length(void **state) {
    (void)state;
    /* A CRC-valid start command carrying one byte, and a set-window with two. */
    const uint8_t one = 0x00;
    const uint8_t two[] = {0x64, 0x00};
    uint8_t stream[32];
    int n1 = tlm_frame_encode(TLM_TYPE_START, 3, &one, 1, stream, sizeof stream);
    assert_true(n1 > 0);
    int n2 =
        tlm_frame_encode(TLM_TYPE_SET_WINDOW, 4, two, 2, &stream[n1], sizeof stream - (size_t)n1);
    assert_true(n2 > 0);

    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_COMMANDS));
    tlm_decoder_feed(&dec, stream, (size_t)(n1 + n2), &sink);
    assert_int_equal(rec.frame_count, 0);
    assert_int_equal(rec.reject_count, 2);
    assert_int_equal(rec.rejects[0].reason, TLM_RESULT_BAD_LENGTH);
    assert_int_equal(rec.rejects[0].seq, 3);
    assert_int_equal(rec.rejects[0].length, 1);
    assert_int_equal(rec.rejects[1].reason, TLM_RESULT_BAD_LENGTH);
    assert_int_equal(rec.rejects[1].type, TLM_TYPE_SET_WINDOW);
    struct tlm_rx_counters want = zero_counters();
    want.bad_length = 2;
    want.discarded_bytes = (uint32_t)(n1 + n2);
    assert_counters(&dec.counters, &want);
}

static void test_truncated_frame_followed_by_good_frame(void **state) {
    (void)state;
    /* The first 6 bytes of a set-window (sender reset mid-frame), then a whole
     * frame: the decoder takes the good frame's bytes as the tail of the
     * first, fails its CRC, rescans and still finds the good frame. */
    uint8_t stream[64];
    size_t n = 0;
    memcpy(stream, set_window_100_seq1, 6);
    n += 6;
    memcpy(&stream[n], ack_seq9, sizeof ack_seq9);
    n += sizeof ack_seq9;
    memcpy(&stream[n], start_seq0, sizeof start_seq0);
    n += sizeof start_seq0;

    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, stream, n, &sink);
    assert_int_equal(rec.frame_count, 2);
    assert_int_equal(rec.frames[0].type, TLM_TYPE_ACK);
    assert_int_equal(rec.frames[1].type, TLM_TYPE_START);
    struct tlm_rx_counters want = zero_counters();
    want.frames_ok = 2;
    want.truncated = 1;
    want.discarded_bytes = 6;
    assert_counters(&dec.counters, &want);
    assert_bytes_accounted(&dec, &rec, n);
}

static void test_truncated_frame_at_end_of_stream(void **state) {
    (void)state;
    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, start_seq0, sizeof start_seq0, &sink);
    tlm_decoder_feed(&dec, set_window_100_seq1, 8, &sink);
    assert_int_equal(tlm_decoder_pending(&dec), 8);
    assert_int_equal(dec.counters.truncated, 0); /* could still complete */
    tlm_decoder_flush(&dec, &sink);
    assert_int_equal(tlm_decoder_pending(&dec), 0);
    struct tlm_rx_counters want = zero_counters();
    want.frames_ok = 1;
    want.truncated = 1;
    want.discarded_bytes = 8;
    assert_counters(&dec.counters, &want);
    /* The decoder hunts again afterwards. */
    tlm_decoder_feed(&dec, ack_seq9, sizeof ack_seq9, &sink);
    assert_int_equal(rec.frame_count, 2);
}

static void test_flush_recovers_frame_behind_truncated_one(void **state) {
    (void)state;
    /* A header claiming 150 payload bytes, then a complete start frame, then
     * the line goes idle: only the flush can tell the start frame was real. */
    uint8_t stream[32];
    const uint8_t header[] = {0xA5, 0x5A, 150, 0x01, 0x05};
    memcpy(stream, header, sizeof header);
    memcpy(&stream[sizeof header], start_seq0, sizeof start_seq0);
    const size_t n = sizeof header + sizeof start_seq0;

    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, stream, n, &sink);
    assert_int_equal(rec.frame_count, 0);
    tlm_decoder_flush(&dec, &sink);
    assert_int_equal(rec.frame_count, 1);
    assert_int_equal(rec.frames[0].type, TLM_TYPE_START);
    struct tlm_rx_counters want = zero_counters();
    want.frames_ok = 1;
    want.truncated = 1;
    want.discarded_bytes = sizeof header;
    assert_counters(&dec.counters, &want);
}

static void test_lone_sync_byte_at_flush_is_not_a_frame(void **state) {
    (void)state;
    struct tlm_decoder dec;
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_push(&dec, TLM_SYNC0, NULL);
    assert_int_equal(tlm_decoder_pending(&dec), 1);
    tlm_decoder_flush(&dec, NULL);
    struct tlm_rx_counters want = zero_counters();
    want.discarded_bytes = 1;
    assert_counters(&dec.counters, &want);
}

static void test_sync_pattern_inside_payload(void **state) {
    (void)state;
    /* Payload bytes that look like a frame start must not disturb anything. */
    const uint8_t payload[] = {0xA5, 0x5A, 0x00, 0x83, 0x00, 0x57, 0x82, 0xA5, 0x5A,
                               0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0xA5};
    assert_int_equal(sizeof payload, TLM_LEN_RAW_SAMPLE);
    uint8_t frame[TLM_FRAME_MAX];
    const int n =
        tlm_frame_encode(TLM_TYPE_RAW_SAMPLE, 5, payload, sizeof payload, frame, sizeof frame);
    assert_int_equal(n, TLM_LEN_RAW_SAMPLE + TLM_FRAME_OVERHEAD);
    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, frame, (size_t)n, &sink);
    assert_int_equal(rec.frame_count, 1);
    assert_memory_equal(rec.frames[0].payload, payload, sizeof payload);
    assert_int_equal(dec.counters.discarded_bytes, 0);
}

/* A stream of seven frames of different sizes, including a maximum one. */
static size_t build_stream(uint8_t *out, size_t cap) {
    size_t n = 0;
    uint8_t payload[TLM_MAX_PAYLOAD];
    for (size_t i = 0; i < sizeof payload; ++i) {
        payload[i] = (uint8_t)(i * 7u + 0xA5u);
    }
    const size_t lengths[] = {0, 1, 3, TLM_MAX_PAYLOAD, 28, 0, 144};
    for (size_t f = 0; f < sizeof lengths / sizeof lengths[0]; ++f) {
        /* Framing does not depend on the type. Type 0x42 is outside the type
         * table, so each frame comes out as a rejection carrying its seq: that
         * records the framing just as well and allows any payload length. */
        const int k = tlm_frame_encode(0x42, (uint8_t)f, payload, lengths[f], &out[n], cap - n);
        assert_true(k > 0);
        n += (size_t)k;
    }
    return n;
}

static void test_frames_split_at_every_boundary(void **state) {
    (void)state;
    static uint8_t stream[2048];
    const size_t n = build_stream(stream, sizeof stream);

    /* Reference: whole stream in one feed. */
    struct tlm_decoder ref;
    struct recorder ref_rec;
    const struct tlm_frame_sink ref_sink = recorder_sink(&ref_rec);
    tlm_decoder_init(&ref, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&ref, stream, n, &ref_sink);
    assert_int_equal(ref_rec.reject_count, 7);
    assert_int_equal(ref.counters.unknown_type, 7);
    assert_int_equal(ref.counters.bad_crc + ref.counters.bad_length + ref.counters.truncated, 0);

    /* Two chunks split at every position, then chunks of every size 1..64. */
    static struct recorder rec;
    for (size_t split = 0; split <= n; ++split) {
        struct tlm_decoder dec;
        const struct tlm_frame_sink sink = recorder_sink(&rec);
        tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
        tlm_decoder_feed(&dec, stream, split, &sink);
        tlm_decoder_feed(&dec, &stream[split], n - split, &sink);
        assert_int_equal(rec.reject_count, 7);
        assert_memory_equal(rec.rejects, ref_rec.rejects, 7 * sizeof rec.rejects[0]);
        assert_counters(&dec.counters, &ref.counters);
    }
    for (size_t chunk = 1; chunk <= 64; ++chunk) {
        struct tlm_decoder dec;
        const struct tlm_frame_sink sink = recorder_sink(&rec);
        tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
        for (size_t at = 0; at < n; at += chunk) {
            tlm_decoder_feed(&dec, &stream[at], (at + chunk <= n) ? chunk : n - at, &sink);
        }
        assert_counters(&dec.counters, &ref.counters);
        assert_int_equal(rec.reject_count, 7);
    }
}

static void test_known_frames_split_at_every_boundary(void **state) {
    (void)state;
    /* Accepted frames (not rejects) in arbitrary chunks: identical deliveries. */
    uint8_t stream[64];
    size_t n = 0;
    memcpy(&stream[n], set_window_100_seq1, sizeof set_window_100_seq1);
    n += sizeof set_window_100_seq1;
    memcpy(&stream[n], ack_seq9, sizeof ack_seq9);
    n += sizeof ack_seq9;
    memcpy(&stream[n], start_seq0, sizeof start_seq0);
    n += sizeof start_seq0;
    for (size_t a = 0; a <= n; ++a) {
        for (size_t b = a; b <= n; ++b) {
            struct tlm_decoder dec;
            struct recorder rec;
            const struct tlm_frame_sink sink = recorder_sink(&rec);
            tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
            tlm_decoder_feed(&dec, stream, a, &sink);
            tlm_decoder_feed(&dec, &stream[a], b - a, &sink);
            tlm_decoder_feed(&dec, &stream[b], n - b, &sink);
            assert_int_equal(rec.frame_count, 3);
            assert_int_equal(rec.frames[0].type, TLM_TYPE_SET_WINDOW);
            assert_memory_equal(rec.frames[0].payload, &set_window_100_seq1[5], 3);
            assert_int_equal(rec.frames[1].seq, 9);
            assert_int_equal(rec.frames[2].type, TLM_TYPE_START);
            assert_int_equal(dec.counters.discarded_bytes, 0);
        }
    }
}

static uint32_t lcg_next(uint32_t *x) {
    *x = *x * 1664525u + 1013904223u; /* Numerical Recipes LCG */
    return *x >> 8;
}

static void test_every_frame_survives_random_noise(void **state) {
    (void)state;
    /* 300 ack frames, each preceded by 0..40 random bytes (biased toward the
     * sync bytes to provoke false candidates): every frame must come out, in
     * order, and every byte must be accounted for. */
    static uint8_t stream[300 * (11 + 40)];
    size_t n = 0;
    uint32_t x = 2024u;
    for (unsigned f = 0; f < 300; ++f) {
        const uint32_t garbage = lcg_next(&x) % 41u;
        for (uint32_t g = 0; g < garbage; ++g) {
            const uint32_t r = lcg_next(&x);
            stream[n++] = (r % 4u == 0u) ? TLM_SYNC0 : (r % 4u == 1u) ? TLM_SYNC1 : (uint8_t)r;
        }
        const struct tlm_ack ack = {.echo_seq = (uint8_t)f, .command = 0x81, .result = 0};
        const int k = tlm_encode_ack((uint8_t)f, &ack, &stream[n], sizeof stream - n);
        assert_int_equal(k, 11);
        n += (size_t)k;
    }
    struct tlm_decoder dec;
    static struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_TELEMETRY));
    tlm_decoder_feed(&dec, stream, n, &sink);
    tlm_decoder_flush(&dec, &sink);
    assert_int_equal(rec.frame_count, 300);
    for (unsigned f = 0; f < 300; ++f) {
        assert_int_equal(rec.frames[f].seq, (uint8_t)f);
        assert_int_equal(rec.frames[f].payload[0], (uint8_t)f);
    }
    assert_int_equal(dec.counters.frames_ok, 300);
    assert_bytes_accounted(&dec, &rec, n);
    /* False candidates in the noise were counted, not delivered. */
    assert_true(dec.counters.bad_length + dec.counters.bad_crc + dec.counters.truncated > 0);
}

static void test_init_resets_state_and_counters(void **state) {
    (void)state;
    struct tlm_decoder dec;
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    tlm_decoder_feed(&dec, set_window_100_seq1, 7, NULL);
    dec.counters.bad_crc = 5;
    tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_ALL));
    assert_int_equal(tlm_decoder_pending(&dec), 0);
    struct tlm_rx_counters want = zero_counters();
    assert_counters(&dec.counters, &want);
}

static void test_result_codes(void **state) {
    (void)state;
    for (unsigned r = 0; r <= 10; ++r) { /* ok .. busy (tlm_frame.h) */
        assert_true(tlm_result_is_valid((uint8_t)r));
    }
    assert_int_equal(TLM_RESULT_LAST, TLM_RESULT_BUSY);
    assert_false(tlm_result_is_valid(11));
    assert_false(tlm_result_is_valid(0xFF));
}

/* The framing knows nothing of the messages: a table of its own (type 0x42, 2 bytes)
 * decides what a decoder accepts, and no table accepts nothing. */
static int own_length(const void *ctx, uint8_t type) {
    const uint8_t *only = ctx;
    return type == only[0] ? (int)only[1] : -1;
}

static void test_framing_takes_its_type_table(void **state) {
    (void)state;
    static const uint8_t only[2] = {0x42, 2};
    const struct tlm_type_table table = {.payload_length = own_length, .ctx = only};
    uint8_t frame[TLM_FRAME_MAX];
    const uint8_t payload[2] = {0xBE, 0xEF};
    const int n = tlm_frame_encode(0x42, 7, payload, sizeof payload, frame, sizeof frame);
    assert_int_equal(n, 2 + (int)TLM_FRAME_OVERHEAD);
    struct tlm_decoder dec;
    struct recorder rec;
    const struct tlm_frame_sink sink = recorder_sink(&rec);
    tlm_decoder_init(&dec, &table);
    tlm_decoder_feed(&dec, frame, (size_t)n, &sink);
    tlm_decoder_feed(&dec, start_seq0, sizeof start_seq0, &sink); /* a protocol command */
    assert_int_equal(rec.frame_count, 1);
    assert_int_equal(rec.frames[0].type, 0x42);
    assert_memory_equal(rec.frames[0].payload, payload, 2);
    assert_int_equal(dec.counters.unknown_type, 1);
    /* The same frame with a length the table does not give is a bad length. */
    const uint8_t three[3] = {1, 2, 3};
    const int m = tlm_frame_encode(0x42, 8, three, sizeof three, frame, sizeof frame);
    tlm_decoder_feed(&dec, frame, (size_t)m, &sink);
    assert_int_equal(dec.counters.bad_length, 1);
    /* No table: every CRC-valid frame is of unknown type. */
    tlm_decoder_init(&dec, NULL);
    tlm_decoder_feed(&dec, start_seq0, sizeof start_seq0, &sink);
    assert_int_equal(dec.counters.unknown_type, 1);
    assert_int_equal(dec.counters.frames_ok, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_encode_matches_reference_bytes),
        cmocka_unit_test(test_encode_rejects_bad_arguments),
        cmocka_unit_test(test_decodes_a_single_frame),
        cmocka_unit_test(test_decoder_sink_may_have_no_callbacks),
        cmocka_unit_test(test_resynchronises_after_garbage),
        cmocka_unit_test(test_bad_crc_is_counted_and_next_frame_kept),
        cmocka_unit_test(test_corrupt_crc_bytes_are_a_bad_crc),
        cmocka_unit_test(test_length_above_maximum_is_bad_length),
        cmocka_unit_test(test_unknown_type_is_counted_and_reported),
        cmocka_unit_test(test_direction_filter),
        cmocka_unit_test(test_wrong_payload_length_for_type_is_bad_length),
        cmocka_unit_test(test_truncated_frame_followed_by_good_frame),
        cmocka_unit_test(test_truncated_frame_at_end_of_stream),
        cmocka_unit_test(test_flush_recovers_frame_behind_truncated_one),
        cmocka_unit_test(test_lone_sync_byte_at_flush_is_not_a_frame),
        cmocka_unit_test(test_sync_pattern_inside_payload),
        cmocka_unit_test(test_frames_split_at_every_boundary),
        cmocka_unit_test(test_known_frames_split_at_every_boundary),
        cmocka_unit_test(test_every_frame_survives_random_noise),
        cmocka_unit_test(test_init_resets_state_and_counters),
        cmocka_unit_test(test_result_codes),
        cmocka_unit_test(test_framing_takes_its_type_table),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
