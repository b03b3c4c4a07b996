/* Telemetry message types: the type table (direction and fixed payload length of every type). */
#include <stddef.h>

#include "telemetry/tlm_messages.h"

/* --- the type table: direction and fixed payload length of every type ---- */

struct type_info {
    uint8_t type;
    uint8_t accept; /* TLM_ACCEPT_COMMANDS or TLM_ACCEPT_TELEMETRY */
    uint8_t length;
};

static const struct type_info type_table[] = {
    {TLM_TYPE_ESTIMATE, TLM_ACCEPT_TELEMETRY, TLM_LEN_ESTIMATE},
    {TLM_TYPE_RAW_SAMPLE, TLM_ACCEPT_TELEMETRY, TLM_LEN_RAW_SAMPLE},
    {TLM_TYPE_HEALTH, TLM_ACCEPT_TELEMETRY, TLM_LEN_HEALTH},
    {TLM_TYPE_ACK, TLM_ACCEPT_TELEMETRY, TLM_LEN_ACK},
    {TLM_TYPE_STATUS, TLM_ACCEPT_TELEMETRY, TLM_LEN_STATUS},
    {TLM_TYPE_CALIBRATION, TLM_ACCEPT_TELEMETRY, TLM_LEN_CALIBRATION},
    {TLM_TYPE_SET_WINDOW, TLM_ACCEPT_COMMANDS, TLM_LEN_SET_WINDOW},
    {TLM_TYPE_SELECT_ESTIMATOR, TLM_ACCEPT_COMMANDS, TLM_LEN_SELECT_ESTIMATOR},
    {TLM_TYPE_START, TLM_ACCEPT_COMMANDS, TLM_LEN_START},
    {TLM_TYPE_STOP, TLM_ACCEPT_COMMANDS, TLM_LEN_STOP},
    {TLM_TYPE_STATUS_REQUEST, TLM_ACCEPT_COMMANDS, TLM_LEN_STATUS_REQUEST},
    {TLM_TYPE_RAW_STREAM, TLM_ACCEPT_COMMANDS, TLM_LEN_RAW_STREAM},
    {TLM_TYPE_SET_PROCESS_NOISE, TLM_ACCEPT_COMMANDS, TLM_LEN_SET_PROCESS_NOISE},
    {TLM_TYPE_SAVE, TLM_ACCEPT_COMMANDS, TLM_LEN_SAVE},
    {TLM_TYPE_SET_ARM, TLM_ACCEPT_COMMANDS, TLM_LEN_SET_ARM},
    {TLM_TYPE_SET_PERIOD, TLM_ACCEPT_COMMANDS, TLM_LEN_SET_PERIOD},
    {TLM_TYPE_WRITE_CALIBRATION, TLM_ACCEPT_COMMANDS, TLM_LEN_WRITE_CALIBRATION},
    {TLM_TYPE_READ_CALIBRATION, TLM_ACCEPT_COMMANDS, TLM_LEN_READ_CALIBRATION},
    {TLM_TYPE_REZERO, TLM_ACCEPT_COMMANDS, TLM_LEN_REZERO},
};
#define TYPE_COUNT (sizeof type_table / sizeof type_table[0])
_Static_assert(TLM_LEN_HEALTH <= TLM_MAX_PAYLOAD, "largest payload must fit a frame");
_Static_assert(TLM_LEN_ESTIMATE <= TLM_LEN_HEALTH && TLM_LEN_STATUS <= TLM_LEN_HEALTH &&
                   TLM_LEN_CALIBRATION <= TLM_LEN_HEALTH &&
                   TLM_LEN_RAW_SAMPLE <= TLM_LEN_ESTIMATE, /* 17 = 17: not one bound twice */
               "every payload must fit a frame: the health payload is the largest");
_Static_assert(TLM_WINDOW_MAX <= UINT16_MAX, "window length travels as uint16");

static const struct type_info *find_type(uint8_t type, uint8_t accept) {
    for (size_t i = 0; i < TYPE_COUNT; ++i) {
        if (type_table[i].type == type && (type_table[i].accept & accept) != 0u) {
            return &type_table[i];
        }
    }
    return NULL;
}

int tlm_type_payload_length(uint8_t type, uint8_t accept) {
    const struct type_info *info = find_type(type, accept);
    return info != NULL ? (int)info->length : -1;
}

static int table_length(const void *ctx, uint8_t type) {
    return tlm_type_payload_length(type, *(const uint8_t *)ctx);
}

const struct tlm_type_table *tlm_message_types(uint8_t accept) {
    static const uint8_t masks[4] = {0u, TLM_ACCEPT_COMMANDS, TLM_ACCEPT_TELEMETRY, TLM_ACCEPT_ALL};
    static const struct tlm_type_table tables[4] = {
        {.payload_length = table_length, .ctx = &masks[0]},
        {.payload_length = table_length, .ctx = &masks[1]},
        {.payload_length = table_length, .ctx = &masks[2]},
        {.payload_length = table_length, .ctx = &masks[3]},
    };
    return &tables[accept & TLM_ACCEPT_ALL];
}

bool tlm_type_is_command(uint8_t type) {
    return find_type(type, TLM_ACCEPT_COMMANDS) != NULL;
}
