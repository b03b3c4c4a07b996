/*
 * QEMU MPS2 board (mps2-an386: Cortex-M4, mps2-an385: Cortex-M3): the firmware
 * replays a recorded trace against the same simulated I²C bus and VL53 models
 * as host_sim (sim/, integer C), reading the trace and writing the
 * estimate CSV through semihosting. Its output is byte-identical to
 * `host_sim replay TRACE --out EST.csv` with the same window, mode and
 * estimator (a `target` test checks it).
 *
 * Command line (QEMU -append): TRACE.csv EST.csv [WINDOW [tumbling|sliding [ESTIMATOR]]]
 * Exit status: 0 on success, 1 on bad input or output, 2 on bad arguments.
 */
#include <string.h>

#include "board.h"
#include "firmware/app.h"
#include "firmware/calibration_record.h"
#include "firmware/settings.h"
#include "firmware/est_csv.h"
#include "hal/hal_err.h"
#include "qemu_trace.h"
#include "semihost.h"
#include "sim/sim_flash.h"
#include "sim/sim_replay.h"

static void semihost_log_write(void *ctx, const char *text, size_t len) {
    (void)ctx;
    semihost_write_stdout(text, len);
}

static const struct hal_log_ops semihost_log_ops = {.write = semihost_log_write};

/* Everything static: the stack stays small and the RAM use shows in the map file. */
static struct {
    struct qemu_trace trace;
    struct sim_replay sim;
    struct tof_app_config cfg;
    struct tof_platform platform;
    struct tof_app app;
    enum attitude_estimator primary;
    int out;
    uint32_t samples_done;
    int failed;
    char cmdline[512];
    struct sim_flash flash;          /* the record storage, the trace's calibration in it */
    struct tof_record_store records; /* what the firmware's boot reads */
} q;

static void say(const char *a, const char *b) {
    semihost_write_stdout(a, strlen(a));
    semihost_write_stdout(b, strlen(b));
    semihost_write_stdout("\n", 1);
}

static void on_estimate(void *ctx, const struct tof_estimate_record *record) {
    (void)ctx;
    const struct qemu_trace_row *row = NULL;
    if (qemu_trace_row(&q.trace, record->output.last_row, &row) != 0) {
        q.failed = 1;
        return;
    }
    char line[TOF_EST_CSV_ROW_MAX];
    struct tof_text t;
    tof_text_init(&t, line, sizeof line);
    tof_est_csv_row(&t, row->t_ms, &record->output.est[q.primary], record->temp_known,
                    record->temp_cdeg);
    if (t.overflow || semihost_write(q.out, line, t.len) != 0) {
        q.failed = 1;
    }
}

static void on_sample(void *ctx, const struct tof_sample *sample) {
    (void)ctx;
    q.samples_done = sample->index + 1u;
}

static const struct tof_output_ops output_ops = {.estimate = on_estimate, .sample = on_sample};

/* Split the command line in place into at most `max` words. */
static unsigned split_words(char *s, char **words, unsigned max) {
    unsigned n = 0;
    for (unsigned i = 0; s[i] != '\0' && n < max && i < sizeof q.cmdline; ++i) {
        if (s[i] != ' ' && (i == 0u || s[i - 1u] == '\0')) {
            words[n++] = &s[i];
        }
        if (s[i] == ' ') {
            s[i] = '\0';
        }
    }
    return n;
}

static int parse_args(char **trace, char **out, uint16_t *window, bool *sliding) {
    char *w[6] = {0};
    if (semihost_cmdline(q.cmdline, sizeof q.cmdline) != 0) {
        say("replay: ", "no command line (run with -append 'TRACE.csv EST.csv ...')");
        return -1;
    }
    /* QEMU passes "<kernel> <-append text>"; the first word is the image. */
    const unsigned n = split_words(q.cmdline, w, 6);
    if (n < 3u) {
        say("replay: usage: ", "TRACE.csv EST.csv [WINDOW [tumbling|sliding [ESTIMATOR]]]");
        return -1;
    }
    *trace = w[1];
    *out = w[2];
    *window = 100;
    *sliding = false;
    q.primary = ATTITUDE_EST_CONSENSUS;
    if (n > 3u) {
        uint32_t v = 0;
        for (const char *c = w[3]; *c != '\0' && v <= 255u; ++c) {
            v = (*c >= '0' && *c <= '9') ? v * 10u + (uint32_t)(*c - '0') : 1000u;
        }
        if (v < 2u || v > 255u) {
            say("replay: WINDOW must be 2..255: ", w[3]);
            return -1;
        }
        *window = (uint16_t)v;
    }
    if (n > 4u) {
        if (strcmp(w[4], "sliding") == 0) {
            *sliding = true;
        } else if (strcmp(w[4], "tumbling") != 0) {
            say("replay: mode must be tumbling or sliding: ", w[4]);
            return -1;
        }
    }
    if (n > 5u) {
        bool known = false;
        for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
            if (strcmp(w[5], attitude_estimator_name((enum attitude_estimator)e)) == 0) {
                q.primary = (enum attitude_estimator)e;
                known = true;
            }
        }
        if (!known) {
            say("replay: unknown estimator: ", w[5]);
            return -1;
        }
    }
    return 0;
}

