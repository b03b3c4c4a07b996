/* tof_twin: the unmodified flight ELF of the NUCLEO-L476RG on the emulated STM32L476 against
 * the simulated sensor head, replaying a recorded trace (README "Digital twin").
 *
 *   tof_twin FIRMWARE.elf TRACE.csv [--estimator NAME] [--window N] [--mode tumbling|sliding]
 *            [--faults SPEC] [--seed S] --out EST.csv [--uart-out CAPTURE.bin]
 *            [--i2c-log BUS.csv] [--strict] [--coverage FILE] [--report FILE.json]
 *            [--hsi-fail] [--spurious-berr PPM] [--max-sim-s S] [--calibration HEAD.cal]
 *            [--command ROW:TEXT]... [--save] [--flash-cut N] [--flash-in F] [--flash-out F]
 *   tof_twin FIRMWARE.elf TRACE.csv --pty [...]   (USART2 on a pseudo-terminal: `pty PATH`)
 *
 * This file sets the run up and runs it; the options are read by tof_twin_args.c, the
 * firmware's UART telemetry is decoded by tof_twin_host.c with the project's decoder
 * (firmware/telemetry) and written through firmware/est_csv, the rows host_sim writes, and
 * tof_twin_report.c writes the summary, report and coverage; tof_twin_pty.c puts the line on
 * a pseudo-terminal.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "calibrate/cal_apply.h"
#include "firmware/config.h"
#include "firmware/est_csv.h"
#include "firmware/settings.h"
#include "hal/hal_err.h"
#include "sim/sim_fault.h"
#include "tof_twin.h"
#include "twin_elf.h"

static struct run R;

/* The estimator whose rows EST.csv holds, by name. 0, or -1 after a message. */
static int select_estimator(struct run *r) {
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
        return -1;
    }
    return 0;
}

/* The trace and its period (ms) into *period_ms; the firmware configuration the flight image
 * runs it in (r->cfg: its defaults at the trace's arm and period, which the boot takes from
 * the saved settings, preload_records()). 0, or -1 after a message. */
static int load_trace(struct run *r, uint32_t *period_ms) {
    char err[512];
    if (trace_load_file(r->a.trace, 10000000u, &r->rows, &r->row_count, &r->meta, err,
                        sizeof err) != 0) {
        fprintf(stderr, "tof_twin: %s\n", err);
        return -1;
    }
    *period_ms = r->meta.period_ms != 0u ? r->meta.period_ms : 20u;
    const int32_t arm_um = (int32_t)lround(r->meta.arm_mm * 1000.0);
    const struct tof_app_config *image = &tof_app_default_config;
    if (tof_app_config_for_replay(&r->cfg, arm_um, *period_ms, image->estimator.window,
                                  image->estimator.mode == ATTITUDE_SLIDING,
                                  image->timing.mode) != HAL_OK) {
        fprintf(stderr,
                "tof_twin: %s: arm_mm %.3f, period_ms %u: the flight image cannot run them (%s "
                "mode: the shortest period is a %u ms budget + %u ms margin; the arm 1..1000 "
                "mm)\n",
                r->a.trace, r->meta.arm_mm, *period_ms, vl53_distance_mode_name(image->timing.mode),
                (unsigned)vl53_shortest_budget_ms(image->timing.mode), VL53_IMP_MARGIN_MS);
        return -1;
    }
    r->cfg.raw_output = image->raw_output; /* the image's, not the replay's raw stream */
    return 0;
}

/* The record pages (TWIN_RECORDS_SIZE bytes) from or to `path`: what a reflash keeps between
 * runs (--flash-in, --flash-out). 0, or -1 (message on stderr). */
static int records_file(struct run *r, const char *path, bool write) {
    uint8_t *mem = &r->t.flash[TWIN_RECORDS_BASE - TWIN_FLASH_BASE];
    FILE *f = fopen(path, write ? "wb" : "rb");
    const size_t n = f == NULL ? 0u
                     : write   ? fwrite(mem, 1, TWIN_RECORDS_SIZE, f)
                               : fread(mem, 1, TWIN_RECORDS_SIZE, f);
    if (f == NULL || n != TWIN_RECORDS_SIZE || fclose(f) != 0) {
        fprintf(stderr, "tof_twin: %s: %s\n", path,
                f == NULL ? strerror(errno) : "not the 4096 bytes of the record pages");
        return -1;
    }
    return 0;
}

