/*
 * The tof_twin command-line tool's own state, shared by its files: the options
 * (tof_twin_args.c), the host side of the UART that decodes the firmware's telemetry into
 * EST.csv rows (tof_twin_host.c), the line on a pseudo-terminal (tof_twin_pty.c), the
 * coverage file, summary and report (tof_twin_report.c) and the run itself (main.c). The
 * twin (struct twin, twin.h) knows nothing of it.
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

/* A command frame a host sent over the pseudo-terminal, waiting for its answer. */
struct pty_command {
    uint8_t seq, type;
    uint64_t last_byte_ps; /* its last stop bit ends then */
};
#define TOF_TWIN_PTY_PENDING 32u

/* --pty: USART2 on a pseudo-terminal (tof_twin_pty.c). */
struct tof_twin_pty {
    int fd; /* the master, -1 without --pty */
    char path[128];
    bool line_open; /* a program has the slave open */
    bool paced;     /* simulated time held to the host's clock */
    int64_t anchor_host_ns;
    uint64_t anchor_sim_ps; /* the pair of times pacing started from */
    int64_t slept_ns, behind_max_ns;
    uint8_t in[512];
    size_t in_len; /* the host's bytes the receiver's queue could not take yet */
    uint8_t out[8192];
    size_t out_len;         /* the firmware's bytes for the host, written at the next poll */
    uint64_t byte_end_ps;   /* the end of the host byte being decoded */
    struct tlm_decoder dec; /* the host's command frames (ack latency) */
    struct pty_command pending[TOF_TWIN_PTY_PENDING];
    unsigned npending;
    uint32_t opens, commands, answered, nacked;
    uint64_t ack_latency_max_ps, ack_latency_sum_ps;
    uint64_t bytes_in, bytes_out, dropped, unheard;
    int stop_signal;
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
    bool pty; /* --pty: USART2 on a pseudo-terminal, the trace looping, until a signal */
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
    struct tof_twin_pty pty;
    bool cal_preloaded;   /* a calibration was written into the record pages (preload) */
    char cal_source[320]; /* where it came from */
    bool cal_warned;
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

/* ---- tof_twin_pty.c: --pty ---- */

/* The pseudo-terminal opened (raw, 115200 Bd), `pty PATH` on stdout, SIGINT and SIGTERM
 * caught to end the run cleanly. 0, or -1 (message on stderr). */
int tof_twin_pty_open(struct run *r);
void tof_twin_pty_close(struct run *r);

/* Between emulation slices: a line opened or closed, the host's bytes in, the firmware's
 * out, and the pacing (sleeps while simulated time would run ahead of the host's clock). */
void tof_twin_pty_poll(struct run *r);

/* A byte the firmware sent, for the host on the line (dropped while none is open). */
void tof_twin_pty_on_byte(struct run *r, uint8_t byte);

/* An answer to a command the host sent over the line: true if it was one (its latency
 * counted), false if not. */
bool tof_twin_pty_answer(struct run *r, const struct tlm_ack *ack);

/* The run was ended by SIGINT or SIGTERM (the way a --pty run ends). */
bool tof_twin_pty_stopped_by_signal(const struct run *r);

/* ---- tof_twin_report.c ---- */

/* The executed flash halfwords as address ranges into a->coverage. 0, or -1 (message). */
int tof_twin_write_coverage(const struct run *r);

/* The one-line summary on stderr. */
void tof_twin_print_summary(const struct run *r, bool finished, double host_s);

/* The run's report JSON into a->report (DESIGN §6 keys). 0, or -1 (message). */
int tof_twin_write_report(const struct run *r, bool finished, double host_s);

#endif /* TWIN_TOF_TWIN_H */
