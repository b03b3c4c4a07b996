/*
 * The tof_twin command-line tool's own state, shared by its files: the options
 * (tof_twin_args.c), the host side of the UART that decodes the firmware's telemetry into
 * EST.csv rows (tof_twin_host.c), the coverage file, summary and report (tof_twin_report.c)
 * and the run itself (main.c). The twin (struct twin, twin.h) knows nothing of it.
 */
#ifndef TWIN_TOF_TWIN_H
#define TWIN_TOF_TWIN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "estimator/attitude.h"
#include "firmware/config.h"
#include "scene/trace.h"
#include "telemetry/tlm_frame.h"
#include "telemetry/tlm_messages.h"
#include "twin.h"
#include "twin_world.h"

#define FLIGHT_WINDOW 100u /* tof_app_default_config: ATTITUDE_CONFIG_DEFAULT window */

#define TOF_TWIN_COMMANDS      32u
#define TOF_TWIN_USER_COMMANDS 16u /* --command ROW:TEXT */

/* A --command: its row and the command its TEXT parsed into (telemetry/tlm_command_text.h). */
struct user_command {
    uint32_t row;
    struct tlm_command cmd;
};

/* One command the host sends and its answer. */
struct host_command {
    struct tlm_command cmd;
    uint8_t seq;
    uint64_t last_byte_ps; /* its last stop bit ends then */
    bool answered;
};

struct args {
    const char *elf, *trace, *out, *uart_out, *i2c_log, *coverage, *report, *faults;
    const char *estimator;
    unsigned window;
    bool sliding;
    uint64_t seed;
    bool strict, hsi_fail;
    bool late_command;  /* --late-command: accept a window/mode the rows cannot match */
    bool save;          /* --save: send `save` once the settings are in force */
    uint32_t flash_cut; /* --flash-cut N: power cut at the Nth flash erase/double-word */
    const char *flash_in, *flash_out; /* --flash-in/--flash-out: the record pages, 4 KB */
    const char *calibration; /* --calibration HEAD.cal: preloaded as the record's section 2 */
    uint32_t spurious_berr_ppm;
    double max_sim_s;
    struct user_command commands[TOF_TWIN_USER_COMMANDS]; /* --command, in order */
    unsigned ncommands;
};

struct run {
    struct args a;
    struct tof_app_config cfg; /* the flight image's configuration for the trace (main.c) */
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
    uint32_t acks_bad;
    /* Commands, as a host sends them (tof_twin_host.c): the boot's configuration burst (the
     * options' window, mode and estimator, then a status request), back to back at the line
     * rate (again after a reset if the boot's settings differ), with --save a `save` once that
     * is acknowledged, and with --late-command a status request halfway through the trace. */
    struct host_command cmds[TOF_TWIN_COMMANDS];
    unsigned ncmds;       /* queued or sent */
    unsigned nsent;       /* of them sent */
    unsigned next_ack;    /* the command whose answer comes next if they come in order */
    uint8_t next_seq;     /* sequence number of the next command */
    bool mid_sent;        /* the status request halfway through the trace */
    unsigned user_queued; /* --command commands queued so far */
    uint64_t slot0_fw_us; /* the boot's slot 0 on the firmware's timeline (start_boot) */
    uint64_t now_ps;      /* when the byte being decoded ended */
    uint32_t commands_sent, commands_acked, commands_out_of_order, commands_unmatched;
    uint32_t commands_lost;      /* sent, unanswered when the MCU reset (a power cut in `save`) */
    uint64_t ack_latency_max_ps; /* last byte of a command to the end of its answer */
    uint32_t status_confirmed, status_mismatch; /* status replies: the options' settings? */
    uint64_t rows_missing;                      /* rows whose why names missing:X */
    char line[128];
    size_t line_len;
    char last_fault[128];
    struct tlm_health health;      /* the last health frame */
    struct tlm_status boot_status; /* the last boot's status frame (its saved settings) */
    bool save_sent;
    uint64_t health_frames;
};

/* ---- tof_twin_args.c ---- */

/* The command line into `a` (defaults for what it does not say). 0, or -1 after a message
 * on stderr. --help prints the usage and exits 0. */
int tof_twin_parse_args(int argc, char **argv, struct args *a);

/* ---- tof_twin_host.c: what a host on the other end of USART2 does ---- */

/* USART2's transmitter callback (twin_usart on_tx, ctx: struct run): the capture file, text
 * lines, and the telemetry decoder, whose estimate frames become EST.csv rows. */
void tof_twin_on_uart_byte(void *ctx, uint8_t byte, uint64_t now_ps);

/* The host's timers between emulation slices (struct twin host_poll, ctx: struct run): the
 * commands due, sent back to back at the line rate. */
void tof_twin_host_poll(void *ctx);

/* ---- tof_twin_report.c ---- */

/* The executed flash halfwords as address ranges into a->coverage. 0, or -1 (message). */
int tof_twin_write_coverage(const struct run *r);

/* The one-line summary on stderr. */
void tof_twin_print_summary(const struct run *r, bool finished, double host_s);

/* The run's report JSON into a->report (DESIGN §6 keys). 0, or -1 (message). */
int tof_twin_write_report(const struct run *r, bool finished, double host_s);

#endif /* TWIN_TOF_TWIN_H */
