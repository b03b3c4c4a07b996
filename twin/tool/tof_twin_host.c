/* tof_twin's host end of USART2: the capture file, the firmware's text lines, its telemetry
 * frames decoded into EST.csv rows (firmware/est_csv, the rows host_sim writes) with host_sim's
 * accuracy check, and the commands a host sends (the configuration, `save`), back to back at
 * the line rate, with their answers matched by sequence number. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/est_csv.h"
#include "firmware/text.h"
#include "scene/crb.h"
#include "tof_twin.h"

/* Queue `cmd` to go out with the next burst (tof_twin_host_poll). */
static void queue_command(struct run *r, const struct tlm_command *cmd) {
    if (r->ncmds >= TOF_TWIN_COMMANDS) {
        fprintf(stderr, "tof_twin: internal: more than %u commands\n", TOF_TWIN_COMMANDS);
        exit(1);
    }
    r->cmds[r->ncmds++] = (struct host_command){.cmd = *cmd, .seq = r->next_seq++};
}

/* Every queued command in one write, back to back at the line rate. */
static void send_queued(struct run *r) {
    uint8_t bytes[TOF_TWIN_COMMANDS * TLM_FRAME_MAX];
    unsigned len = 0, first = r->nsent;
    unsigned end_at[TOF_TWIN_COMMANDS];
    for (unsigned k = first; k < r->ncmds; ++k) {
        const int n =
            tlm_encode_command(r->cmds[k].seq, &r->cmds[k].cmd, &bytes[len], sizeof bytes - len);
        if (n <= 0) {
            fprintf(stderr, "tof_twin: internal: command 0x%02x not encoded\n",
                    r->cmds[k].cmd.type);
            exit(1);
        }
        len += (unsigned)n;
        end_at[k] = len;
    }
    const uint64_t last = twin_usart_send_to_mcu(&r->t, bytes, len);
    if (last == 0u) {
        fprintf(stderr, "tof_twin: internal: the receive queue is full\n");
        exit(1);
    }
    /* Byte i of the write ends (len - 1 - i) byte times before the last one. */
    const uint64_t byte_ps = 10u * 1000000000000ull / TWIN_HOST_BAUD;
    for (unsigned k = first; k < r->ncmds; ++k) {
        r->cmds[k].last_byte_ps = last - (uint64_t)(len - end_at[k]) * byte_ps;
        ++r->commands_sent;
    }
    r->nsent = r->ncmds;
}

