/* The calibration message and the calibration section's header check (tlm_messages.h). */
#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"
#include "telemetry/tlm_messages.h"

/* A calibration section's header as the protocol checks it: id 2, a version other than 0,
 * length 114 (the content is the firmware's to check); `none_ok` also takes the all-zero
 * section of "none stored". */
bool tlm_cal_section_is_valid(const uint8_t *s, bool none_ok) {
    if (none_ok && s[0] == 0u && s[1] == 0u && s[2] == 0u && s[3] == 0u) {
        for (size_t i = 4; i < TLM_CAL_SECTION_LEN; ++i) {
            if (s[i] != 0u) {
                return false;
            }
        }
        return true;
    }
    return s[0] == TLM_CAL_SECTION_ID && s[1] != 0u &&
           (size_t)(s[2] | s[3] << 8) == TLM_CAL_SECTION_LEN - 4u;
}

int tlm_encode_calibration(uint8_t seq, const struct tlm_calibration *msg, uint8_t *out,
                           size_t cap) {
    if (msg == NULL || out == NULL || msg->state > TLM_CAL_STATE_LAST ||
        !tlm_cal_section_is_valid(msg->section, true)) {
        return HAL_ERR_INVALID;
    }
    uint8_t payload[TLM_LEN_CALIBRATION];
    payload[0] = msg->state;
    memcpy(&payload[1], msg->section, TLM_CAL_SECTION_LEN);
    return tlm_frame_encode(TLM_TYPE_CALIBRATION, seq, payload, TLM_LEN_CALIBRATION, out, cap);
}
