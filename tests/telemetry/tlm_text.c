/* Test helper: the canonical one-line text of every message, as tools/tof_telemetry.py prints
 * it. */
#include "tlm_text.h"

#include <inttypes.h>
#include <string.h>

#include "estimator/attitude.h" /* attitude_why_format: the estimator's own names */

static const char *const estimator_names[] = {"consensus", "consensus-paper", "kalman", "mean"};
static const char *const status_names[] = {"ok", "degraded", "invalid"};
static const char *const record_names[] = {"none",    "loaded",   "corrupt",
                                           "version", "rejected", "no-storage"};
static const char *const cal_names[] = {"none",        "applied",      "corrupt",  "version",
                                        "other-head",  "other-mode",   "rejected", "no-storage",
                                        "other-parts", "other-budget", "other-arm"};
static const char *const cal_age_names[] = {"none", "kept", "unknown", "failed"};
static const char *const health_names[] = {"healthy", "suspect", "lost", "recovering"};
static const char *const mode_names[] = {"tumbling", "sliding"};
static const char *const result_names[] = {
    "ok",          "unknown-type", "bad-length",   "out-of-range", "state", "other-head",
    "other-parts", "other-mode",   "other-budget", "other-arm",    "busy"};

/* value / 10^digits as exact decimal text, e.g. -1500000, 6 -> "-1.500000". */
static void print_fixed(FILE *out, int32_t value, int digits) {
    int64_t v = value;
    const char *sign = v < 0 ? "-" : "";
    if (v < 0) {
        v = -v;
    }
    int64_t unit = 1;
    for (int i = 0; i < digits; ++i) {
        unit *= 10;
    }
    fprintf(out, "%s%" PRId64 ".%0*" PRId64, sign, v / unit, digits, v % unit);
}

/* A temperature: " temp_c=-12.34", or " temp_c=none" when not known. */
static void print_temp(FILE *out, bool known, int16_t cdeg) {
    fputs(" temp_c=", out);
    if (known) {
        print_fixed(out, cdeg, 2);
    } else {
        fputs("none", out);
    }
}

static void print_optional_fixed(FILE *out, const char *key, int32_t value, int digits) {
    fprintf(out, " %s=", key);
    if (value == TLM_NO_VALUE) {
        fputs("none", out);
    } else {
        print_fixed(out, value, digits);
    }
}

/* The why set in the estimator's words ("none" when empty). */
static void print_why(FILE *out, uint64_t why) {
    char text[ATTITUDE_WHY_TEXT_MAX];
    const int n = attitude_why_format((attitude_why_t)why, text, sizeof text);
    fprintf(out, " why=%s", n > 0 ? text : (n == 0 ? "none" : "?"));
}

static void print_sensors(FILE *out, uint8_t mask) {
    fputs(" sensors=", out);
    if (mask == 0u) {
        fputs("none", out);
        return;
    }
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        if (mask & (1u << i)) {
            fputc("ABCD"[i], out);
        }
    }
}

static void print_u32_list(FILE *out, const char *key, const struct tlm_health *h, size_t field) {
    fprintf(out, " %s=", key);
    for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
        const uint32_t values[4] = {h->sensor[i].comm_errors, h->sensor[i].timeouts,
                                    h->sensor[i].flagged, h->sensor[i].reinits};
        fprintf(out, "%s%" PRIu32, i ? "," : "", values[field]);
    }
}

static void print_rx_counters(FILE *out, const char *prefix, const struct tlm_rx_counters *c) {
    fprintf(out,
            "%sframes_ok=%" PRIu32 " %sbad_crc=%" PRIu32 " %sbad_length=%" PRIu32
            " %sunknown_type=%" PRIu32 " %struncated=%" PRIu32 " %sout_of_range=%" PRIu32
            " %sdiscarded_bytes=%" PRIu32,
            prefix, c->frames_ok, prefix, c->bad_crc, prefix, c->bad_length, prefix,
            c->unknown_type, prefix, c->truncated, prefix, c->out_of_range, prefix,
            c->discarded_bytes);
}

static const char *command_name(uint8_t type) {
    switch (type) {
    case TLM_TYPE_SET_WINDOW:
        return "set-window";
    case TLM_TYPE_SELECT_ESTIMATOR:
        return "select-estimator";
    case TLM_TYPE_START:
        return "start";
    case TLM_TYPE_STOP:
        return "stop";
    case TLM_TYPE_STATUS_REQUEST:
        return "status-request";
    case TLM_TYPE_RAW_STREAM:
        return "raw-stream";
    case TLM_TYPE_SET_PROCESS_NOISE:
        return "set-process-noise";
    case TLM_TYPE_SAVE:
        return "save";
    case TLM_TYPE_WRITE_CALIBRATION:
        return "write-calibration";
    case TLM_TYPE_READ_CALIBRATION:
        return "read-calibration";
    case TLM_TYPE_REZERO:
        return "re-zero";
    case TLM_TYPE_SET_ARM:
        return "set-arm";
    case TLM_TYPE_SET_PERIOD:
        return "set-period";
    default:
        return NULL;
    }
}

