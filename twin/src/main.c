/*
 * tof_twin: the unmodified flight ELF of the NUCLEO-L476RG on the emulated STM32L476 against
 * the simulated sensor head, replaying a recorded trace (README "Digital twin").
 *
 *   tof_twin FIRMWARE.elf TRACE.csv [--estimator NAME] [--window N] [--mode tumbling|sliding]
 *            [--faults SPEC] [--seed S] --out EST.csv [--uart-out CAPTURE.bin]
 *            [--i2c-log BUS.csv] [--strict] [--coverage FILE] [--report FILE.json]
 *            [--hsi-fail] [--spurious-berr PPM] [--max-sim-s S]
 *
 * The firmware's UART telemetry is decoded with the project's decoder (firmware/telemetry)
 * and written through firmware/est_csv, the rows host_sim writes.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "estimator/attitude.h"
#include "firmware/est_csv.h"
#include "firmware/text.h"
#include "scene/crb.h"
#include "scene/trace.h"
#include "sim/sim_fault.h"
#include "telemetry/tlm_frame.h"
#include "telemetry/tlm_messages.h"
#include "twin.h"
#include "twin_elf.h"
#include "twin_world.h"

#define FLIGHT_WINDOW    100u /* tof_app_default_config: ATTITUDE_CONFIG_DEFAULT window */
#define FLIGHT_ARM_UM    30000
#define FLIGHT_PERIOD_MS 20u

struct args {
    const char *elf, *trace, *out, *uart_out, *i2c_log, *coverage, *report, *faults;
    const char *estimator;
    unsigned window;
    bool sliding;
    uint64_t seed;
    bool strict, hsi_fail;
    bool late_command; /* --late-command: accept a window/mode the rows cannot match */
    uint32_t spurious_berr_ppm;
    double max_sim_s;
};

struct run {
    struct args a;
    struct twin t;
    struct twin_world w;
    struct scene_row *rows;
    size_t row_count;
    struct trace_meta meta;
    struct tlm_decoder dec;
    FILE *est, *uart;
    enum attitude_estimator primary;
    uint32_t boots;         /* boots with a status frame */
    uint32_t status_resets; /* t.stats.resets when the last boot's status frame came */

    uint64_t estimates, other_estimates, written, ok_rows;
    uint64_t unflagged_wrong;
    uint64_t faults_text, banners;
    uint32_t acks_bad, acks_ok;
    bool command_sent, command_needed;
    struct tlm_command command;
    uint64_t command_at_us;
    unsigned command_tries;
    char line[128];
    size_t line_len;
    char last_fault[128];
    struct tlm_health health; /* the last health frame */
    uint64_t health_frames;
};

static struct run R;

static void usage(FILE *f) {
    fputs("usage: tof_twin FIRMWARE.elf TRACE.csv [--estimator consensus|kalman|...] [--window N]\n"
          "                [--mode tumbling|sliding] [--faults SPEC] [--seed S] --out EST.csv\n"
          "                [--uart-out CAPTURE.bin] [--i2c-log BUS.csv] [--strict]\n"
          "                [--coverage FILE] [--report FILE.json] [--hsi-fail]\n"
          "                [--spurious-berr PPM] [--max-sim-s S] [--late-command]\n",
          f);
}

static bool parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out) {
    errno = 0;
    char *end = NULL;
    const unsigned long long v = strtoull(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || s[0] == '-' || v < lo || v > hi) {
        return false;
    }
    *out = v;
    return true;
}