/* The twin with the ELF in its flash. 0, or -1 (message on stderr). */
static int load_firmware(struct run *r) {
    char err[512];
    if (twin_init(&r->t, r->a.strict, stderr) != 0) {
        return -1;
    }
    uint8_t *image = malloc(TWIN_FLASH_SIZE);
    struct twin_elf_info info;
    if (image == NULL) {
        return -1;
    }
    memset(image, 0xFF, TWIN_FLASH_SIZE);
    if (twin_elf_load(r->a.elf, image, TWIN_FLASH_BASE, TWIN_FLASH_SIZE, &info, err, sizeof err) !=
        0) {
        fprintf(stderr, "tof_twin: %s\n", err);
        return -1;
    }
    twin_load_flash(&r->t, image);
    free(image);
    return r->a.flash_in != NULL ? records_file(r, r->a.flash_in, false) : 0;
}

/* The record pages as a user leaves them for this trace: the settings section with the
 * trace's arm and period when they are not the image's own (set-arm, set-period, `save`: the
 * boot applies them), and the head's calibration (--calibration, else the trace's keys,
 * docs/reference/trace-format.md) as section 2, made in the configuration the boot arrives at, as
 * host_sim replay preloads it. The flight firmware's boot finds both where a flight unit keeps
 * them. 0, or -1 (message on stderr). */
static int preload_records(struct run *r) {
    static struct trace_v1_meta m; /* the trace's keys, checked by its reader already */
    memset(&m, 0, sizeof m);
    for (unsigned k = 0; k < r->meta.count && k < TRACE_MAX_META; ++k) {
        uint32_t col = 0;
        const char *what = NULL;
        memcpy(m.key[k], r->meta.key[k], sizeof m.key[k]);
        memcpy(m.value[k], r->meta.value[k], sizeof m.value[k]);
        m.line[k] = r->meta.line[k];
        (void)trace_v1_cal_value(&m.cal, m.key[k], m.value[k], m.line[k], &col, &what);
        m.count = k + 1u;
    }
    /* The plate's rate bound reaches the unit as its default only: a trace that states
     * another is refused, not replayed under a bound it does not state. */
    for (unsigned k = 0; k < r->meta.count && k < TRACE_MAX_META; ++k) {
        if (strcmp(r->meta.key[k], "max_rate_deg_s") == 0 &&
            fabs(strtod(r->meta.value[k], NULL) * 1000.0 -
                 (double)ATTITUDE_MAX_RATE_MDEG_S_DEFAULT) > 0.5) {
            fprintf(stderr,
                    "tof_twin: %s:%lu: max_rate_deg_s=%s: the twin replays at the unit's "
                    "default rate bound (%u m°/s) only; use host_sim replay for another\n",
                    r->a.trace, (unsigned long)r->meta.line[k], r->meta.value[k],
                    ATTITUDE_MAX_RATE_MDEG_S_DEFAULT);
            return -1;
        }
    }
    const char *what = NULL;
    uint32_t line = 0;
    static struct cal_apply cal;
    static struct sim_flash flash;
    static struct tof_record_store store;
    if (trace_v1_cal_check(&m.cal, &what, &line) != 0 ||
        cal_apply_resolve("tof_twin", r->a.calibration, &m, r->a.trace, &cal) != 0) {
        if (what != NULL) {
            fprintf(stderr, "tof_twin: %s:%u: %s\n", r->a.trace, line, what);
        }
        return -1;
    }
    uint8_t *mem = &r->t.flash[TWIN_RECORDS_BASE - TWIN_FLASH_BASE + TWIN_RECORD_PAGE_AT];
    /* A unit's storage (--flash-in) is never overwritten from the trace's keys: only by an
     * explicit --calibration, and then it says so. */
    if (r->a.flash_in != NULL && r->a.calibration == NULL && cal.cal.calibrated) {
        fprintf(stderr,
                "tof_twin: note: %s: the trace's calibration keys are not written over the "
                "unit's storage from --flash-in %s: the unit runs with the calibration it "
                "stores; pass --calibration HEAD.cal to write one\n",
                r->a.trace, r->a.flash_in);
        cal.cal.calibrated = false;
    } else if (r->a.flash_in != NULL && cal.cal.calibrated) {
        fprintf(stderr,
                "tof_twin: note: --calibration %s written into the unit's storage from "
                "--flash-in %s (record section 2, in place of any calibration there)\n",
                r->a.calibration, r->a.flash_in);
    }
    r->cal_preloaded = cal.cal.calibrated;
    snprintf(r->cal_source, sizeof r->cal_source, "%s", cal.source);
    /* bound as the HEAD.cal states (head, mode, budget, arm): the flight image's boot
     * refuses what a flight unit would, and the report's calibration_state says so */
    if (cal_apply_preload(&cal.cal, &r->cfg, &cal.made_in, mem, &flash, &store) != 0) {
        return -1;
    }
    const struct tof_app_config *image = &tof_app_default_config;
    if (r->cfg.estimator.arm_um != image->estimator.arm_um ||
        r->cfg.timing.inter_measurement_ms != image->timing.inter_measurement_ms) {
        const struct tof_settings s = {
            .window = image->estimator.window,
            .sliding = image->estimator.mode == ATTITUDE_SLIDING,
            .primary = (uint8_t)ATTITUDE_EST_CONSENSUS,
            .running = true,
            .raw_output = image->raw_output,
            .arm_um = r->cfg.estimator.arm_um,
            .period_ms = (uint16_t)r->cfg.timing.inter_measurement_ms,
        };
        (void)tof_record_load(&store); /* the record in use, whose other sections are kept */
        if (r->a.flash_in != NULL) {
            fprintf(stderr,
                    "tof_twin: note: %s: arm_mm %.3f, period_ms %u written into the unit's "
                    "settings from --flash-in %s (as set-arm, set-period and save would)\n",
                    r->a.trace, r->meta.arm_mm, (unsigned)s.period_ms, r->a.flash_in);
        }
        if (tof_settings_save(&store, &s) != HAL_OK) {
            fprintf(stderr, "tof_twin: internal: the settings do not make a record\n");
            return -1;
        }
    }
    memcpy(mem, flash.mem[0], CAL_APPLY_PAGE_SIZE);
    memcpy(mem + CAL_APPLY_PAGE_SIZE, flash.mem[1], CAL_APPLY_PAGE_SIZE);
    return 0;
}

