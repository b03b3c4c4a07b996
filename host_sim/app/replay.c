/* host_sim replay's loop: trace rows through the simulated world and the firmware (replay.h). */
/*
 * The firmware's outputs go to the statistics (replay_stats), the estimate CSV and the
 * plot data (replay_plot); the distance mode is replay_mode's, the words after the run
 * replay_report's. Every call points down from here: none of them calls back.
 */
#include "replay.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimator/attitude.h"
#include "firmware/calibration_record.h"
#include "firmware/est_csv.h"
#include "hal/hal_err.h"
#include "replay_report.h"
#include "replay_state.h"

static struct replay R;

static void on_estimate(void *ctx, const struct tof_estimate_record *record) {
    struct replay *r = ctx;
    if (r->commands.count > 0u) { /* the link as the flight image has it (--command) */
        tof_link_output_ops.estimate(&r->commands.link, record);
    }
    const struct attitude_output *out = &record->output;
    int rc = 0;
    /* The window's last sample from its time (the end of its slot, firmware/src/assembler.c),
     * not from the estimator's row count: a set-window command starts that again. */
    const uint64_t period_us = r->app.assembler_cfg.period_us;
    const uint64_t index = (record->t_us - r->app.assembler.origin_us) / period_us - 1u;
    const struct scene_row *row = scene_row_stream_get(&r->stream, index, &rc);
    if (row == NULL && rc > 0) {
        /* A slot the trace does not reach: the firmware closed it (all readings missing)
         * before the replay stopped, which a faulted run's timing can bring about. No row to
         * score or write it against: counted in the report ("estimates_after_end"). */
        r->after_end++;
        return;
    }
    if (row == NULL) {
        fprintf(stderr, "host_sim replay: internal: trace row %llu no longer available\n",
                (unsigned long long)index);
        r->failed = 1;
        return;
    }
    if (r->est_out != NULL) {
        char line[TOF_EST_CSV_ROW_MAX];
        struct tof_text t;
        tof_text_init(&t, line, sizeof line);
        tof_est_csv_row(&t, row->t_ms, &out->est[r->primary], record->temp_known,
                        record->temp_cdeg);
        if (t.overflow || fputs(line, r->est_out) == EOF) {
            r->failed = 1;
        }
    }
    if (r->plot.data != NULL) {
        replay_plot_row(&r->plot, row, out);
    }
    replay_stats_estimate(&r->stats, row, out, r->args->sliding);
}

static void on_sample(void *ctx, const struct tof_sample *sample) {
    struct replay *r = ctx;
    if (r->commands.count > 0u) { /* a re-zero's samples reach the link (--command) */
        tof_link_output_ops.sample(&r->commands.link, sample);
    }
    int rc = 0;
    r->samples_done = (uint64_t)sample->index + 1u;
    const struct scene_row *row = scene_row_stream_get(&r->stream, sample->index, &rc);
    if (row == NULL) {
        if (rc < 0) {
            r->failed = 1; /* the stream's own message is printed by run() */
        }
        return; /* past the end of the trace: nothing to account */
    }
    const bool window_end =
        !r->args->sliding && (sample->index + 1u) % r->app_cfg.estimator.window == 0u;
    replay_stats_sample(&r->stats, row, window_end, r->arm_mm);
}

static void on_event(void *ctx, const struct tof_event *ev) {
    struct replay *r = ctx;
    switch (ev->kind) {
    case TOF_EVENT_HEALTH:
        ++r->health_events;
        break;
    case TOF_EVENT_REINIT:
        ++r->reinit_events;
        break;
    case TOF_EVENT_BUS_RECOVERY:
        ++r->bus_recovery_events;
        break;
    case TOF_EVENT_TEMP_UPDATE:
        ++r->temp_update_events;
        break;
    case TOF_EVENT_TEMP_UPDATE_DONE:
        r->temp_update_failures += ev->err != HAL_OK ? 1u : 0u;
        break;
    case TOF_EVENT_OVERRUN:
    default:
        ++r->overrun_events;
        break;
    }
}

static const struct tof_output_ops replay_output_ops = {
    .estimate = on_estimate, .sample = on_sample, .event = on_event};

