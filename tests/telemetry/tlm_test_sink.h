/* Test helper: a frame sink that records every frame and rejection it is given. */
#ifndef TLM_TEST_SINK_H
#define TLM_TEST_SINK_H

#include <stddef.h>
#include <stdint.h>

#include "telemetry/tlm_frame.h"

#define RECORDER_CAPACITY 320

struct recorded_frame {
    uint8_t type;
    uint8_t seq;
    uint8_t length;
    uint8_t payload[TLM_MAX_PAYLOAD];
};

struct recorder {
    struct recorded_frame frames[RECORDER_CAPACITY];
    size_t frame_count;
    struct tlm_reject rejects[RECORDER_CAPACITY];
    size_t reject_count;
    size_t frame_bytes; /* total size of the frames recorded, overhead included */
};

/* Empty `rec` and return a sink recording into it. */
struct tlm_frame_sink recorder_sink(struct recorder *rec);

/* The recorded frame `index` as a struct tlm_frame (payload points into `rec`). */
struct tlm_frame recorder_frame(const struct recorder *rec, size_t index);

#endif /* TLM_TEST_SINK_H */