/* The trace's calibration keys (docs/reference/trace-format.md) as the flight unit keeps them:
 * record section 2 in the record storage, which the firmware's boot reads (as host_sim replay
 * does). A calibration=FILE is host_sim's to read: refused here. 0, or -1 (said). */
static int apply_trace_calibration(void) {
    const struct trace_v1_cal *tc = &q.trace.reader.meta.cal;
    if ((tc->keys & TRACE_CAL_KEY_FILE) != 0u) {
        say("replay: calibration=FILE is not read by this image: put the keys in the trace, or "
            "replay with host_sim: ",
            q.trace.path);
        return -1;
    }
    if (sim_flash_init(&q.flash, 2u, 2048u) != HAL_OK ||
        tof_record_init(&q.records, sim_flash_hal(&q.flash), 0u, 1u) != HAL_OK) {
        return -1;
    }
    if (tc->calibrated) {
        struct calibration_head head = {.calibrated = true};
        for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
            head.offset_um[i] = tc->offset_um[i];
            head.gain_ppm[i] = tc->gain_ppm[i];
            head.offset_sd_um[i] = tc->offset_sd_um[i];
            head.gain_sd_ppm[i] = tc->gain_sd_ppm[i];
            head.offset_gain_corr_q15[i] = tc->corr_q15[i];
        }
        const struct tof_cal_binding bind = tof_cal_binding_of(&q.cfg);
        uint8_t section[TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH];
        if (tof_cal_encode(&head, tc->has_gain, &bind, section) != HAL_OK ||
            tof_section_save(&q.records, section) != HAL_OK) {
            say("replay: the trace's calibration does not make a record: ", q.trace.path);
            return -1;
        }
    }
    const enum tof_cal_state want = tc->calibrated ? TOF_CAL_APPLIED : TOF_CAL_NONE;
    if (tof_cal_boot(&q.records, &q.app) != want) {
        say("replay: the firmware's boot did not take the trace's calibration: ", q.trace.path);
        return -1;
    }
    return 0;
}

int main(void) {
    char *trace_path = NULL;
    char *out_path = NULL;
    uint16_t window = 0;
    bool sliding = false;
    say(TOF_FW_NAME " " TOF_FW_VERSION, "");
    say(BOARD_NAME, "");
    if (parse_args(&trace_path, &out_path, &window, &sliding) != 0) {
        return 2;
    }
    if (qemu_trace_open(&q.trace, trace_path) != 0) {
        say("replay: ", q.trace.error);
        return 1;
    }
    /* the mode qemu_trace chose by sim/'s policy (the trace's distance_mode, else short; it
     * fails on a reading that would make host_sim, reading ahead, choose long) */
    if (tof_app_config_for_replay(&q.cfg, q.trace.arm_um, q.trace.period_ms, window, sliding,
                                  q.trace.mode) != HAL_OK) {
        say("replay: no firmware configuration fits this trace: ", trace_path);
        return 1;
    }
    q.out = semihost_open(out_path, SEMIHOST_MODE_WRITE_BINARY);
    if (q.out < 0 || semihost_write(q.out, TOF_EST_CSV_HEADER, strlen(TOF_EST_CSV_HEADER)) != 0) {
        say("replay: cannot write ", out_path);
        return 1;
    }
    sim_replay_init(&q.sim, qemu_trace_source(&q.trace), q.trace.period_ms * 1000u, NULL);
    q.platform = (struct tof_platform){
        .board_name = BOARD_NAME,
        .i2c = q.sim.rig.i2c,
        .gpio = q.sim.rig.hal_gpio,
        .time = q.sim.rig.time,
        .log = {.ops = &semihost_log_ops},
        .output = {.ops = &output_ops},
        .sensor_pads_at_avdd = true, /* as host_sim: the same bus bytes as its replay */
    };
    for (unsigned i = 0; i < 4u; ++i) {
        q.platform.xshut_pin[i] = SIM_RIG_XSHUT_PIN(i);
        q.platform.gpio1_pin[i] = SIM_RIG_GPIO1_PIN(i);
    }
    if (tof_app_init(&q.app, &q.platform, &q.cfg) != HAL_OK) {
        say("replay: firmware init failed on ", BOARD_NAME);
        return 1;
    }
    if (apply_trace_calibration() != 0) {
        return 1;
    }
    sim_replay_set_origin(&q.sim, q.app.assembler.origin_us);
    /* Bounded: every iteration advances simulated time, and the progress watchdog ends
     * the loop after SIM_REPLAY_STALL_US without a sample. */
    for (;;) {
        tof_app_step(&q.app, true);
        if (q.failed || q.trace.error[0] != '\0') {
            break;
        }
        if (q.trace.done && q.samples_done >= q.trace.rows) {
            break;
        }
        if (!sim_replay_progressing(&q.sim, q.samples_done)) {
            say("replay: firmware stalled on ", BOARD_NAME);
            q.failed = 1;
            break;
        }
    }
    semihost_close(q.out);
    if (q.trace.error[0] != '\0') {
        say("replay: ", q.trace.error);
        return 1;
    }
    return q.failed ? 1 : 0;
}

void board_exit(int status) {
    /* A negative HAL error becomes a non-zero exit code QEMU passes to its caller. */
    semihost_exit(status < 0 ? -status : status);
}

void board_fault(const char *what) {
    say("FAULT: ", what);
    semihost_exit(128);
}