static int open_inputs(struct replay *r) {
    FILE *f = fopen(r->args->trace_path, "rb");
    if (f == NULL) {
        fprintf(stderr, "host_sim replay: %s: %s\n", r->args->trace_path, strerror(errno));
        return -1;
    }
    if (trace_reader_open(&r->reader, f, r->args->trace_path) != 0) {
        fprintf(stderr, "host_sim replay: %s\n", trace_reader_error(&r->reader));
        return -1;
    }
    /* The reader parsed and checked both (arm_mm > 0, period_ms 1..2^32-1). */
    r->arm_mm = r->reader.meta.arm_mm;
    if (r->arm_mm < 1.0 || r->arm_mm > 1000.0) {
        fprintf(stderr, "host_sim replay: %s:%lu: arm_mm %g is not a length in 1..1000 mm\n",
                r->args->trace_path, trace_reader_meta_line(&r->reader, "arm_mm"), r->arm_mm);
        return -1;
    }
    r->period_ms = trace_reader_timing(&r->reader)->period_ms; /* or TRACE_DEFAULT_PERIOD_MS */
    if (r->period_ms > 10000u) {
        fprintf(stderr, "host_sim replay: %s:%lu: period_ms %u is not an integer 1..10000\n",
                r->args->trace_path, trace_reader_meta_line(&r->reader, "period_ms"), r->period_ms);
        return -1;
    }
    scene_row_stream_init(&r->stream, scene_pull_trace, &r->reader);
    return cal_apply_resolve("host_sim replay", r->args->calibration_path, &r->reader.core.meta,
                             r->args->trace_path, &r->cal);
}

/* The head's temperature of trace row `row` (the temp_c column), for the simulated sensor. */
static int row_temperature(void *ctx, uint32_t row, bool *present, int16_t *cdeg) {
    struct replay *r = ctx;
    int rc = 0;
    const struct scene_row *got = scene_row_stream_get(&r->stream, row, &rc);
    if (got == NULL) {
        return rc;
    }
    *present = got->has_temp;
    *cdeg = got->has_temp ? (int16_t)lround(got->temp_c * 100.0) : 0; /* a trace's: exact */
    return 0;
}

static const struct sim_temp_source_ops row_temperature_ops = {.at = row_temperature};

/* The estimator to write, the faults, the simulated world and the firmware's platform. */
static int configure_world(struct replay *r) {
    const uint32_t period_us = r->period_ms * 1000u;
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        if (strcmp(attitude_estimator_name((enum attitude_estimator)e), r->args->estimator) == 0) {
            r->primary = (enum attitude_estimator)e;
        }
    }
    if (r->args->faults != NULL) {
        size_t at = 0;
        const char *what = NULL;
        if (sim_fault_parse(r->args->faults, &r->faults, &at, &what) != 0) {
            fprintf(stderr, "host_sim replay: --faults: %s at column %zu of '%s'\n",
                    what != NULL ? what : "invalid", at + 1u, r->args->faults);
            return -1;
        }
    }
    r->faults.seed = (uint32_t)(r->args->seed ^ (r->args->seed >> 32));
    sim_replay_init(&r->sim, scene_row_stream_source(&r->stream), period_us, &r->faults);
    r->sim.rig.bus.bus_hz = (uint32_t)r->app_cfg.i2c_khz * 1000u; /* --i2c-khz */
    r->platform = (struct tof_platform){
        .board_name = "host_sim",
        .i2c = r->sim.rig.i2c,
        .gpio = r->sim.rig.hal_gpio,
        .time = r->sim.rig.time,
        .output = {.ops = &replay_output_ops, .ctx = r},
        .sensor_pads_at_avdd = true, /* as the NUCLEO boards it simulates */
    };
    /* A trace with a temp_c column: the head has a temperature sensor reading it (an empty
     * cell is a failed reading); without the column, a board with no sensor. */
    if (r->reader.core.column_of[TRACE_COL_TEMP] >= 0) {
        const struct sim_temp_source rows = {.ops = &row_temperature_ops, .ctx = r};
        r->platform.temp = sim_replay_temp(&r->sim, rows);
    }
    for (unsigned i = 0; i < 4; ++i) {
        r->platform.xshut_pin[i] = SIM_RIG_XSHUT_PIN(i);
        r->platform.gpio1_pin[i] = SIM_RIG_GPIO1_PIN(i);
    }
    return 0;
}

