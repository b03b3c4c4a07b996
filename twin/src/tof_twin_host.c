/* tof_twin's host end of USART2: the capture file, the firmware's text lines, its telemetry
 * frames decoded into EST.csv rows (firmware/est_csv, the rows host_sim writes) with host_sim's
 * accuracy check, the set-window command a host sends until it is acknowledged, and `save`. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/est_csv.h"
#include "firmware/text.h"
#include "scene/crb.h"
#include "tof_twin.h"

static void send_command(struct run *r, const struct tlm_command *cmd) {
    uint8_t frame[TLM_FRAME_MAX];
    const int n = tlm_encode_command(0x40u, cmd, frame, sizeof frame);
    if (n <= 0 || !twin_usart_send_to_mcu(&r->t, frame, (unsigned)n)) {
        fprintf(stderr, "tof_twin: internal: command not encoded or receive queue full\n");
        exit(1);
    }
}

/* A window's bound (as host_sim replay computes it) from the trace rows it covers. */
static bool window_bound(const struct run *r, int64_t first, int64_t last, double *sd_a,
                         double *sd_b) {
    uint32_t n[4] = {0};
    double sum[4] = {0}, sum2[4] = {0}, sigma[4];
    for (int64_t k = first; k <= last; ++k) {
        const struct scene_row *row = &r->rows[k];
        for (unsigned s = 0; s < 4u; ++s) {
            if (scene_row_valid(row, s)) {
                ++n[s];
                sum[s] += row->range_mm[s];
                sum2[s] += (double)row->range_mm[s] * row->range_mm[s];
            }
        }
    }
    for (unsigned s = 0; s < 4u; ++s) {
        double var =
            n[s] >= 2u ? (sum2[s] - sum[s] * sum[s] / (double)n[s]) / ((double)n[s] - 1.0) : 0.0;
        sigma[s] = sqrt(var > 1.0 / 12.0 ? var : 1.0 / 12.0);
    }
    const struct scene_row *lr = &r->rows[last];
    struct scene_crb crb;
    if (!lr->has_alpha || !lr->has_beta ||
        scene_crb(r->meta.arm_mm, sigma, n, lr->alpha_deg, lr->beta_deg, &crb) != 0) {
        return false;
    }
    *sd_a = crb.sd_alpha_deg;
    *sd_b = crb.sd_beta_deg;
    return true;
}

static void on_estimate(struct run *r, const struct tlm_estimate *m) {
    if (m->estimator != (uint8_t)r->primary) {
        ++r->other_estimates;
        return;
    }
    ++r->estimates;
    const unsigned n = r->a.window;
    const int64_t fw_row =
        r->a.sliding ? (int64_t)m->window_index : ((int64_t)m->window_index + 1) * (int64_t)n - 1;
    const int64_t row = fw_row + r->w.boot_row;
    if (row < 0 || (uint64_t)row >= r->row_count) {
        return; /* about samples past the end of the trace */
    }
    struct attitude_estimate e = {0};
    e.status = m->status == TLM_STATUS_OK         ? ATTITUDE_OK
               : m->status == TLM_STATUS_DEGRADED ? ATTITUDE_DEGRADED
                                                  : ATTITUDE_INVALID;
    e.alpha_valid = m->alpha_udeg != TLM_NO_VALUE;
    e.beta_valid = m->beta_udeg != TLM_NO_VALUE;
    e.distance_valid = m->distance_um != TLM_NO_VALUE;
    e.alpha_udeg = e.alpha_valid ? m->alpha_udeg : 0;
    e.beta_udeg = e.beta_valid ? m->beta_udeg : 0;
    e.distance_um = e.distance_valid ? m->distance_um : 0;
    /* the frame carries each sd exactly when its value is present (docs/telemetry.md) */
    e.alpha_sd_udeg = e.alpha_valid ? m->alpha_sd_udeg : 0;
    e.beta_sd_udeg = e.beta_valid ? m->beta_sd_udeg : 0;
    e.distance_sd_um = e.distance_valid ? m->distance_sd_um : 0;
    e.why = (attitude_why_t)m->why;
    char line[TOF_EST_CSV_ROW_MAX];
    struct tof_text txt;
    tof_text_init(&txt, line, sizeof line);
    tof_est_csv_row(&txt, r->rows[row].t_ms, &e);
    if (txt.overflow || fputs(line, r->est) == EOF) {
        fprintf(stderr, "tof_twin: %s: write failed\n", r->a.out);
        exit(1);
    }
    ++r->written;
    /* host_sim's check: an ok estimate more than 5x its window's bound from the truth. */
    if (e.status == ATTITUDE_OK && !r->a.sliding) {
        ++r->ok_rows;
        double sd_a = 0, sd_b = 0;
        const struct scene_row *lr = &r->rows[row];
        const int64_t first = row - (int64_t)n + 1 >= 0 ? row - (int64_t)n + 1 : 0;
        if (window_bound(r, first, row, &sd_a, &sd_b) &&
            ((e.alpha_valid && fabs(e.alpha_udeg / 1e6 - lr->alpha_deg) > 5.0 * sd_a) ||
             (e.beta_valid && fabs(e.beta_udeg / 1e6 - lr->beta_deg) > 5.0 * sd_b))) {
            ++r->unflagged_wrong;
        }
    }
}

/*
 * A boot's slot 0 in simulated time, as the firmware defines it (firmware/src/app.c,
 * tof_app_init): the first whole period after the next slot boundary once init is over, the
 * boundaries being multiples of the period on the firmware's timeline. Its status frame is
 * sent right after init and carries that timeline's value in ms (tof_link_send_status: the
 * uptime tof_app_init last read, the one the boundary was computed from); the period being
 * a whole number of ms, the boundary follows from it exactly. The timeline counts
 * microseconds from the SysTick enable (boards/stm32/stm32_systick_time.c), which the twin
 * saw. host_sim reads the same instant from the firmware's assembler (sim_replay_set_origin).
 */
