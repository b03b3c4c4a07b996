/* Telemetry commands (host -> firmware): the encoder and the validating parser. */
#include <string.h>

#include "hal/hal_err.h"
#include "telemetry/tlm_messages.h"
#include "tlm_wire.h"

/* --- commands ------------------------------------------------------------- */

/* The protocol's range of set-process-noise: only the defined flag bits. The intensities
 * are any uint32; what Q per row they give at the sample period is the estimator's to
 * accept or refuse (the nack then carries its code). */
static bool process_noise_is_valid(uint8_t flags) {
    return (flags & ~TLM_PROCESS_NOISE_AUTO) == 0u;
}

int tlm_encode_command(uint8_t seq, const struct tlm_command *cmd, uint8_t *out, size_t cap) {
    if (cmd == NULL || out == NULL) {
        return HAL_ERR_INVALID;
    }
    const int length = tlm_type_payload_length(cmd->type, TLM_ACCEPT_COMMANDS);
    if (length < 0 || !has_room(out, cap, (size_t)length)) {
        return HAL_ERR_INVALID;
    }
    struct writer w = {.buf = &out[TLM_HEADER_SIZE], .at = 0};
    switch (cmd->type) {
    case TLM_TYPE_SET_WINDOW:
        if (!window_is_valid(cmd->u.set_window.window_n, cmd->u.set_window.mode)) {
            return HAL_ERR_INVALID;
        }
        put_u16(&w, cmd->u.set_window.window_n);
        put_u8(&w, cmd->u.set_window.mode);
        break;
    case TLM_TYPE_SELECT_ESTIMATOR:
        if (cmd->u.estimator > TLM_ESTIMATOR_LAST) {
            return HAL_ERR_INVALID;
        }
        put_u8(&w, cmd->u.estimator);
        break;
    case TLM_TYPE_RAW_STREAM:
        put_u8(&w, cmd->u.raw_enable ? 1u : 0u);
        break;
    case TLM_TYPE_SET_PROCESS_NOISE:
        if (!process_noise_is_valid(cmd->u.process_noise.flags)) {
            return HAL_ERR_INVALID;
        }
        put_u32(&w, cmd->u.process_noise.qd_um2_per_s);
        put_u32(&w, cmd->u.process_noise.qt_um2_per_s);
        put_u8(&w, cmd->u.process_noise.flags);
        break;
    case TLM_TYPE_WRITE_CALIBRATION:
        if (!tlm_cal_section_is_valid(cmd->u.cal_section, false)) {
            return HAL_ERR_INVALID;
        }
        memcpy(w.buf, cmd->u.cal_section, TLM_CAL_SECTION_LEN);
        w.at = TLM_CAL_SECTION_LEN;
        break;
    case TLM_TYPE_REZERO:
        if (cmd->u.rezero_samples < TLM_REZERO_MIN || cmd->u.rezero_samples > TLM_REZERO_MAX) {
            return HAL_ERR_INVALID;
        }
        put_u16(&w, cmd->u.rezero_samples);
        break;
    case TLM_TYPE_SET_ARM:
        if (!arm_is_valid(cmd->u.arm_um)) {
            return HAL_ERR_INVALID;
        }
        put_u32(&w, cmd->u.arm_um);
        break;
    case TLM_TYPE_SET_PERIOD:
        if (!period_is_valid(cmd->u.period_ms)) {
            return HAL_ERR_INVALID;
        }
        put_u16(&w, cmd->u.period_ms);
        break;
    default: /* start, stop, status request, save, read-calibration: no payload */
        break;
    }
    return finish_frame(cmd->type, seq, out, w.at, cap);
}

enum tlm_result tlm_parse_command(const struct tlm_frame *frame, struct tlm_command *out,
                                  struct tlm_rx_counters *counters) {
    enum tlm_result result = TLM_RESULT_OK;
    const int length = tlm_type_payload_length(frame->type, TLM_ACCEPT_COMMANDS);
    memset(out, 0, sizeof *out);
    if (length < 0) {
        result = TLM_RESULT_UNKNOWN_TYPE;
    } else if (frame->length != (size_t)length || (frame->length > 0u && frame->payload == NULL)) {
        result = TLM_RESULT_BAD_LENGTH;
    } else {
        struct reader r = {.buf = frame->payload, .at = 0};
        out->type = frame->type;
        switch (frame->type) {
        case TLM_TYPE_SET_WINDOW:
            out->u.set_window.window_n = get_u16(&r);
            out->u.set_window.mode = get_u8(&r);
            if (!window_is_valid(out->u.set_window.window_n, out->u.set_window.mode)) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_SELECT_ESTIMATOR:
            out->u.estimator = get_u8(&r);
            if (out->u.estimator > TLM_ESTIMATOR_LAST) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_RAW_STREAM:
            if (!get_bool(&r, &out->u.raw_enable)) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_SET_PROCESS_NOISE:
            out->u.process_noise.qd_um2_per_s = get_u32(&r);
            out->u.process_noise.qt_um2_per_s = get_u32(&r);
            out->u.process_noise.flags = get_u8(&r);
            if (!process_noise_is_valid(out->u.process_noise.flags)) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_WRITE_CALIBRATION:
            memcpy(out->u.cal_section, frame->payload, TLM_CAL_SECTION_LEN);
            if (!tlm_cal_section_is_valid(out->u.cal_section, false)) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_REZERO:
            out->u.rezero_samples = get_u16(&r);
            if (out->u.rezero_samples < TLM_REZERO_MIN || out->u.rezero_samples > TLM_REZERO_MAX) {
                result = TLM_RESULT_OUT_OF_RANGE;
            }
            break;
        case TLM_TYPE_SET_ARM:
            out->u.arm_um = get_u32(&r);
            result = arm_is_valid(out->u.arm_um) ? result : TLM_RESULT_OUT_OF_RANGE;
            break;
        case TLM_TYPE_SET_PERIOD:
            out->u.period_ms = get_u16(&r);
            result = period_is_valid(out->u.period_ms) ? result : TLM_RESULT_OUT_OF_RANGE;
            break;
        default: /* start, stop, status request, save, read-calibration: length only */
            break;
        }
    }
    count_result(counters, result);
    return result;
}