static int configure(struct replay *r) {
    const int32_t arm_um = (int32_t)lround(r->arm_mm * 1000.0);
    if (replay_mode_choose(&r->distance, &r->reader, r->args->trace_path, r->args->distance_mode,
                           r->period_ms) != 0) {
        return -1;
    }
    if (tof_app_config_for_replay(&r->app_cfg, arm_um, r->period_ms, (uint16_t)r->args->window,
                                  r->args->sliding, r->distance.mode) != HAL_OK) {
        const char *bad = tof_app_config_check(&r->app_cfg);
        char where[64] = ": period_ms (default: the trace has none)";
        if (trace_reader_timing(&r->reader)->period_from_meta) {
            snprintf(where, sizeof where, ":%lu", trace_reader_meta_line(&r->reader, "period_ms"));
        }
        fprintf(stderr,
                "host_sim replay: %s%s: no firmware configuration fits period_ms %u and arm_mm "
                "%.3f in %s mode (%s; the shortest period is a %u ms budget + %u ms margin)\n",
                r->args->trace_path, where, r->period_ms, r->arm_mm,
                vl53_distance_mode_name(r->distance.mode),
                bad != NULL ? bad : "no VL53L1X timing budget fits the period",
                (unsigned)vl53_shortest_budget_ms(r->distance.mode), VL53_IMP_MARGIN_MS);
        return -1;
    }
    r->app_cfg.i2c_khz = (uint16_t)(r->args->i2c_khz != 0u ? r->args->i2c_khz : 400u);
    if (!tof_app_bus_fits(r->period_ms, r->app_cfg.i2c_khz)) {
        uint32_t shortest = r->period_ms;
        while (shortest < 10000u && !tof_app_bus_fits(shortest, r->app_cfg.i2c_khz)) {
            ++shortest;
        }
        fprintf(stderr,
                "host_sim replay: %s: period_ms %u at --i2c-khz %u: a sample's four readings take "
                "%u us on the bus, and with their %u us of slack that is not under half the "
                "period; the unit refuses it (at %u kHz the shortest period is %u ms)\n",
                r->args->trace_path, r->period_ms, (unsigned)r->app_cfg.i2c_khz,
                (unsigned)tof_app_sample_bus_us(r->app_cfg.i2c_khz), TOF_SKEW_SLACK_US,
                (unsigned)r->app_cfg.i2c_khz, (unsigned)shortest);
        return -1;
    }
    /* the timing again at this bus clock: the skew window covers the slower readings */
    (void)tof_app_config_period(&r->app_cfg, r->period_ms);
    if (r->args->offset_walk_given) {
        r->app_cfg.estimator.offset_walk_um2_h = r->args->offset_walk_um2_h;
    }
    /* The plate's rate bound: the option, else the trace's key, else the unit's default. */
    if (r->args->max_rate_given) {
        r->app_cfg.estimator.max_rate_mdeg_s = r->args->max_rate_mdeg_s;
    } else if (trace_reader_meta(&r->reader, "max_rate_deg_s") != NULL) {
        const char *v = trace_reader_meta(&r->reader, "max_rate_deg_s");
        if (!cli_parse_rate_mdeg_s(v, &r->app_cfg.estimator.max_rate_mdeg_s)) {
            fprintf(stderr,
                    "host_sim replay: %s:%lu: max_rate_deg_s must be the plate's rate bound in "
                    "°/s, 0..360 with at most 3 decimals, got '%s'\n",
                    r->args->trace_path, trace_reader_meta_line(&r->reader, "max_rate_deg_s"), v);
            return -1;
        }
    }
    if (r->args->process_noise_given &&
        tof_app_config_process_noise(&r->app_cfg, r->args->process_noise_um2_per_s[0],
                                     r->args->process_noise_um2_per_s[1],
                                     r->args->process_noise_auto) != HAL_OK) {
        fprintf(stderr,
                "host_sim replay: --process-noise: %u,%u µm²/s do not give a Q per row in "
                "(0, 4294 mm²] at period_ms %u of %s\n",
                r->args->process_noise_um2_per_s[0], r->args->process_noise_um2_per_s[1],
                r->period_ms, r->args->trace_path);
        return -1;
    }
    /* The simulated head is the one the HEAD.cal names; its mode and budget are the file's
     * to state, and the boot refuses them as the flight unit would. */
    r->app_cfg.head_id = r->cal.made_in.has_head ? r->cal.made_in.head_id : 0u;
    if (cal_apply_preload(&r->cal.cal, &r->app_cfg, &r->cal.made_in, NULL, &r->flash,
                          &r->records) != 0) {
        return -1;
    }
    return configure_world(r);
}

static int open_outputs(struct replay *r) {
    if (r->args->i2c_log_path != NULL &&
        i2c_log_open(&r->i2c_log, r->args->i2c_log_path, &r->sim.rig.bus) != 0) {
        return -1;
    }
    if (r->args->out_path != NULL) {
        r->est_out = fopen(r->args->out_path, "w");
        if (r->est_out == NULL || fputs(TOF_EST_CSV_HEADER, r->est_out) == EOF) {
            fprintf(stderr, "host_sim replay: %s: %s\n", r->args->out_path, strerror(errno));
            return -1;
        }
    }
    if (r->args->plot_path != NULL && replay_plot_open(&r->plot, r->args->plot_path) != 0) {
        return -1;
    }
    return 0;
}

