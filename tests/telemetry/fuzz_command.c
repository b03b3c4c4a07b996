/*
 * libFuzzer target: the command and telemetry parsers on arbitrary frames
 * (first input byte = type, the rest = payload, any length). Checks that
 * the result classes are exact and that an accepted command or message
 * re-encodes to exactly its payload: validation leaves no byte unchecked.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_input.h" /* FUZZ_CHECK */
#include "telemetry/tlm_frame.h"
#include "telemetry/tlm_messages.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 1 || size - 1 > 255) {
        return 0;
    }
    /* Copy the payload so ASan sees its exact extent. */
    const size_t length = size - 1;
    uint8_t *payload = malloc(length > 0 ? length : 1);
    FUZZ_CHECK(payload != NULL);
    memcpy(payload, data + 1, length);
    const struct tlm_frame frame = {
        .type = data[0], .seq = 0x5C, .length = (uint8_t)length, .payload = payload};

    struct tlm_rx_counters counters;
    memset(&counters, 0, sizeof counters);
    struct tlm_command cmd;
    const enum tlm_result result = tlm_parse_command(&frame, &cmd, &counters);
    const int expected_len = tlm_type_payload_length(frame.type, TLM_ACCEPT_COMMANDS);
    if (expected_len < 0) {
        FUZZ_CHECK(result == TLM_RESULT_UNKNOWN_TYPE && counters.unknown_type == 1);
    } else if ((size_t)expected_len != length) {
        FUZZ_CHECK(result == TLM_RESULT_BAD_LENGTH && counters.bad_length == 1);
    } else if (result == TLM_RESULT_OK) {
        FUZZ_CHECK(cmd.type == frame.type);
        uint8_t out[TLM_FRAME_MAX];
        const int n = tlm_encode_command(frame.seq, &cmd, out, sizeof out);
        FUZZ_CHECK(n == (int)(length + TLM_FRAME_OVERHEAD));
        FUZZ_CHECK(out[3] == frame.type && out[4] == frame.seq);
        FUZZ_CHECK(length == 0 || memcmp(&out[TLM_HEADER_SIZE], payload, length) == 0);
        FUZZ_CHECK(counters.unknown_type + counters.bad_length + counters.out_of_range == 0);
    } else {
        FUZZ_CHECK(result == TLM_RESULT_OUT_OF_RANGE && counters.out_of_range == 1);
    }

    /* The same frame through the telemetry parser: a command is unknown there. */
    struct tlm_telemetry msg;
    const enum tlm_result tresult = tlm_parse_telemetry(&frame, &msg, NULL);
    const int tlen = tlm_type_payload_length(frame.type, TLM_ACCEPT_TELEMETRY);
    if (tlen < 0) {
        FUZZ_CHECK(tresult == TLM_RESULT_UNKNOWN_TYPE);
    } else if ((size_t)tlen != length) {
        FUZZ_CHECK(tresult == TLM_RESULT_BAD_LENGTH);
    } else if (tresult == TLM_RESULT_OK) {
        FUZZ_CHECK(msg.type == frame.type);
        uint8_t out[TLM_FRAME_MAX];
        int n = -1;
        switch (msg.type) {
        case TLM_TYPE_ESTIMATE:
            n = tlm_encode_estimate(frame.seq, &msg.u.estimate, out, sizeof out);
            break;
        case TLM_TYPE_RAW_SAMPLE:
            n = tlm_encode_raw_sample(frame.seq, &msg.u.raw, out, sizeof out);
            break;
        case TLM_TYPE_HEALTH:
            n = tlm_encode_health(frame.seq, &msg.u.health, out, sizeof out);
            break;
        case TLM_TYPE_ACK:
            n = tlm_encode_ack(frame.seq, &msg.u.ack, out, sizeof out);
            break;
        case TLM_TYPE_STATUS:
            n = tlm_encode_status(frame.seq, &msg.u.status, out, sizeof out);
            break;
        case TLM_TYPE_CALIBRATION:
            n = tlm_encode_calibration(frame.seq, &msg.u.calibration, out, sizeof out);
            break;
        default:
            /* a telemetry type the fuzzer does not know */
            fprintf(stderr, "%s:%d: property violated: unknown telemetry type %u\n", __FILE__,
                    __LINE__, (unsigned)frame.type);
            abort();
        }
        FUZZ_CHECK(n == (int)(length + TLM_FRAME_OVERHEAD));
        FUZZ_CHECK(memcmp(&out[TLM_HEADER_SIZE], payload, length) == 0);
    } else {
        FUZZ_CHECK(tresult == TLM_RESULT_OUT_OF_RANGE);
    }
    free(payload);
    return 0;
}