static int parse_args(int argc, char **argv, struct args *a) {
    *a = (struct args){.estimator = "consensus", .window = FLIGHT_WINDOW, .max_sim_s = 0.0};
    int pos = 0;
    for (int i = 1; i < argc; ++i) {
        const char *o = argv[i];
        const bool has = i + 1 < argc;
        uint64_t v = 0;
        if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(o, "--strict") == 0) {
            a->strict = true;
        } else if (strcmp(o, "--hsi-fail") == 0) {
            a->hsi_fail = true;
        } else if (strcmp(o, "--late-command") == 0) {
            a->late_command = true;
        } else if (o[0] == '-' && o[1] == '-' && !has) {
            fprintf(stderr, "tof_twin: %s needs a value\n", o);
            return -1;
        } else if (strcmp(o, "--estimator") == 0) {
            a->estimator = argv[++i];
        } else if (strcmp(o, "--window") == 0) {
            if (!parse_u64(argv[++i], TLM_WINDOW_MIN, TLM_WINDOW_MAX, &v)) {
                fprintf(stderr,
                        "tof_twin: --window '%s' is not an integer %u..%u (the set-window "
                        "command's range)\n",
                        argv[i], TLM_WINDOW_MIN, TLM_WINDOW_MAX);
                return -1;
            }
            a->window = (unsigned)v;
        } else if (strcmp(o, "--mode") == 0) {
            const char *m = argv[++i];
            if (strcmp(m, "tumbling") != 0 && strcmp(m, "sliding") != 0) {
                fprintf(stderr, "tof_twin: --mode '%s' is not tumbling or sliding\n", m);
                return -1;
            }
            a->sliding = strcmp(m, "sliding") == 0;
        } else if (strcmp(o, "--faults") == 0) {
            a->faults = argv[++i];
        } else if (strcmp(o, "--seed") == 0) {
            if (!parse_u64(argv[++i], 0, UINT64_MAX, &v)) {
                fprintf(stderr, "tof_twin: --seed '%s' is not a non-negative integer\n", argv[i]);
                return -1;
            }
            a->seed = v;
        } else if (strcmp(o, "--out") == 0) {
            a->out = argv[++i];
        } else if (strcmp(o, "--uart-out") == 0) {
            a->uart_out = argv[++i];
        } else if (strcmp(o, "--i2c-log") == 0) {
            a->i2c_log = argv[++i];
        } else if (strcmp(o, "--coverage") == 0) {
            a->coverage = argv[++i];
        } else if (strcmp(o, "--report") == 0) {
            a->report = argv[++i];
        } else if (strcmp(o, "--spurious-berr") == 0) {
            if (!parse_u64(argv[++i], 0, 1000000, &v)) {
                fprintf(stderr, "tof_twin: --spurious-berr '%s' is not 0..1000000 ppm\n", argv[i]);
                return -1;
            }
            a->spurious_berr_ppm = (uint32_t)v;
        } else if (strcmp(o, "--max-sim-s") == 0) {
            a->max_sim_s = strtod(argv[++i], NULL);
            if (!(a->max_sim_s > 0.0)) {
                fprintf(stderr, "tof_twin: --max-sim-s '%s' is not a positive number\n", argv[i]);
                return -1;
            }
        } else if (o[0] == '-') {
            fprintf(stderr, "tof_twin: unknown option '%s'\n", o);
            usage(stderr);
            return -1;
        } else if (pos == 0) {
            a->elf = o;
            ++pos;
        } else if (pos == 1) {
            a->trace = o;
            ++pos;
        } else {
            fprintf(stderr, "tof_twin: unexpected argument '%s'\n", o);
            return -1;
        }
    }
    if (a->elf == NULL || a->trace == NULL || a->out == NULL) {
        usage(stderr);
        return -1;
    }
    /* The flight image boots with window 100, tumbling (tof_app_default_config); another
     * window or mode is a set-window command, which it reads only about 0.3 s after boot
     * (USART2 once per 20 ms slot), so its windows no longer start at trace row 0 and the
     * rows cannot equal host_sim's; in sliding mode its blocking telemetry also trips the
     * watchdog (docs/boards.md). Refused unless asked for (the coverage run's command path). */
    if ((a->window != FLIGHT_WINDOW || a->sliding) && !a->late_command) {
        fprintf(stderr,
                "tof_twin: --window %u --mode %s: the flight image starts with window %u, "
                "tumbling; other settings arrive by command after boot, and its rows would not "
                "be host_sim's (docs/boards.md). Replay them with host_sim, or pass "
                "--late-command to run the command path anyway\n",
                a->window, a->sliding ? "sliding" : "tumbling", FLIGHT_WINDOW);
        return -1;
    }
    if (a->late_command && (a->window != FLIGHT_WINDOW || a->sliding)) {
        fprintf(stderr, "tof_twin: warning: --late-command: the rows are labelled as if the "
                        "commanded windows started at trace row 0; they are not host_sim's\n");
    }
    return 0;
}