/* --faults-until: stop injecting at that row, then time the return to four healthy
 * sensors (the recovery goal). */
static void track_fault_stop(struct replay *r) {
    if (r->args->faults_until_row == 0u) {
        return;
    }
    if (!r->faults_stopped && r->samples_done >= r->args->faults_until_row) {
        const struct sim_fault_config none = {0};
        sim_i2c_set_faults(&r->sim.rig.bus, &none);
        r->faults_stopped = true;
        r->faults_stop_us = sim_clock_now(&r->sim.rig.clock);
    }
    if (r->faults_stopped && r->recovery_us < 0) {
        bool all = true;
        for (unsigned i = 0; i < 4; ++i) {
            all = all && r->app.health[i].state == TOF_HEALTH_HEALTHY;
        }
        if (all) {
            r->recovery_us = (int64_t)(sim_clock_now(&r->sim.rig.clock) - r->faults_stop_us);
        }
    }
}

/* Run the firmware until every trace row has become a sample (or the source failed). */
static int run(struct replay *r) {
    if (tof_app_init(&r->app, &r->platform, &r->app_cfg) != HAL_OK) {
        fprintf(stderr, "host_sim replay: firmware init failed\n");
        return -1;
    }
    /* The boot reads the calibration from the record storage, as on the flight unit. */
    r->cal_state = (int)tof_cal_boot(&r->records, &r->app);
    if (r->cal.cal.calibrated &&
        (r->cal_state == TOF_CAL_OTHER_MODE || r->cal_state == TOF_CAL_OTHER_HEAD ||
         r->cal_state == TOF_CAL_OTHER_PARTS || r->cal_state == TOF_CAL_OTHER_BUDGET ||
         r->cal_state == TOF_CAL_OTHER_ARM)) {
        if (r->cal_state == TOF_CAL_OTHER_ARM) {
            fprintf(stderr,
                    "host_sim replay: warning: %s was made at another arm (its arm_mm key) than "
                    "this replay's %.3f mm: not applied, as the flight unit would refuse it "
                    "(other-arm); the head is uncalibrated\n",
                    r->cal.source, r->app_cfg.estimator.arm_um / 1000.0);
        } else if (r->cal_state == TOF_CAL_OTHER_PARTS) {
            fprintf(stderr,
                    "host_sim replay: warning: %s was made with other parts (its part_id_A..D "
                    "keys) than the simulated head's: not applied, as the flight unit would "
                    "refuse it; the head is uncalibrated\n",
                    r->cal.source);
        } else {
            fprintf(stderr,
                    "host_sim replay: warning: %s was made in another distance mode or timing "
                    "budget than this replay's (%s, %u ms): not applied, as the flight unit "
                    "would refuse it; the head is uncalibrated\n",
                    r->cal.source, vl53_distance_mode_name(r->app_cfg.timing.mode),
                    (unsigned)r->app_cfg.timing.budget_ms);
        }
    } else if (r->cal_state != (r->cal.cal.calibrated ? TOF_CAL_APPLIED : TOF_CAL_NONE)) {
        fprintf(stderr,
                "host_sim replay: internal: the firmware's boot found calibration state %d\n",
                r->cal_state);
        return -1;
    }
    if (r->app.estimator.cfg.calibration.thermal && r->platform.temp.ops == NULL) {
        /* the estimator's fall-back (docs/explanation/uncertainty.md "Temperature"), said */
        fprintf(stderr,
                "host_sim replay: note: %s has temperature coefficients but %s has no temp_c "
                "column: the offsets are held at their calibration temperature (%.2f C) and the "
                "sd's drift prior grows with time alone\n",
                r->cal.source, r->args->trace_path,
                r->app.estimator.cfg.calibration.cal_temp_cdeg / 100.0);
    }
    sim_replay_set_origin(&r->sim, r->app.assembler.origin_us);
    for (unsigned k = 0; k < r->args->command_count; ++k) {
        (void)replay_commands_add(&r->commands, r->args->commands[k]); /* checked by the cli */
    }
    replay_commands_start(&r->commands, &r->app, &r->records, r->cal_state, &r->sim.rig.clock,
                          r->app.assembler.origin_us, r->app.assembler_cfg.period_us);
    r->recovery_us = -1;
    for (;;) {
        /* The flight image's loop (tof_app_main): the work, the link's poll, then the sleep, so
         * a command is taken at the instant the firmware takes it. */
        tof_app_step(&r->app, false);
        replay_commands_poll(&r->commands);
        tof_app_idle(&r->app);
        if (r->app.assembler_cfg.period_us != r->period_ms * 1000u) {
            fprintf(stderr,
                    "host_sim replay: --command set-period: the firmware now samples every %u ms, "
                    "the trace's rows are %u ms apart (%s): replay a trace recorded at that "
                    "period instead\n",
                    r->app.assembler_cfg.period_us / 1000u, r->period_ms, r->args->trace_path);
            return -1;
        }
        if (!r->app.raw_output) {
            /* `raw off` by --command: the samples no longer reach on_sample (nor the
             * statistics); count those the firmware has processed. */
            const uint64_t done = r->app.counters.samples - r->app.deferred_count;
            r->samples_done = done > r->samples_done ? done : r->samples_done;
        }
        track_fault_stop(r);
        if (r->stream.end < 0) {
            /* The reader's message names file, line and column; the stream's says where
             * the replay was. */
            const char *why = trace_reader_error(&r->reader);
            fprintf(stderr, "host_sim replay: %s\n",
                    why != NULL && why[0] != '\0' ? why : scene_row_stream_error(&r->stream));
            return -1;
        }
        if (r->failed) {
            return -1;
        }
        if (r->stream.end == 1 && r->samples_done >= r->stream.next_index) {
            if (r->stream.next_index == 0u) {
                fprintf(stderr, "host_sim replay: %s: no samples after the header\n",
                        r->args->trace_path);
                return -1;
            }
            return 0; /* every row of the trace went through the firmware */
        }
        if (!sim_replay_progressing(&r->sim, r->samples_done)) {
            fprintf(stderr,
                    "host_sim replay: firmware stalled: no sample for %u s of simulated "
                    "time at row %llu\n",
                    SIM_REPLAY_STALL_US / 1000000u, (unsigned long long)r->samples_done);
            return -1;
        }
    }
}