/* EST.csv with its header, the UART capture and the I2C log if asked for. 0, or -1. */
static int open_outputs(struct run *r) {
    if (r->a.out == NULL) {
        return 0; /* --pty: the rows go to the host on the line */
    }
    r->est = fopen(r->a.out, "w");
    if (r->est == NULL || fputs(TOF_EST_CSV_HEADER, r->est) == EOF) {
        fprintf(stderr, "tof_twin: %s: %s\n", r->a.out, strerror(errno));
        return -1;
    }
    if (r->a.uart_out != NULL && (r->uart = fopen(r->a.uart_out, "wb")) == NULL) {
        fprintf(stderr, "tof_twin: %s: %s\n", r->a.uart_out, strerror(errno));
        return -1;
    }
    if (r->a.i2c_log != NULL) {
        r->w.i2c_log = fopen(r->a.i2c_log, "w");
        if (r->w.i2c_log == NULL) {
            fprintf(stderr, "tof_twin: %s: %s\n", r->a.i2c_log, strerror(errno));
            return -1;
        }
        fputs("t_us,addr,write,read,result\n", r->w.i2c_log);
    }
    return 0;
}

/* The world over the trace, wired to the twin's pins and bus; the host on USART2; then the
 * power-on reset. */
static void wire(struct run *r, uint32_t period_ms, const struct sim_fault_config *faults) {
    twin_world_init(&r->w, r->rows, r->row_count, period_ms * 1000u, faults);
    r->w.loop = r->a.pty;
    r->t.world = &r->w;
    r->t.rcc.hsi_broken = r->a.hsi_fail;
    r->t.i2c.spurious_berr_ppm = r->a.spurious_berr_ppm;
    r->t.usart.on_tx = tof_twin_on_uart_byte;
    r->t.host_poll = tof_twin_host_poll;
    r->t.host_ctx = r;
    r->t.usart.tx_ctx = r;
    r->t.flash_pe.cut_after = r->a.flash_cut;
    tlm_decoder_init(&r->dec, tlm_message_types(TLM_ACCEPT_TELEMETRY));
    r->status_resets = UINT32_MAX;
    r->next_seq = 0x40u;
    twin_reset(&r->t, true);
}