/* ---- UART: capture, text lines, frames ---- */

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

static void host_poll(void *ctx) {
    struct run *r = ctx;
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

static void on_uart_byte(void *ctx, uint8_t byte, uint64_t now_ps) {
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

/* ---- coverage: executed flash halfwords as address ranges ---- */

static int write_coverage(const struct run *r) {
    FILE *f = fopen(r->a.coverage, "w");
    if (f == NULL) {
        fprintf(stderr, "tof_twin: %s: %s\n", r->a.coverage, strerror(errno));
        return -1;
    }
    fputs("# executed flash ranges [start, end) from the twin's block hook\n", f);
    const uint32_t n = TWIN_FLASH_SIZE / 2u;
    for (uint32_t i = 0; i < n;) {
        if (!r->t.covered[i]) {
            ++i;
            continue;
        }
        uint32_t j = i;
        while (j < n && r->t.covered[j]) {
            ++j;
        }
        fprintf(f, "0x%08x 0x%08x\n", TWIN_FLASH_BASE + 2u * i, TWIN_FLASH_BASE + 2u * j);
        i = j;
    }
    return fclose(f);
}

static uint64_t end_us(const struct run *r) {
    if (!r->w.origin_set) {
        return UINT64_MAX;
    }
    /* Every trace row measured, its estimate sent (one health frame is ~20 ms of UART). */
    return r->w.origin_us + ((uint64_t)r->row_count + 2u) * r->w.period_us + 200000u;
}

int main(int argc, char **argv) {
    struct run *r = &R;
    if (parse_args(argc, argv, &r->a) != 0) {
        return 2;
    }
    bool found = false;
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        if (strcmp(attitude_estimator_name((enum attitude_estimator)e), r->a.estimator) == 0) {
            r->primary = (enum attitude_estimator)e;
            found = true;
        }
    }
    if (!found) {
        fprintf(stderr,
                "tof_twin: --estimator '%s' is not consensus, consensus-paper, kalman or "
                "mean\n",
                r->a.estimator);
        return 2;
    }
    char err[512];
    if (trace_load_file(r->a.trace, 10000000u, &r->rows, &r->row_count, &r->meta, err,
                        sizeof err) != 0) {
        fprintf(stderr, "tof_twin: %s\n", err);
        return 1;
    }
    const uint32_t period_ms = r->meta.period_ms != 0u ? r->meta.period_ms : 20u;
    /* The flight image's configuration is compiled in (firmware/src/config.c): arm and
     * period cannot be changed by command, so a trace must match them. */
    if (lround(r->meta.arm_mm * 1000.0) != FLIGHT_ARM_UM || period_ms != FLIGHT_PERIOD_MS) {
        fprintf(stderr,
                "tof_twin: %s: arm_mm %.3f, period_ms %u: the flight image is built for arm_mm "
                "%.1f and period_ms %u (firmware/src/config.c); replay this trace with host_sim\n",
                r->a.trace, r->meta.arm_mm, period_ms, FLIGHT_ARM_UM / 1000.0, FLIGHT_PERIOD_MS);
        return 1;
    }
    struct sim_fault_config faults = {0};
    if (r->a.faults != NULL) {
        size_t at = 0;
        const char *what = NULL;
        if (sim_fault_parse(r->a.faults, &faults, &at, &what) != 0) {
            fprintf(stderr, "tof_twin: --faults: %s at column %zu of '%s'\n",
                    what != NULL ? what : "invalid", at + 1u, r->a.faults);
            return 2;
        }
    }
    faults.seed = (uint32_t)(r->a.seed ^ (r->a.seed >> 32));

    if (twin_init(&r->t, r->a.strict, stderr) != 0) {
        return 1;
    }
    uint8_t *image = malloc(TWIN_FLASH_SIZE);
    struct twin_elf_info info;
    if (image == NULL) {
        return 1;
    }
    memset(image, 0xFF, TWIN_FLASH_SIZE);
    if (twin_elf_load(r->a.elf, image, TWIN_FLASH_BASE, TWIN_FLASH_SIZE, &info, err, sizeof err) !=
        0) {
        fprintf(stderr, "tof_twin: %s\n", err);
        return 1;
    }
    twin_load_flash(&r->t, image);
    free(image);

    r->est = fopen(r->a.out, "w");
    if (r->est == NULL || fputs(TOF_EST_CSV_HEADER, r->est) == EOF) {
        fprintf(stderr, "tof_twin: %s: %s\n", r->a.out, strerror(errno));
        return 1;
    }
    if (r->a.uart_out != NULL && (r->uart = fopen(r->a.uart_out, "wb")) == NULL) {
        fprintf(stderr, "tof_twin: %s: %s\n", r->a.uart_out, strerror(errno));
        return 1;
    }
    if (r->a.i2c_log != NULL) {
        r->w.i2c_log = fopen(r->a.i2c_log, "w");
        if (r->w.i2c_log == NULL) {
            fprintf(stderr, "tof_twin: %s: %s\n", r->a.i2c_log, strerror(errno));
            return 1;
        }
        fputs("t_us,addr,write,read,result\n", r->w.i2c_log);
    }
    twin_world_init(&r->w, r->rows, r->row_count, period_ms * 1000u, &faults);
    r->t.world = &r->w;
    r->t.rcc.hsi_broken = r->a.hsi_fail;
    r->t.i2c.spurious_berr_ppm = r->a.spurious_berr_ppm;
    r->t.usart.on_tx = on_uart_byte;
    r->t.host_poll = host_poll;
    r->t.host_ctx = r;
    r->t.usart.tx_ctx = r;
    tlm_decoder_init(&r->dec, tlm_message_types(TLM_ACCEPT_TELEMETRY));
    r->status_resets = UINT32_MAX;
    twin_reset(&r->t, true);

    const double trace_s = (double)r->row_count * period_ms / 1000.0;
    const double max_s = r->a.max_sim_s > 0.0 ? r->a.max_sim_s : trace_s + 30.0;
    const uint64_t max_ps = (uint64_t)(max_s * 1e12);
    const clock_t c0 = clock();
    for (;;) {
        /* Look again each simulated second: the end is known once the origin is. */
        const uint64_t want = end_us(r);
        uint64_t lim = twin_now_ps(&r->t) + 1000000000000ull;
        lim = want != UINT64_MAX && want * 1000000u < lim ? want * 1000000u : lim;
        r->t.limit_ps = lim < max_ps ? lim : max_ps;
        twin_run(&r->t);
        if (r->t.stop == TWIN_STOP_LIMIT && twin_now_ps(&r->t) < max_ps &&
            twin_now_us(&r->t) < end_us(r)) {
            r->t.stop = TWIN_RUNNING; /* the origin moved the end: go on */
            continue;
        }
        break;
    }
    const double host_s = (double)(clock() - c0) / CLOCKS_PER_SEC;
    const bool finished = r->t.stop == TWIN_STOP_LIMIT && twin_now_us(&r->t) >= end_us(r);
    int rc = 0;
    if (!finished) {
        if (r->t.stop == TWIN_STOP_LIMIT) {
            fprintf(stderr,
                    "tof_twin: the run did not finish within %.1f s of simulated time (%s)\n",
                    max_s,
                    r->w.origin_set ? "trace not fully replayed"
                                    : "the firmware never started its sensors");
        } else {
            fprintf(stderr, "tof_twin: stopped: %s\n", r->t.stop_msg);
        }
        rc = 1;
    }
    if (r->w.source_error != 0) {
        rc = 1;
    }
    if (r->command_needed && r->acks_ok == 0u) {
        fprintf(stderr, "tof_twin: %u tries, %llu receiver overruns, %llu bytes received\n",
                r->command_tries, (unsigned long long)r->t.usart.overruns,
                (unsigned long long)r->t.usart.bytes_rx);
        fprintf(stderr, "tof_twin: the firmware never acknowledged the set-window command "
                        "(--window/--mode other than the flight default 100 tumbling): its rows "
                        "are not those of the options asked for\n");
        rc = 1;
    }
    fclose(r->est);
    if (r->uart != NULL) {
        fclose(r->uart);
    }
    if (r->w.i2c_log != NULL) {
        fclose(r->w.i2c_log);
    }
    if (r->a.coverage != NULL && write_coverage(r) != 0) {
        rc = 1;
    }
    const double minsn = (double)r->t.stats.instructions / 1e6;
    fprintf(stderr,
            "tof_twin: %s: %.3f s simulated, %.2f s host, %.1f M instructions (%.1f M/s), "
            "%" PRIu64 " estimates (%" PRIu64 " rows written), %u boots, %u watchdog resets, "
            "%u HardFaults, %" PRIu64 " unflagged wrong\n",
            finished ? "done" : "FAILED", (double)twin_now_ps(&r->t) / 1e12, host_s, minsn,
            host_s > 0 ? minsn / host_s : 0.0, r->estimates, r->written, r->boots,
            r->t.stats.watchdog_resets, r->t.stats.hardfaults, r->unflagged_wrong);
    if (r->a.report != NULL) {
        FILE *f = fopen(r->a.report, "w");
        if (f == NULL) {
            fprintf(stderr, "tof_twin: %s: %s\n", r->a.report, strerror(errno));
            return 1;
        }
        fprintf(
            f,
            "{\"finished\": %s, \"stop\": \"%s\", \"sim_s\": %.6f, \"host_s\": %.3f,\n"
            " \"instructions\": %" PRIu64 ", \"minsn_per_s\": %.2f, \"warps\": %" PRIu64 ",\n"
            " \"mmio_reads\": %" PRIu64 ", \"mmio_writes\": %" PRIu64 ",\n"
            " \"estimates\": %" PRIu64 ", \"rows_written\": %" PRIu64 ", \"ok_rows\": %" PRIu64
            ", \"unflagged_wrong\": %" PRIu64 ",\n"
            " \"boots\": %u, \"banners\": %" PRIu64 ", \"resets\": %u, \"watchdog_resets\": %u,"
            " \"software_resets\": %u, \"hardfaults\": %u, \"fault_pc\": %u, \"fault_addr\": %u,\n"
            " \"fault_lines\": %" PRIu64 ", \"last_fault\": \"%s\", \"systicks\": %u,\n"
            " \"i2c_transfers\": %" PRIu64 ", \"spurious_berr\": %u, \"bus_recoveries\": %u,"
            " \"commands_refused\": %u,\n"
            " \"health_frames\": %" PRIu64 ", \"loop_overruns\": %u, \"loop_max_us\": %u,"
            " \"tx_dropped\": %u, \"uart_overruns\": %" PRIu64 "}\n",
            finished ? "true" : "false", finished ? "" : r->t.stop_msg,
            (double)twin_now_ps(&r->t) / 1e12, host_s, r->t.stats.instructions,
            host_s > 0 ? minsn / host_s : 0.0, r->t.stats.warps, r->t.stats.mmio_reads,
            r->t.stats.mmio_writes, r->estimates, r->written, r->ok_rows, r->unflagged_wrong,
            r->boots, r->banners, r->t.stats.resets, r->t.stats.watchdog_resets,
            r->t.stats.software_resets, r->t.stats.hardfaults, r->t.fault_pc, r->t.fault_addr,
            r->faults_text, r->last_fault, r->t.stats.exceptions[15], r->w.transfers,
            r->t.i2c.berr_injected, r->w.rig.bus.stats.recoveries, r->acks_bad, r->health_frames,
            r->health.loop_overruns, r->health.loop_max_us, r->health.tx_dropped,
            r->t.usart.overruns);
        fclose(f);
    }
    free(r->rows);
    twin_free(&r->t);
    return rc;
}
