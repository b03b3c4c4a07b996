/* host_sim replay's host end of the firmware's link for --command ROW:TEXT (replay_commands.h). */
#include "replay_commands.h"

#include <string.h>

#include "firmware/settings.h"
#include "telemetry/tlm_command_text.h"
#include "telemetry/tlm_messages.h"

/* 115200 Bd 8N1: 10 bits a byte, in picoseconds (the twin's TWIN_HOST_BAUD byte time). */
#define BYTE_PS (10u * 1000000000000ull / 115200u)

const char *replay_commands_add(struct replay_commands *c, const char *arg) {
    if (c->count == REPLAY_COMMANDS_MAX) {
        return "too many --command (16 at most)";
    }
    struct tlm_command cmd;
    const char *why = tlm_command_from_arg(arg, &c->cmd[c->count].row, &cmd);
    if (why != NULL) {
        return why;
    }
    /* The sequence numbers the twin's host gives its commands (from 0x40, in order). */
    const int n = tlm_encode_command((uint8_t)(0x40u + c->count), &cmd, c->cmd[c->count].bytes,
                                     sizeof c->cmd[c->count].bytes);
    if (n <= 0) {
        return "internal: the command was not encoded";
    }
    c->cmd[c->count].len = (size_t)n;
    ++c->count;
    return NULL;
}

static size_t serial_read(void *ctx, uint8_t *buf, size_t max) {
    struct replay_commands *c = ctx;
    const uint64_t now_ps = sim_clock_now(c->clock) * 1000000u;
    size_t n = 0;
    while (n < max && c->line_read < c->line_len && c->line_at_ps[c->line_read] <= now_ps) {
        buf[n++] = c->line[c->line_read++];
    }
    return n;
}

static void on_answer(void *ctx, const struct tlm_frame *frame) {
    struct replay_commands *c = ctx;
    struct tlm_telemetry msg;
    if (tlm_parse_telemetry(frame, &msg, NULL) == TLM_RESULT_OK && msg.type == TLM_TYPE_ACK &&
        msg.u.ack.result == 0u) {
        ++c->acked;
    }
}

/* What the firmware sends (acks, status, health): decoded for the acks, nothing kept. */
static size_t serial_write(void *ctx, const uint8_t *data, size_t len) {
    struct replay_commands *c = ctx;
    const struct tlm_frame_sink sink = {.on_frame = on_answer, .on_reject = NULL, .ctx = c};
    tlm_decoder_feed(&c->answers, data, len, &sink);
    return len;
}

static const struct hal_serial_ops serial_ops = {.write = serial_write, .read = serial_read};

void replay_commands_start(struct replay_commands *c, struct tof_app *app,
                           struct tof_record_store *records, int cal_state,
                           const struct sim_clock *clock, uint64_t origin_us, uint32_t period_us) {
    c->clock = clock;
    c->origin_us = origin_us;
    c->period_us = period_us;
    tlm_decoder_init(&c->answers, tlm_message_types(TLM_ACCEPT_TELEMETRY));
    tof_link_init(&c->link, (struct hal_serial){.ops = &serial_ops, .ctx = c});
    tof_link_bind(&c->link, app);
    /* the flight unit's record storage and what its boot found (service_start's) */
    tof_link_set_records(&c->link, &tof_link_storage, records);
    struct tof_settings none;
    c->link.record_state =
        (uint8_t)(records->current < 0
                      ? TOF_RECORD_NONE
                      : tof_settings_decode(records->payload, records->length, &none));
    c->link.cal_state = (uint8_t)cal_state;
}

void replay_commands_poll(struct replay_commands *c) {
    if (c->count == 0u) {
        return;
    }
    const uint64_t now_us = sim_clock_now(c->clock);
    while (c->next < c->count) {
        const uint64_t due =
            c->origin_us + (uint64_t)c->cmd[c->next].row * c->period_us + c->period_us / 2u;
        if (now_us < due) {
            break;
        }
        /* On the line from the instant due (a host writes then; this poll may come later, the
         * firmware reads what has arrived by now), after what is already on it. */
        uint64_t at = c->line_end_ps > due * 1000000u ? c->line_end_ps : due * 1000000u;
        for (size_t k = 0; k < c->cmd[c->next].len; ++k) {
            at += BYTE_PS;
            c->line[c->line_len] = c->cmd[c->next].bytes[k];
            c->line_at_ps[c->line_len++] = at;
        }
        c->line_end_ps = at;
        ++c->sent;
        ++c->next;
    }
    tof_link_poll(&c->link);
}