static void start_boot(struct run *r, const struct tlm_status *st) {
    const uint64_t period_ms = st->period_ms;
    if (period_ms * 1000u != r->w.period_us || r->t.scs.syst_enabled_ps == UINT64_MAX) {
        twin_stop(&r->t, TWIN_STOP_DONE,
                  "the firmware's status frame says period_ms %u (the trace: %u)%s: its slots "
                  "cannot be matched to trace rows",
                  st->period_ms, r->w.period_us / 1000u,
                  r->t.scs.syst_enabled_ps == UINT64_MAX ? ", SysTick never enabled" : "");
        return;
    }
    const uint64_t slot0_fw_us = ((uint64_t)st->uptime_ms / period_ms + 2u) * period_ms * 1000u;
    twin_world_start_boot(&r->w, r->t.scs.syst_enabled_ps / 1000000u + slot0_fw_us);
}

static void on_frame(void *ctx, const struct tlm_frame *frame) {
    struct run *r = ctx;
    struct tlm_telemetry msg;
    if (tlm_parse_telemetry(frame, &msg, &r->dec.counters) != TLM_RESULT_OK) {
        return;
    }
    switch (msg.type) {
    case TLM_TYPE_STATUS: {
        if (r->t.stats.resets == r->status_resets) {
            break; /* a status frame of the same boot (asked for): the slots are known */
        }
        r->status_resets = r->t.stats.resets;
        ++r->boots;
        r->boot_status = msg.u.status;
        start_boot(r, &msg.u.status);
        r->command_sent = false;
        if (!r->command_sent && (msg.u.status.window_n != r->a.window ||
                                 (msg.u.status.mode == TLM_WINDOW_SLIDING) != r->a.sliding)) {
            const struct tlm_command cmd = {
                .type = TLM_TYPE_SET_WINDOW,
                .u.set_window = {.window_n = (uint16_t)r->a.window,
                                 .mode = r->a.sliding ? TLM_WINDOW_SLIDING : TLM_WINDOW_TUMBLING}};
            r->command = cmd;
            r->command_needed = true;
            r->command_tries = 0;
            r->command_at_us = 0;
            r->acks_ok = 0;
        }
        r->command_sent = true;
        break;
    }
    case TLM_TYPE_ACK:
        if (msg.u.ack.result == 0u) {
            ++r->acks_ok;
        } else {
            ++r->acks_bad;
            fprintf(stderr, "tof_twin: the firmware refused command 0x%02x (result %u)\n",
                    msg.u.ack.command, msg.u.ack.result);
        }
        break;
    case TLM_TYPE_ESTIMATE:
        on_estimate(r, &msg.u.estimate);
        break;
    case TLM_TYPE_HEALTH:
        r->health = msg.u.health;
        ++r->health_frames;
        break;
    default:
        break;
    }
}

/* The firmware reads USART2 once per main-loop iteration: a command byte arriving during a
 * long iteration overruns the receiver and the frame is lost. Like a real host, send it
 * again until it is acknowledged (every COMMAND_RETRY_US, at most COMMAND_TRIES times). */
#define COMMAND_RETRY_US 400000u
#define COMMAND_TRIES    10u

void tof_twin_host_poll(void *ctx) {
    struct run *r = ctx;
    /* --save: once per run, when the settings asked for are in force (after the boot's
     * status frame, and the set-window command's ack if one was needed) */
    if (r->a.save && !r->save_sent && r->boots > 0u && (!r->command_needed || r->acks_ok > 0u) &&
        r->t.usart.rx_count == 0u) {
        const struct tlm_command save = {.type = TLM_TYPE_SAVE};
        send_command(r, &save);
        r->save_sent = true;
    }
    if (!r->command_needed || r->acks_ok > 0u || r->command_tries >= COMMAND_TRIES) {
        return;
    }
    const uint64_t now = twin_now_us(&r->t);
    if (r->command_tries == 0u || now - r->command_at_us >= COMMAND_RETRY_US) {
        if (r->t.usart.rx_count == 0u) {
            send_command(r, &r->command);
            r->command_tries++;
            r->command_at_us = now;
        }
    }
}

static void on_reject(void *ctx, const struct tlm_reject *reject) {
    (void)ctx;
    (void)reject;
}

void tof_twin_on_uart_byte(void *ctx, uint8_t byte, uint64_t now_ps) {
    struct run *r = ctx;
    (void)now_ps;
    if (r->uart != NULL) {
        fputc(byte, r->uart);
    }
    /* Text (boot banner, FAULT: lines) is what a terminal shows between frames. */
    if (byte == '\n') {
        r->line[r->line_len] = '\0';
        if (r->line_len >= 4u) {
            fprintf(stderr, "tof_twin: uart: %s\n", r->line);
            if (strncmp(r->line, "FAULT", 5) == 0) {
                ++r->faults_text;
                snprintf(r->last_fault, sizeof r->last_fault, "%s", r->line);
            }
            if (strncmp(r->line, "tof-attitude", 12) == 0) {
                ++r->banners;
            }
        }
        r->line_len = 0;
    } else if (byte >= 0x20u && byte < 0x7Fu && r->line_len + 1u < sizeof r->line) {
        r->line[r->line_len++] = (char)byte;
    } else {
        r->line_len = 0;
    }
    const struct tlm_frame_sink sink = {.on_frame = on_frame, .on_reject = on_reject, .ctx = r};
    tlm_decoder_push(&r->dec, byte, &sink);
}