/* An answer (ack or nack) to one of the commands sent: matched by its sequence number. */
static void on_answer(struct run *r, const struct tlm_ack *ack) {
    unsigned k = r->nsent;
    for (unsigned i = 0; i < r->nsent; ++i) {
        if (!r->cmds[i].answered && r->cmds[i].seq == ack->echo_seq &&
            r->cmds[i].cmd.type == ack->command) {
            k = i;
            break;
        }
    }
    if (k == r->nsent) {
        if (r->pty.fd < 0 || !tof_twin_pty_answer(r, ack)) {
            ++r->commands_unmatched;
        }
        return;
    }
    if (k != r->next_ack) {
        ++r->commands_out_of_order;
    }
    r->next_ack = k + 1u;
    r->cmds[k].answered = true;
    const uint64_t lat = r->now_ps - r->cmds[k].last_byte_ps;
    r->ack_latency_max_ps = lat > r->ack_latency_max_ps ? lat : r->ack_latency_max_ps;
    if (ack->result == 0u) {
        ++r->commands_acked;
    } else {
        ++r->acks_bad;
        fprintf(stderr, "tof_twin: the firmware refused command 0x%02x (result %u, error %d)\n",
                ack->command, ack->result, ack->error);
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
    /* The window's last sample from its time (the end of its slot on the firmware's
     * timeline, firmware/src/assembler.c), not from its index: a set-window command starts
     * the count again, the slots go on. */
    const uint64_t t_us = (uint64_t)m->t_ms * 1000u;
    if (t_us < r->slot0_fw_us + r->w.period_us) {
        return;
    }
    const int64_t fw_row = (int64_t)((t_us - r->slot0_fw_us) / r->w.period_us) - 1;
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
    /* the frame carries each sd exactly when its value is present
     * (docs/reference/telemetry-protocol.md) */
    e.alpha_sd_udeg = e.alpha_valid ? m->alpha_sd_udeg : 0;
    e.beta_sd_udeg = e.beta_valid ? m->beta_sd_udeg : 0;
    e.distance_sd_um = e.distance_valid ? m->distance_sd_um : 0;
    e.why = (attitude_why_t)m->why;
    const attitude_why_t missing = ATTITUDE_WHY_MISSING(0) | ATTITUDE_WHY_MISSING(1) |
                                   ATTITUDE_WHY_MISSING(2) | ATTITUDE_WHY_MISSING(3);
    if ((e.why & missing) != 0u) {
        ++r->rows_missing; /* a reading lost: the sensor's data came too late or not at all */
    }
    if (r->est == NULL) {
        return; /* --pty without --out */
    }
    char line[TOF_EST_CSV_ROW_MAX];
    struct tof_text txt;
    tof_text_init(&txt, line, sizeof line);
    /* The window's temperature as the estimate frame carries it (the unit's reading). */
    tof_est_csv_row(&txt, r->rows[row].t_ms, &e, m->temp_known, m->temp_cdeg);
    if (txt.overflow || fputs(line, r->est) == EOF) {
        fprintf(stderr, "tof_twin: %s: write failed\n", r->a.out);
        exit(1);
    }
    ++r->written;
    /* host_sim's check: an ok estimate more than 5x its window's bound from the truth (the
     * options' window: not after a --command, which may have changed it). */
    if (e.status == ATTITUDE_OK && !r->a.sliding && r->user_queued == 0u) {
        const unsigned n = r->a.window;
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
    r->slot0_fw_us = slot0_fw_us;
    twin_world_start_boot(&r->w, r->t.scs.syst_enabled_ps / 1000000u + slot0_fw_us);
}

/* After a boot's status frame: the commands that bring the firmware to the options' window,
 * mode and (with --late-command) primary estimator, then a status request to confirm them,
 * all back to back. */
static void queue_configuration(struct run *r, const struct tlm_status *st) {
    bool any = false;
    if (st->window_n != r->a.window || (st->mode == TLM_WINDOW_SLIDING) != r->a.sliding) {
        const struct tlm_command cmd = {
            .type = TLM_TYPE_SET_WINDOW,
            .u.set_window = {.window_n = (uint16_t)r->a.window,
                             .mode = r->a.sliding ? TLM_WINDOW_SLIDING : TLM_WINDOW_TUMBLING}};
        queue_command(r, &cmd);
        any = true;
    }
    if (r->a.late_command && st->estimator != (uint8_t)r->primary) {
        const struct tlm_command cmd = {.type = TLM_TYPE_SELECT_ESTIMATOR,
                                        .u.estimator = (uint8_t)r->primary};
        queue_command(r, &cmd);
        any = true;
    }
    if (any) {
        const struct tlm_command cmd = {.type = TLM_TYPE_STATUS_REQUEST};
        queue_command(r, &cmd);
    }
}

static void on_frame(void *ctx, const struct tlm_frame *frame) {
    struct run *r = ctx;
    struct tlm_telemetry msg;
    if (tlm_parse_telemetry(frame, &msg, &r->dec.counters) != TLM_RESULT_OK) {
        return;
    }
    switch (msg.type) {
    case TLM_TYPE_STATUS: {
        const struct tlm_status *st = &msg.u.status;
        if (r->t.stats.resets == r->status_resets && r->user_queued > 0u) {
            break; /* after a --command the settings are the user's: nothing to compare */
        }
        if (r->t.stats.resets == r->status_resets) {
            /* A status request's answer: are the settings the options' now? */
            const bool same = st->window_n == r->a.window &&
                              (st->mode == TLM_WINDOW_SLIDING) == r->a.sliding &&
                              (!r->a.late_command || st->estimator == (uint8_t)r->primary);
            ++*(same ? &r->status_confirmed : &r->status_mismatch);
            break;
        }
        r->status_resets = r->t.stats.resets;
        ++r->boots;
        r->boot_status = *st;
        if (r->cal_preloaded && !r->cal_warned && st->calibration != TLM_CAL_APPLIED) {
            /* as host_sim replay warns: the flight image's boot refused it */
            static const char *const state[] = {
                "none",     "applied",    "corrupt",     "version",      "other-head", "other-mode",
                "rejected", "no-storage", "other-parts", "other-budget", "other-arm"};
            fprintf(stderr,
                    "tof_twin: warning: %s: not applied by the flight image's boot "
                    "(calibration=%s), as a flight unit would refuse it; the head is "
                    "uncalibrated\n",
                    r->cal_source,
                    st->calibration <= TLM_CAL_STATE_LAST ? state[st->calibration] : "?");
            r->cal_warned = true;
        }
        /* What was sent before the reset and not answered is lost with it (a power cut during
         * `save`): no answer will come, the answers that come next are to this boot's. */
        for (unsigned k = 0; k < r->nsent; ++k) {
            r->commands_lost += r->cmds[k].answered ? 0u : 1u;
            r->cmds[k].answered = true;
        }
        r->next_ack = r->ncmds;
        start_boot(r, st);
        queue_configuration(r, st);
        break;
    }
    case TLM_TYPE_ACK:
        on_answer(r, &msg.u.ack);
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

/* Every command sent has its answer, ack or nack. */
static bool all_answered(const struct run *r) {
    for (unsigned k = 0; k < r->nsent; ++k) {
        if (!r->cmds[k].answered) {
            return false;
        }
    }
    return true;
}

void tof_twin_host_poll(void *ctx) {
    struct run *r = ctx;
    /* --save: once per run, when the settings asked for are in force (after the boot's
     * status frame, and every command of its configuration acknowledged) */
    if (r->a.save && !r->save_sent && r->boots > 0u && r->nsent == r->ncmds && all_answered(r)) {
        const struct tlm_command save = {.type = TLM_TYPE_SAVE};
        queue_command(r, &save);
        r->save_sent = true;
    }
    if (r->a.late_command && !r->mid_sent && r->w.origin_set && r->nsent == r->ncmds &&
        twin_now_us(&r->t) >= r->w.origin_us + (uint64_t)r->row_count / 2u * r->w.period_us) {
        /* A command halfway through the trace, in whatever mode it runs by then. */
        const struct tlm_command cmd = {.type = TLM_TYPE_STATUS_REQUEST};
        queue_command(r, &cmd);
        r->mid_sent = true;
    }
    /* --command ROW:TEXT: when row ROW's slot is half over (its readings taken, row ROW + 1's
     * not yet: host_sim's replay_commands.c sends them at the same instant), every command
     * due then in one write. */
    while (r->user_queued < r->a.ncommands && r->w.origin_set &&
           twin_now_us(&r->t) >= r->w.origin_us +
                                     (uint64_t)r->a.commands[r->user_queued].row * r->w.period_us +
                                     r->w.period_us / 2u) {
        queue_command(r, &r->a.commands[r->user_queued++].cmd);
    }
    if (r->nsent < r->ncmds) {
        send_queued(r);
    }
    if (r->pty.fd >= 0) {
        tof_twin_pty_poll(r);
    }
}

static void on_reject(void *ctx, const struct tlm_reject *reject) {
    (void)ctx;
    (void)reject;
}

void tof_twin_on_uart_byte(void *ctx, uint8_t byte, uint64_t now_ps) {
    struct run *r = ctx;
    r->now_ps = now_ps;
    if (r->uart != NULL) {
        fputc(byte, r->uart);
    }
    if (r->pty.fd >= 0) {
        tof_twin_pty_on_byte(r, byte);
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
