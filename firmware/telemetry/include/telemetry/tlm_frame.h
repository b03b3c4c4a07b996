/*
 * Telemetry link layer: the frame format, a frame encoder into a caller
 * buffer, and a streaming byte-at-a-time decoder that resynchronises after
 * garbage and counts every class of malformed frame. Byte layouts, the
 * resynchronisation rule and examples: docs/reference/telemetry-protocol.md.
 *
 *   offset  size  field
 *   0       1     sync 0xA5
 *   1       1     sync 0x5A
 *   2       1     length: payload bytes, 0..TLM_MAX_PAYLOAD
 *   3       1     type (its meaning and length: the decoder's struct tlm_type_table)
 *   4       1     sequence (per sender, +1 per frame, wraps 255 -> 0)
 *   5       len   payload (multi-byte fields little-endian)
 *   5+len   2     CRC-16/CCITT-FALSE over bytes 2 .. 4+len, little-endian
 */
#ifndef TELEMETRY_TLM_FRAME_H
#define TELEMETRY_TLM_FRAME_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define TLM_SYNC0          0xA5u /* 1010 0101: see docs/reference/telemetry-protocol.md for the choice */
#define TLM_SYNC1          0x5Au /* 0101 1010: bitwise complement of TLM_SYNC0 */
#define TLM_HEADER_SIZE    5u    /* sync0, sync1, length, type, sequence */
#define TLM_CRC_SIZE       2u
#define TLM_FRAME_OVERHEAD (TLM_HEADER_SIZE + TLM_CRC_SIZE)
/* Largest payload: the health message (148 bytes) plus room to grow. */
#define TLM_MAX_PAYLOAD 192u
#define TLM_FRAME_MAX   (TLM_FRAME_OVERHEAD + TLM_MAX_PAYLOAD)

/*
 * All the framing knows of the messages: which types a decoder accepts and each one's
 * fixed payload length, looked up through this table (tlm_messages.h provides the
 * protocol's; tests may pass their own). The framing includes nothing of the messages.
 */
struct tlm_type_table {
    /* Fixed payload length of `type`, or -1 if this decoder does not accept it. */
    int (*payload_length)(const void *ctx, uint8_t type);
    const void *ctx;
};

/* Wire result codes: the `result` of an ack and the reason of a rejection. */
enum tlm_result {
    TLM_RESULT_OK = 0,
    TLM_RESULT_UNKNOWN_TYPE = 1, /* type not defined (for a command: unknown command) */
    TLM_RESULT_BAD_LENGTH = 2,   /* payload length differs from the type's fixed length */
    TLM_RESULT_OUT_OF_RANGE = 3, /* a field holds a value outside its documented range */
    TLM_RESULT_STATE = 4,        /* valid, but refused in the current state (firmware's call) */
    /* A calibration refused, by its cause (write-calibration;
       docs/reference/telemetry-protocol.md): */
    TLM_RESULT_OTHER_HEAD = 5,   /* made on another head (head_id) */
    TLM_RESULT_OTHER_PARTS = 6,  /* made with other parts (a part's NVM identity) */
    TLM_RESULT_OTHER_MODE = 7,   /* made in another distance mode */
    TLM_RESULT_OTHER_BUDGET = 8, /* made at another timing budget */
    TLM_RESULT_OTHER_ARM = 9,    /* made at another arm */
    TLM_RESULT_BUSY = 10,        /* a re-zero or a record write in progress: send again after it */
};
#define TLM_RESULT_LAST TLM_RESULT_BUSY

/* A validated frame. `payload` points into the decoder's buffer or the caller's. */
struct tlm_frame {
    uint8_t type;
    uint8_t seq;
    uint8_t length; /* payload bytes */
    const uint8_t *payload;
};

/*
 * Receive-side counters, each a distinct class; every malformed frame is
 * counted once. The firmware reports them in the health message.
 */