static uint64_t end_us(const struct run *r) {
    if (!r->w.origin_set || r->a.pty) {
        return UINT64_MAX;
    }
    /* Every trace row measured, its estimate sent (one health frame is ~20 ms of UART). */
    return r->w.origin_us + ((uint64_t)r->row_count + 2u) * r->w.period_us + 200000u;
}

/* Run until every trace row is replayed or `max_ps` of simulated time. */
static void run_to_end(struct run *r, uint64_t max_ps) {
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
}

/* Why the run failed, if it did: 0 or 1 (the exit status so far). */
static int judge(const struct run *r, bool finished, double max_s) {
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
    if (r->commands_acked + r->commands_lost != r->commands_sent || r->status_mismatch != 0u) {
        fprintf(stderr,
                "tof_twin: %u commands sent, %u acknowledged, %u lost to a reset, %u refused, "
                "%u status replies with other settings; %llu receiver overruns, %llu bytes "
                "received: the rows are not those of the options asked for\n",
                r->commands_sent, r->commands_acked, r->commands_lost, r->acks_bad,
                r->status_mismatch, (unsigned long long)r->t.usart.overruns,
                (unsigned long long)r->t.usart.bytes_rx);
        rc = 1;
    }
    return rc;
}

/* Close the outputs, write coverage, summary and report. The exit status. */
static int finish(struct run *r, bool finished, double max_s, double host_s) {
    int rc = judge(r, finished, max_s);
    if (r->est != NULL) {
        fclose(r->est);
    }
    tof_twin_pty_close(r);
    if (r->uart != NULL) {
        fclose(r->uart);
    }
    if (r->w.i2c_log != NULL) {
        fclose(r->w.i2c_log);
    }
    if (r->a.flash_out != NULL && records_file(r, r->a.flash_out, true) != 0) {
        rc = 1;
    }
    if (r->a.coverage != NULL && tof_twin_write_coverage(r) != 0) {
        rc = 1;
    }
    tof_twin_print_summary(r, finished, host_s);
    if (r->a.report != NULL && tof_twin_write_report(r, finished, host_s) != 0) {
        return 1;
    }
    free(r->rows);
    twin_free(&r->t);
    return rc;
}

int main(int argc, char **argv) {
    struct run *r = &R;
    r->pty.fd = -1;
    if (tof_twin_parse_args(argc, argv, &r->a) != 0 || select_estimator(r) != 0) {
        return 2;
    }
    uint32_t period_ms = 0;
    if (load_trace(r, &period_ms) != 0) {
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
    if (load_firmware(r) != 0 || preload_records(r) != 0 || open_outputs(r) != 0) {
        return 1;
    }
    if (r->a.pty && tof_twin_pty_open(r) != 0) {
        return 1;
    }
    wire(r, period_ms, &faults);

    /* --pty runs until a signal (or --max-sim-s): 10^6 s bound the simulated time. */
    const double trace_s = (double)r->row_count * period_ms / 1000.0;
    const double max_s = r->a.max_sim_s > 0.0 ? r->a.max_sim_s : r->a.pty ? 1e6 : trace_s + 30.0;
    const clock_t c0 = clock();
    run_to_end(r, (uint64_t)(max_s * 1e12));
    const double host_s = (double)(clock() - c0) / CLOCKS_PER_SEC;
    const bool finished = r->a.pty
                              ? tof_twin_pty_stopped_by_signal(r) ||
                                    (r->t.stop == TWIN_STOP_LIMIT && r->a.max_sim_s > 0.0)
                              : r->t.stop == TWIN_STOP_LIMIT && twin_now_us(&r->t) >= end_us(r);
    return finish(r, finished, max_s, host_s);
}