static void print_hex(FILE *out, const uint8_t *bytes, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        fprintf(out, "%02x", bytes[i]);
    }
}

void tlm_text_telemetry(FILE *out, uint8_t seq, const struct tlm_telemetry *msg) {
    fprintf(out, "seq=%u ", seq);
    switch (msg->type) {
    case TLM_TYPE_ESTIMATE: {
        const struct tlm_estimate *e = &msg->u.estimate;
        fprintf(out, "estimate t_ms=%" PRIu32 " window=%" PRIu32 " estimator=%s status=%s", e->t_ms,
                e->window_index, estimator_names[e->estimator], status_names[e->status]);
        print_why(out, e->why);
        print_sensors(out, e->sensors_used);
        print_optional_fixed(out, "alpha_deg", e->alpha_udeg, 6);
        print_optional_fixed(out, "beta_deg", e->beta_udeg, 6);
        print_optional_fixed(out, "distance_mm", e->distance_um, 3);
        print_optional_fixed(out, "alpha_sd_deg", e->alpha_sd_udeg, 6);
        print_optional_fixed(out, "beta_sd_deg", e->beta_sd_udeg, 6);
        print_optional_fixed(out, "distance_sd_mm", e->distance_sd_um, 3);
        if (e->flatness_um == TLM_NO_VALUE) {
            fputs(" flatness_um=none", out);
        } else {
            fprintf(out, " flatness_um=%" PRId32, e->flatness_um);
        }
        print_temp(out, e->temp_known, e->temp_cdeg);
        break;
    }
    case TLM_TYPE_RAW_SAMPLE: {
        const struct tlm_raw_sample *r = &msg->u.raw;
        fprintf(out, "raw t_ms=%" PRIu32, r->t_ms);
        for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
            if (r->present_mask & (1u << i)) {
                fprintf(out, " %c_mm=%u", "abcd"[i], r -> range_mm[i]);
            } else {
                fprintf(out, " %c_mm=none", "abcd"[i]);
            }
        }
        for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
            if (r->present_mask & (1u << i)) {
                fprintf(out, " %c_st=%u", "abcd"[i], r -> range_status[i]);
            } else {
                fprintf(out, " %c_st=none", "abcd"[i]);
            }
        }
        break;
    }
    case TLM_TYPE_HEALTH: {
        const struct tlm_health *h = &msg->u.health;
        fprintf(out, "health uptime_ms=%" PRIu32 " state=", h->uptime_ms);
        for (unsigned i = 0; i < TLM_SENSOR_COUNT; ++i) {
            fprintf(out, "%s%s", i ? "," : "", health_names[h->sensor_state[i]]);
        }
        print_u32_list(out, "comm_errors", h, 0);
        print_u32_list(out, "timeouts", h, 1);
        print_u32_list(out, "flagged", h, 2);
        print_u32_list(out, "reinits", h, 3);
        fprintf(out,
                " bus_addr_nack=%" PRIu32 " bus_data_nack=%" PRIu32 " bus_busy=%" PRIu32
                " bus_timeout=%" PRIu32 " bus_stuck=%" PRIu32 " bus_other=%" PRIu32
                " bus_recoveries=%" PRIu32 " watchdog_resets=%" PRIu32 " loop_overruns=%" PRIu32
                " loop_max_us=%" PRIu32 " tx_dropped=%" PRIu32 " ",
                h->bus.addr_nack, h->bus.data_nack, h->bus.busy, h->bus.timeout, h->bus.stuck,
                h->bus.other, h->bus.recoveries, h->watchdog_resets, h->loop_overruns,
                h->loop_max_us, h->tx_dropped);
        print_rx_counters(out, "rx_", &h->link);
        fprintf(out, " uart_overruns=%" PRIu32, h->uart_overruns);
        break;
    }
    case TLM_TYPE_ACK: {
        const struct tlm_ack *a = &msg->u.ack;
        const char *name = command_name(a->command);
        fprintf(out, "%s echo_seq=%u command=", a->result == 0 ? "ack" : "nack", a->echo_seq);
        if (name != NULL) {
            fputs(name, out);
        } else {
            fprintf(out, "0x%02x", a->command);
        }
        fprintf(out, " result=%s error=%d", result_names[a->result], a->error);
        break;
    }
    case TLM_TYPE_STATUS: {
        const struct tlm_status *s = &msg->u.status;
        fprintf(out,
                "status fw=%u.%u.%u protocol=%u uptime_ms=%" PRIu32
                " window_n=%u mode=%s estimator=%s running=%s raw_stream=%s period_ms=%u"
                " record=%s calibration=%s arm_um=%" PRIu32 " cal_age_s=%" PRIu32 " cal_age=%s",
                s->fw_major, s->fw_minor, s->fw_patch, TLM_PROTOCOL_VERSION, s->uptime_ms,
                s->window_n, mode_names[s->mode], estimator_names[s->estimator],
                s->running ? "yes" : "no", s->raw_stream ? "yes" : "no", s->period_ms,
                record_names[s->record], cal_names[s->calibration], s->arm_um, s->cal_age_s,
                cal_age_names[s->cal_age]);
        print_temp(out, s->temp_known, s->temp_cdeg);
        break;
    }
    case TLM_TYPE_CALIBRATION:
        fprintf(out, "calibration state=%s section=", cal_names[msg->u.calibration.state]);
        print_hex(out, msg->u.calibration.section, TLM_CAL_SECTION_LEN);
        break;
    default:
        fprintf(out, "unprintable type 0x%02x", msg->type);
        break;
    }
    fputc('\n', out);
}