static void fill_result(const struct replay *r, struct replay_result *out) {
    memset(out, 0, sizeof *out);
    out->rows = r->stream.next_index;
    out->estimates = r->stats.estimates;
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        memcpy(out->status_count[e], r->stats.est[e].status_count, sizeof out->status_count[e]);
        out->unflagged_wrong[e] = r->stats.unflagged_wrong[e];
        out->rms_alpha_deg[e] = replay_rms(r->stats.est[e].sum2_alpha, r->stats.est[e].n_alpha);
    }
    out->crb_alpha_deg = replay_rms(r->stats.crb_sum2_alpha, r->stats.crb_windows);
    out->overruns = r->app.counters.overruns;
    out->max_iteration_us = r->app.counters.max_iteration_us;
    out->reinits = r->app.counters.reinits_ok + r->app.counters.reinits_failed;
    out->bus_recoveries = r->app.counters.bus_recoveries;
    out->faults_stopped = r->faults_stopped;
    out->recovery_us = r->recovery_us;
}

int replay_run(const struct replay_args *args) {
    struct replay_result result;
    return replay_execute(args, &result) == 0 ? 0 : 1;
}

/* Closes the outputs the run wrote to and the trace. 0, or -1 (said on stderr). */
static int close_run(struct replay *r, int rc) {
    if (r->est_out != NULL && fclose(r->est_out) != 0 && rc == 0) {
        fprintf(stderr, "host_sim replay: %s: write failed\n", r->args->out_path);
        rc = -1;
    }
    if (i2c_log_close(&r->i2c_log, &r->sim.rig.bus) != 0 && rc == 0) {
        rc = -1;
    }
    if (r->reader.file != NULL) {
        fclose(r->reader.file);
    }
    return rc;
}

int replay_execute(const struct replay_args *args, struct replay_result *result) {
    memset(&R, 0, sizeof R);
    R.args = args;
    int rc = open_inputs(&R);
    if (rc == 0) {
        rc = configure(&R);
    }
    if (rc == 0) {
        rc = open_outputs(&R);
    }
    if (rc == 0) {
        rc = run(&R);
    }
    if (rc == 0) {
        rc = replay_report_shape(&R);
    }
    rc = close_run(&R, rc);
    if (rc == 0 && args->report_path != NULL) {
        rc = replay_report_write(&R, args->report_path);
    }
    if (rc == 0 && !args->quiet) {
        replay_report_summary(&R);
    }
    if (R.plot.data != NULL) {
        if (rc == 0) {
            rc = replay_plot_render(&R.plot, args->plot_path, args->trace_path);
        } else {
            replay_plot_discard(&R.plot);
        }
    }
    fill_result(&R, result);
    return rc == 0 ? 0 : -1;
}