struct tlm_rx_counters {
    uint32_t frames_ok;       /* frames that passed sync, length, CRC, type and type length */
    uint32_t bad_crc;         /* CRC mismatch */
    uint32_t bad_length;      /* length byte > TLM_MAX_PAYLOAD, or not the type's length */
    uint32_t unknown_type;    /* CRC-valid frame of a type this decoder does not accept */
    uint32_t truncated;       /* frame cut short: a CRC-valid frame began inside it, or flushed */
    uint32_t out_of_range;    /* frame whose fields failed validation (counted by the parsers) */
    uint32_t discarded_bytes; /* bytes not part of an accepted frame (garbage, bad frames) */
};

/* A CRC-valid frame the decoder refused; the firmware answers it with a nack. */
struct tlm_reject {
    enum tlm_result reason; /* TLM_RESULT_UNKNOWN_TYPE or TLM_RESULT_BAD_LENGTH */
    uint8_t type;
    uint8_t seq;
    uint8_t length;
};

/* Where a decoder delivers its results, called from inside tlm_decoder_push(). */
struct tlm_frame_sink {
    /* An accepted frame; `frame->payload` is valid only during the call. */
    void (*on_frame)(void *ctx, const struct tlm_frame *frame);
    /* A CRC-valid frame refused for its type or length; may be NULL. */
    void (*on_reject)(void *ctx, const struct tlm_reject *reject);
    void *ctx;
};

/*
 * Decoder state, owned by the caller. The window holds the bytes from the
 * current candidate sync byte onward; after a failed candidate the decoder
 * rescans the bytes it already holds, so a good frame hidden inside a bad
 * one is still found (docs/reference/telemetry-protocol.md, "Resynchronisation").
 */
struct tlm_decoder {
    struct tlm_type_table types; /* the accepted types and their lengths */
    uint16_t start;              /* first byte of the current candidate in window */
    uint16_t end;                /* one past the last byte received */
    uint16_t suspect_left;       /* bytes of a CRC-failed frame still ahead; 0 = none */
    uint8_t window[TLM_FRAME_MAX];
    struct tlm_rx_counters counters;
};

/*
 * Encode a frame of `type`, `seq` and `length` payload bytes into `out` (may overlap
 * `payload`). Returns the frame size, length + TLM_FRAME_OVERHEAD, or HAL_ERR_INVALID
 * if length > TLM_MAX_PAYLOAD, `cap` is too small or a needed pointer is NULL.
 */
int tlm_frame_encode(uint8_t type, uint8_t seq, const uint8_t *payload, size_t length, uint8_t *out,
                     size_t cap);

/*
 * Reset `dec` to hunt for a sync, accepting the types `types` gives a length for (copied;
 * its ctx must outlive the decoder), all counters zero. NULL accepts no type: every
 * CRC-valid frame is then rejected as of unknown type.
 */
void tlm_decoder_init(struct tlm_decoder *dec, const struct tlm_type_table *types);

/*
 * Feed one received byte. Every frame this byte completes, including good
 * frames found by rescanning after a bad one, is handed to `sink` before
 * return. Work is bounded: at most TLM_FRAME_MAX candidates per call.
 */
void tlm_decoder_push(struct tlm_decoder *dec, uint8_t byte, const struct tlm_frame_sink *sink);

/* Feed `len` bytes, as tlm_decoder_push() on each in order. */
void tlm_decoder_feed(struct tlm_decoder *dec, const uint8_t *data, size_t len,
                      const struct tlm_frame_sink *sink);

/*
 * End of stream or an idle line mid-frame (the sender never pauses inside a
 * frame): count the pending partial frame as truncated, rescan what follows
 * it, and leave the decoder empty, hunting for a sync.
 */
void tlm_decoder_flush(struct tlm_decoder *dec, const struct tlm_frame_sink *sink);

/* Bytes held for a frame not yet complete (0 when idle between frames). */
size_t tlm_decoder_pending(const struct tlm_decoder *dec);

/* True if `result` is one of enum tlm_result. */
bool tlm_result_is_valid(uint8_t result);

#endif /* TELEMETRY_TLM_FRAME_H */