void tlm_text_command(FILE *out, uint8_t seq, const struct tlm_command *cmd) {
    const char *name = command_name(cmd->type);
    fprintf(out, "seq=%u %s", seq, name != NULL ? name : "unprintable-command");
    switch (cmd->type) {
    case TLM_TYPE_SET_WINDOW:
        fprintf(out, " window_n=%u mode=%s", cmd->u.set_window.window_n,
                mode_names[cmd->u.set_window.mode]);
        break;
    case TLM_TYPE_SELECT_ESTIMATOR:
        fprintf(out, " estimator=%s", estimator_names[cmd->u.estimator]);
        break;
    case TLM_TYPE_RAW_STREAM:
        fprintf(out, " enable=%s", cmd->u.raw_enable ? "on" : "off");
        break;
    case TLM_TYPE_SET_PROCESS_NOISE: /* um²/s printed exactly as mm²/s, six decimals */
        fprintf(out,
                " qd_mm2_per_s=%" PRIu32 ".%06" PRIu32 " qt_mm2_per_s=%" PRIu32 ".%06" PRIu32
                " auto=%s",
                cmd->u.process_noise.qd_um2_per_s / 1000000u,
                cmd->u.process_noise.qd_um2_per_s % 1000000u,
                cmd->u.process_noise.qt_um2_per_s / 1000000u,
                cmd->u.process_noise.qt_um2_per_s % 1000000u,
                (cmd->u.process_noise.flags & TLM_PROCESS_NOISE_AUTO) != 0u ? "yes" : "no");
        break;
    case TLM_TYPE_SET_ARM:
        fprintf(out, " arm_um=%" PRIu32, cmd->u.arm_um);
        break;
    case TLM_TYPE_SET_PERIOD:
        fprintf(out, " period_ms=%u", cmd->u.period_ms);
        break;
    case TLM_TYPE_REZERO:
        fprintf(out, " samples=%u", cmd->u.rezero_samples);
        break;
    case TLM_TYPE_WRITE_CALIBRATION:
        fputs(" section=", out);
        print_hex(out, cmd->u.cal_section, TLM_CAL_SECTION_LEN);
        break;
    default:
        break;
    }
    fputc('\n', out);
}

void tlm_text_reject(FILE *out, uint8_t seq, uint8_t type, uint8_t length, enum tlm_result why) {
    fprintf(out, "seq=%u rejected type=0x%02x length=%u reason=%s\n", seq, type, length,
            result_names[why]);
}

void tlm_text_counters(FILE *out, const struct tlm_rx_counters *counters) {
    fputs("# ", out);
    print_rx_counters(out, "", counters);
    fputc('\n', out);
}

void tlm_text_frame(FILE *out, const struct tlm_frame *frame, struct tlm_rx_counters *counters) {
    if (tlm_type_is_command(frame->type)) {
        struct tlm_command cmd;
        const enum tlm_result r = tlm_parse_command(frame, &cmd, counters);
        if (r == TLM_RESULT_OK) {
            tlm_text_command(out, frame->seq, &cmd);
        } else {
            tlm_text_reject(out, frame->seq, frame->type, frame->length, r);
        }
        return;
    }
    struct tlm_telemetry msg;
    const enum tlm_result r = tlm_parse_telemetry(frame, &msg, counters);
    if (r == TLM_RESULT_OK) {
        tlm_text_telemetry(out, frame->seq, &msg);
    } else {
        tlm_text_reject(out, frame->seq, frame->type, frame->length, r);
    }
}
