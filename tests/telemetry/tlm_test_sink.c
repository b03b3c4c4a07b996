/* Test helper: a frame sink that records every frame and rejection it is given. */
#include "tlm_test_sink.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void record_frame(void *ctx, const struct tlm_frame *frame) {
    struct recorder *rec = ctx;
    if (rec->frame_count >= RECORDER_CAPACITY) {
        fprintf(stderr, "recorder: more than %d frames\n", RECORDER_CAPACITY);
        abort();
    }
    struct recorded_frame *out = &rec->frames[rec->frame_count++];
    out->type = frame->type;
    out->seq = frame->seq;
    out->length = frame->length;
    memcpy(out->payload, frame->payload, frame->length);
    rec->frame_bytes += (size_t)frame->length + TLM_FRAME_OVERHEAD;
}

static void record_reject(void *ctx, const struct tlm_reject *reject) {
    struct recorder *rec = ctx;
    if (rec->reject_count >= RECORDER_CAPACITY) {
        fprintf(stderr, "recorder: more than %d rejects\n", RECORDER_CAPACITY);
        abort();
    }
    rec->rejects[rec->reject_count++] = *reject;
}

struct tlm_frame_sink recorder_sink(struct recorder *rec) {
    memset(rec, 0, sizeof *rec);
    return (struct tlm_frame_sink){
        .on_frame = record_frame, .on_reject = record_reject, .ctx = rec};
}

struct tlm_frame recorder_frame(const struct recorder *rec, size_t index) {
    const struct recorded_frame *f = &rec->frames[index];
    return (struct tlm_frame){
        .type = f->type, .seq = f->seq, .length = f->length, .payload = f->payload};
}
