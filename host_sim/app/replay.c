#include "replay.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "estimator/attitude.h"
#include "firmware/app.h"
#include "firmware/est_csv.h"
#include "hal/hal_err.h"
#include "scene/crb.h"
#include "scene/row_source.h"
#include "scene/trace.h"
#include "sim/sim_fault.h"
#include "sim/sim_replay.h"
#include "vl53/vl53.h"
#include "i2c_log.h"

/* "No value" in tables and JSON (printed as nan / null). */
#define NO_VALUE ((double)NAN)

#ifndef TOF_SOURCE_DIR
#error "TOF_SOURCE_DIR must name the repository (for tools/plot_replay.py)"
#endif

/* ---- per-estimator error statistics ---- */

struct err_stats {
    uint64_t n_alpha, n_beta;
    double sum2_alpha, sum_abs_alpha, max_alpha;
    double sum2_beta, sum_abs_beta, max_beta;
    uint32_t status_count[3]; /* ok, degraded, invalid */
};

static void err_add(double err, uint64_t *n, double *sum2, double *sum_abs, double *max) {
    ++*n;
    *sum2 += err * err;
    *sum_abs += fabs(err);
    if (fabs(err) > *max) {
        *max = fabs(err);
    }
}

static double rms(double sum2, uint64_t n) {
    return n > 0u ? sqrt(sum2 / (double)n) : NO_VALUE;
}

/* Calibration of one estimator's sd on one axis against the truth (issue 15): answered
 * rows with truth, those within 3 sd and beyond 6 sd, and Σerr², Σsd². */
struct calib_axis {
    uint64_t n, within3, beyond6;
    double sum2_err, sum2_sd;
};

/* Bits of the why set that are counted in the report: the per-sensor and window ones
 * (0..22) and the reason bits (32..63). */
#define WHY_BITS 64u

static void calib_add(struct calib_axis *c, double err, double sd) {
    ++c->n;
    c->within3 += fabs(err) <= 3.0 * sd;
    c->beyond6 += fabs(err) > 6.0 * sd;
    c->sum2_err += err * err;
    c->sum2_sd += sd * sd;
}

static double share(uint64_t k, uint64_t n) {
    return n > 0u ? (double)k / (double)n : NO_VALUE;
}

static double calib_ratio(const struct calib_axis *c) {
    return c->n > 0u && c->sum2_sd > 0.0 ? sqrt(c->sum2_err / c->sum2_sd) : NO_VALUE;
}

/* Per-sensor sums over a window's valid readings, for its Cramér-Rao bound. */
struct window_truth {
    uint32_t n[4];
    double sum[4], sum2[4];
};

/* The replay's state (static: the trace reader alone is ~66 KB). */
struct replay {
    const struct replay_args *args;
    struct trace_reader reader;
    struct scene_row_stream stream;
    double arm_mm;
    uint32_t period_ms;
    struct sim_fault_config faults;
    struct sim_replay sim;
    struct tof_app_config app_cfg;
    struct tof_platform platform;
    struct tof_app app;
    enum attitude_estimator primary;
    FILE *est_out;
    struct i2c_log_file i2c_log;
    FILE *plot_data;
    char plot_data_path[4096];
    struct err_stats stats[ATTITUDE_EST_COUNT];
    uint64_t estimates;
    uint64_t samples_done;
    bool truth_seen;
    struct window_truth win;
    double crb_sum2_alpha, crb_sum2_beta;
    uint64_t crb_windows;
    double last_crb_alpha, last_crb_beta; /* bound of the window just closed (NaN: none) */
    uint32_t unflagged_wrong[ATTITUDE_EST_COUNT];
    struct calib_axis calib[ATTITUDE_EST_COUNT][2]; /* α, β */
    uint32_t why_count[ATTITUDE_EST_COUNT][WHY_BITS];
    bool faults_stopped;
    uint64_t faults_stop_us;
    int64_t recovery_us;
    uint32_t health_events, reinit_events, bus_recovery_events, overrun_events;
    int failed;            /* an output or data error: stop and report */
    uint64_t partial_rows; /* tumbling: rows after the last whole window (no estimate) */
    char time_base[96];
    enum vl53_distance_mode distance_mode; /* the simulated parts' (choose_distance_mode) */
    char distance_source[200];             /* why that mode, for the summary and the report */
};

static struct replay R;

static void write_plot_row(struct replay *r, const struct scene_row *row,
                           const struct attitude_output *out) {
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct attitude_estimate *est = &out->est[e];
        if (est->reason == ATTITUDE_REASON_DISABLED) {
            continue;
        }
        fprintf(r->plot_data, "%u,%s,", row->t_ms,
                attitude_estimator_name((enum attitude_estimator)e));
        if (est->alpha_valid) {
            fprintf(r->plot_data, "%.6f", est->alpha_udeg / 1e6);
        }
        fputc(',', r->plot_data);
        if (est->beta_valid) {
            fprintf(r->plot_data, "%.6f", est->beta_udeg / 1e6);
        }
        fprintf(r->plot_data, ",%.3f,%s,", est->distance_um / 1e3,
                attitude_status_name(est->status));
        if (row->has_alpha) {
            fprintf(r->plot_data, "%.6f", row->alpha_deg);
        }
        fputc(',', r->plot_data);
        if (row->has_beta) {
            fprintf(r->plot_data, "%.6f", row->beta_deg);
        }
        fputc(',', r->plot_data);
        if (est->alpha_valid) {
            fprintf(r->plot_data, "%.6f", est->alpha_sd_udeg / 1e6);
        }
        fputc(',', r->plot_data);
        if (est->beta_valid) {
            fprintf(r->plot_data, "%.6f", est->beta_sd_udeg / 1e6);
        }
        fputc('\n', r->plot_data);
    }
}

static void window_truth_add(struct replay *r, const struct scene_row *row) {
    for (unsigned k = 0; k < 4; ++k) {
        if (scene_row_valid(row, k)) {
            ++r->win.n[k];
            r->win.sum[k] += row->range_mm[k];
            r->win.sum2[k] += (double)row->range_mm[k] * row->range_mm[k];
        }
    }
}

/* The bound of the window just finished: per-sensor σ from the window's own readings
 * (the plate is static within a window in the protocols this serves), floored at the
 * 1 mm quantisation noise, 1/12 mm². */
static void window_truth_close(struct replay *r, const struct scene_row *last) {
    double sigma[4];
    for (unsigned k = 0; k < 4; ++k) {
        const double n = r->win.n[k];
        double var = 0.0;
        if (n >= 2.0) {
            var = (r->win.sum2[k] - r->win.sum[k] * r->win.sum[k] / n) / (n - 1.0);
        }
        sigma[k] = sqrt(var > 1.0 / 12.0 ? var : 1.0 / 12.0);
    }
    struct scene_crb crb;
    r->last_crb_alpha = NO_VALUE;
    r->last_crb_beta = NO_VALUE;
    if (last->has_alpha && last->has_beta &&
        scene_crb(r->arm_mm, sigma, r->win.n, last->alpha_deg, last->beta_deg, &crb) == 0) {
        r->crb_sum2_alpha += crb.sd_alpha_deg * crb.sd_alpha_deg;
        r->crb_sum2_beta += crb.sd_beta_deg * crb.sd_beta_deg;
        ++r->crb_windows;
        r->last_crb_alpha = crb.sd_alpha_deg;
        r->last_crb_beta = crb.sd_beta_deg;
    }
    memset(&r->win, 0, sizeof r->win);
}

static void on_estimate(void *ctx, const struct tof_estimate_record *record) {
    struct replay *r = ctx;
    const struct attitude_output *out = &record->output;
    int rc = 0;
    const struct scene_row *row = scene_row_stream_get(&r->stream, out->last_row, &rc);
    if (row == NULL) {
        fprintf(stderr, "host_sim replay: internal: trace row %u no longer available\n",
                out->last_row);
        r->failed = 1;
        return;
    }
    ++r->estimates;
    if (r->est_out != NULL) {
        char line[TOF_EST_CSV_ROW_MAX];
        struct tof_text t;
        tof_text_init(&t, line, sizeof line);
        tof_est_csv_row(&t, row->t_ms, &out->est[r->primary]);
        if (t.overflow || fputs(line, r->est_out) == EOF) {
            r->failed = 1;
        }
    }
    if (r->plot_data != NULL) {
        write_plot_row(r, row, out);
    }
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct attitude_estimate *est = &out->est[e];
        struct err_stats *s = &r->stats[e];
        if (est->reason == ATTITUDE_REASON_DISABLED) {
            continue;
        }
        ++s->status_count[est->status <= ATTITUDE_INVALID ? est->status : ATTITUDE_INVALID];
        /* An ok estimate more than 5x its window's bound from the truth went unflagged. */
        if (est->status == ATTITUDE_OK && !r->args->sliding &&
            ((row->has_alpha && est->alpha_valid &&
              fabs(est->alpha_udeg / 1e6 - row->alpha_deg) > 5.0 * r->last_crb_alpha) ||
             (row->has_beta && est->beta_valid &&
              fabs(est->beta_udeg / 1e6 - row->beta_deg) > 5.0 * r->last_crb_beta))) {
            ++r->unflagged_wrong[e];
        }
        for (unsigned b = 0; b < WHY_BITS; ++b) {
            r->why_count[e][b] += (uint32_t)((est->why >> b) & 1u);
        }
        if (est->status != ATTITUDE_INVALID && row->has_alpha && est->alpha_valid) {
            calib_add(&r->calib[e][0], est->alpha_udeg / 1e6 - row->alpha_deg,
                      est->alpha_sd_udeg / 1e6);
        }
        if (est->status != ATTITUDE_INVALID && row->has_beta && est->beta_valid) {
            calib_add(&r->calib[e][1], est->beta_udeg / 1e6 - row->beta_deg,
                      est->beta_sd_udeg / 1e6);
        }
        if (row->has_alpha && est->alpha_valid) {
            err_add(est->alpha_udeg / 1e6 - row->alpha_deg, &s->n_alpha, &s->sum2_alpha,
                    &s->sum_abs_alpha, &s->max_alpha);
        }
        if (row->has_beta && est->beta_valid) {
            err_add(est->beta_udeg / 1e6 - row->beta_deg, &s->n_beta, &s->sum2_beta,
                    &s->sum_abs_beta, &s->max_beta);
        }
    }
}

static void on_sample(void *ctx, const struct tof_sample *sample) {
    struct replay *r = ctx;
    int rc = 0;
    r->samples_done = (uint64_t)sample->index + 1u;
    const struct scene_row *row = scene_row_stream_get(&r->stream, sample->index, &rc);
    if (row == NULL) {
        if (rc < 0) {
            r->failed = 1; /* the stream's own message is printed by run() */
        }
        return; /* past the end of the trace: nothing to account */
    }
    r->truth_seen = r->truth_seen || row->has_alpha || row->has_beta;
    window_truth_add(r, row);
    if (!r->args->sliding && (sample->index + 1u) % r->app_cfg.estimator.window == 0u) {
        window_truth_close(r, row);
    }
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
    return 0;
}

/* The readings of the trace in (1,360, 4,000] mm: what short mode cannot report as valid
 * and long mode can. A second pass of the reader over the file; *first_line and
 * *first_sensor of the first such reading. -1 when the file is not a regular one (a pipe
 * cannot be read twice) or does not parse to its end (the replay's own pass reports
 * that), else the count. */
static int64_t long_range_readings(const char *path, unsigned long *first_line,
                                   unsigned *first_sensor) {
    static struct trace_reader scan; /* static: the reader holds its block buffer */
    struct stat sb;
    if (stat(path, &sb) != 0 || !S_ISREG(sb.st_mode)) {
        return -1;
    }
    FILE *f = fopen(path, "rb");
    if (f == NULL || trace_reader_open(&scan, f, path) != 0) {
        if (f != NULL) {
            fclose(f);
        }
        return -1;
    }
    int64_t count = 0;
    struct scene_row row;
    int rc = 0;
    while ((rc = trace_reader_next(&scan, &row)) == 0) {
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            const uint16_t mm = row.range_mm[k];
            if (row.present[k] && mm > VL53_RANGE_MAX_SHORT_MM && mm <= VL53_RANGE_MAX_LONG_MM) {
                if (count++ == 0) {
                    *first_line = scan.last_row_line;
                    *first_sensor = k;
                }
            }
        }
    }
    fclose(f);
    return rc == 1 ? count : -1;
}

/* The simulated parts' distance mode: --distance-mode, else the trace's distance_mode
 * (checked either way), else long when the trace holds readings only long mode reports (a
 * VL53L1X logging in its default mode, to 4 m) and the period admits a long-mode budget,
 * else short (the firmware's own mode, docs/driver.md). Said on stderr when chosen from
 * the readings, or when they could not be read ahead. */
static int choose_distance_mode(struct replay *r) {
    const char *path = r->args->trace_path;
    const char *stated = trace_reader_meta(&r->reader, "distance_mode");
    const unsigned long meta_line = trace_reader_meta_line(&r->reader, "distance_mode");
    enum vl53_distance_mode stated_mode = VL53_DISTANCE_SHORT;
    if (stated != NULL && !vl53_distance_mode_from_name(stated, &stated_mode)) {
        fprintf(stderr, "host_sim replay: %s:%lu: distance_mode must be short or long, got '%s'\n",
                path, meta_line, stated);
        return -1;
    }
    r->distance_mode = VL53_DISTANCE_SHORT;
    if (r->args->distance_mode != 0u) {
        r->distance_mode = (enum vl53_distance_mode)r->args->distance_mode;
        snprintf(r->distance_source, sizeof r->distance_source, "--distance-mode");
        return 0;
    }
    if (stated != NULL) {
        r->distance_mode = stated_mode;
        snprintf(r->distance_source, sizeof r->distance_source, "the trace (line %lu)", meta_line);
        return 0;
    }
    unsigned long line = 0;
    unsigned sensor = 0;
    const int64_t beyond = long_range_readings(path, &line, &sensor);
    if (beyond < 0) {
        snprintf(r->distance_source, sizeof r->distance_source,
                 "default: the readings could not be read ahead");
        fprintf(stderr,
                "host_sim replay: note: %s: not a regular file that parses to its end, so its "
                "readings were not read ahead for the distance mode: short (to %u mm) unless "
                "'# distance_mode=' or --distance-mode says otherwise\n",
                path, VL53_RANGE_MAX_SHORT_MM);
        return 0;
    }
    if (beyond == 0) {
        snprintf(r->distance_source, sizeof r->distance_source,
                 "default: no reading in (%u, %u] mm", VL53_RANGE_MAX_SHORT_MM,
                 VL53_RANGE_MAX_LONG_MM);
        return 0;
    }
    const char name = (char)('A' + sensor);
    if (tof_app_replay_mode_fits(r->period_ms, VL53_DISTANCE_LONG)) {
        r->distance_mode = VL53_DISTANCE_LONG;
        snprintf(r->distance_source, sizeof r->distance_source,
                 "%lld readings above short mode's %u mm, the first at line %lu (sensor %c)",
                 (long long)beyond, VL53_RANGE_MAX_SHORT_MM, line, name);
        fprintf(stderr,
                "host_sim replay: note: %s: distance mode long (to %u mm): %s; state it with "
                "'# distance_mode=long' or --distance-mode\n",
                path, VL53_RANGE_MAX_LONG_MM, r->distance_source);
    } else {
        snprintf(r->distance_source, sizeof r->distance_source,
                 "default: long mode has no budget for period_ms %u", r->period_ms);
        fprintf(stderr,
                "host_sim replay: warning: %s: %lld readings above short mode's %u mm (the first "
                "at line %lu, sensor %c) are flagged: long mode, which reports them, has no "
                "budget for period_ms %u (at least %u ms)\n",
                path, (long long)beyond, VL53_RANGE_MAX_SHORT_MM, line, name, r->period_ms,
                vl53_shortest_budget_ms(VL53_DISTANCE_LONG) + VL53_IMP_MARGIN_MS);
    }
    return 0;
}

static int configure(struct replay *r) {
    const int32_t arm_um = (int32_t)lround(r->arm_mm * 1000.0);
    if (choose_distance_mode(r) != 0) {
        return -1;
    }
    if (tof_app_config_for_replay(&r->app_cfg, arm_um, r->period_ms, (uint16_t)r->args->window,
                                  r->args->sliding, r->distance_mode) != HAL_OK) {
        const char *bad = tof_app_config_check(&r->app_cfg);
        char where[64] = ": period_ms (default: the trace has none)";
        if (r->reader.timing.period_from_meta) {
            snprintf(where, sizeof where, ":%lu", trace_reader_meta_line(&r->reader, "period_ms"));
        }
        fprintf(stderr,
                "host_sim replay: %s%s: no firmware configuration fits period_ms %u and arm_mm "
                "%.3f in %s mode (%s; the shortest period is a %u ms budget + %u ms margin)\n",
                r->args->trace_path, where, r->period_ms, r->arm_mm,
                vl53_distance_mode_name(r->distance_mode),
                bad != NULL ? bad : "no VL53L1X timing budget fits the period",
                (unsigned)vl53_shortest_budget_ms(r->distance_mode), VL53_IMP_MARGIN_MS);
        return -1;
    }
    if (tof_app_config_process_noise(&r->app_cfg, r->args->process_noise_um2_per_s[0],
                                     r->args->process_noise_um2_per_s[1],
                                     r->args->process_noise_auto) != HAL_OK) {
        fprintf(stderr,
                "host_sim replay: --process-noise: %u,%u µm²/s do not give a Q per row in "
                "(0, 4294 mm²] at period_ms %u of %s\n",
                r->args->process_noise_um2_per_s[0], r->args->process_noise_um2_per_s[1],
                r->period_ms, r->args->trace_path);
        return -1;
    }
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
    r->platform = (struct tof_platform){
        .board_name = "host_sim",
        .i2c = r->sim.rig.i2c,
        .gpio = r->sim.rig.hal_gpio,
        .time = r->sim.rig.time,
        .output = {.ops = &replay_output_ops, .ctx = r},
        .sensor_pads_at_avdd = true, /* as the NUCLEO boards it simulates */
    };
    for (unsigned i = 0; i < 4; ++i) {
        r->platform.xshut_pin[i] = SIM_RIG_XSHUT_PIN(i);
        r->platform.gpio1_pin[i] = SIM_RIG_GPIO1_PIN(i);
    }
    return 0;
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
    if (r->args->plot_path != NULL) {
        snprintf(r->plot_data_path, sizeof r->plot_data_path, "%s.data.csv", r->args->plot_path);
        r->plot_data = fopen(r->plot_data_path, "w");
        if (r->plot_data == NULL) {
            fprintf(stderr, "host_sim replay: %s: %s\n", r->plot_data_path, strerror(errno));
            return -1;
        }
        fputs("t_ms,estimator,alpha_deg,beta_deg,distance_mm,status,true_alpha_deg,"
              "true_beta_deg,alpha_sd_deg,beta_sd_deg\n",
              r->plot_data);
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

/* The time base in words: where the period the replay runs at came from. */
static const char *time_base(struct replay *r) {
    if (r->reader.timing.period_from_meta) {
        snprintf(r->time_base, sizeof r->time_base, "period_ms %u from the trace (line %lu)",
                 r->period_ms, trace_reader_meta_line(&r->reader, "period_ms"));
    } else {
        snprintf(r->time_base, sizeof r->time_base,
                 "period_ms %u, the default (the trace has no period_ms)", r->period_ms);
    }
    return r->time_base;
}

/* Run the firmware until every trace row has become a sample (or the source failed). */
static int run(struct replay *r) {
    if (tof_app_init(&r->app, &r->platform, &r->app_cfg) != HAL_OK) {
        fprintf(stderr, "host_sim replay: firmware init failed\n");
        return -1;
    }
    sim_replay_set_origin(&r->sim, r->app.assembler.origin_us);
    r->recovery_us = -1;
    for (;;) {
        tof_app_step(&r->app, true);
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

/*
 * What the trace's length and time stamps mean for the windows (DESIGN.md §6: windows
 * are counted in rows, t_ms labels them): a trace shorter than one window is an error;
 * a trailing partial window and irregular time stamps are warnings on stderr (and in
 * the report). Returns 0 or -1.
 */
static int check_trace_shape(struct replay *r) {
    const uint64_t rows = r->stream.next_index;
    const unsigned n = r->args->window;
    const char *path = r->args->trace_path;
    if (rows < n) {
        fprintf(stderr,
                "host_sim replay: %s: %llu rows, fewer than one window of %u rows (--window): "
                "no estimate possible\n",
                path, (unsigned long long)rows, n);
        return -1;
    }
    r->partial_rows = r->args->sliding ? 0u : rows % n;
    if (r->partial_rows > 0u) {
        fprintf(stderr,
                "host_sim replay: warning: %s: the last %llu rows (up to line %lu) are a partial "
                "window of %u and give no estimate\n",
                path, (unsigned long long)r->partial_rows, r->reader.last_row_line, n);
    }
    const struct trace_timing *tm = trace_reader_timing(&r->reader);
    for (unsigned i = 0; i < tm->note_count; ++i) {
        const struct trace_timing_note *note = &tm->notes[i];
        if (note->kind == TRACE_TIME_REPEAT) {
            fprintf(stderr,
                    "host_sim replay: warning: %s:%lu: t_ms %lu repeats the previous row's\n", path,
                    note->line, (unsigned long)note->t_ms);
        } else {
            fprintf(stderr,
                    "host_sim replay: warning: %s:%lu: t_ms %lu is %lu ms after the previous "
                    "row's %lu, more than two periods\n",
                    path, note->line, (unsigned long)note->t_ms,
                    (unsigned long)(note->t_ms - note->prev_t_ms), (unsigned long)note->prev_t_ms);
        }
    }
    const uint64_t irregular = tm->repeats + tm->jumps;
    if (irregular > 0u) {
        if (irregular > tm->note_count) {
            fprintf(stderr, "host_sim replay: warning: %s: %llu more irregular time stamps\n", path,
                    (unsigned long long)(irregular - tm->note_count));
        }
        fprintf(stderr,
                "host_sim replay: warning: %s: %llu repeated t_ms and %llu jumps of more than "
                "two periods (largest %lu ms, line %lu); time base: %s; windows are counted in "
                "rows, t_ms only labels them\n",
                path, (unsigned long long)tm->repeats, (unsigned long long)tm->jumps,
                (unsigned long)tm->max_jump_ms, tm->max_jump_line, time_base(r));
    }
    return 0;
}

static void json_number(FILE *f, double v) {
    if (isfinite(v)) {
        fprintf(f, "%.6g", v);
    } else {
        fputs("null", f);
    }
}

/* The estimator's reason counts and, with truth, its sd calibration per axis. */
static void write_calibration(FILE *f, const struct replay *r, unsigned e) {
    const struct err_stats *s = &r->stats[e];
    const uint64_t total = (uint64_t)s->status_count[0] + s->status_count[1] + s->status_count[2];
    fputs(", \"reasons\": {", f);
    bool first = true;
    for (unsigned b = 0; b < WHY_BITS; ++b) {
        char name[ATTITUDE_WHY_TEXT_MAX];
        if (r->why_count[e][b] != 0u &&
            attitude_why_format((attitude_why_t)1u << b, name, sizeof name) > 0) {
            fprintf(f, "%s\"%s\": %u", first ? "" : ", ", name, r->why_count[e][b]);
            first = false;
        }
    }
    fputs("}, \"answered\": ", f);
    json_number(f, share(s->status_count[0] + s->status_count[1], total));
    fputs(", \"calibration\": ", f);
    if (!r->truth_seen) {
        fputs("null", f);
        return;
    }
    fputc('{', f);
    for (unsigned ax = 0; ax < 2u; ++ax) {
        const struct calib_axis *c = &r->calib[e][ax];
        fprintf(f, "%s\"%s\": {\"rows\": %llu, \"within_3sd\": ", ax ? ", " : "",
                ax ? "beta" : "alpha", (unsigned long long)c->n);
        json_number(f, share(c->within3, c->n));
        fputs(", \"beyond_6sd\": ", f);
        json_number(f, share(c->beyond6, c->n));
        fputs(", \"rms_err_over_rms_sd\": ", f);
        json_number(f, calib_ratio(c));
        fputs(", \"rms_sd_deg\": ", f);
        json_number(f, c->n > 0u ? sqrt(c->sum2_sd / (double)c->n) : NO_VALUE);
        fputc('}', f);
    }
    fputc('}', f);
}

static int write_report(struct replay *r, const char *path) {
    FILE *f = fopen(path, "w");
    if (f == NULL) {
        fprintf(stderr, "host_sim replay: %s: %s\n", path, strerror(errno));
        return -1;
    }
    fprintf(f,
            "{\n  \"trace\": \"%s\",\n  \"rows\": %llu,\n  \"window\": %u,\n  \"mode\": \"%s\",\n",
            r->args->trace_path, (unsigned long long)r->stream.next_index, r->args->window,
            r->args->sliding ? "sliding" : "tumbling");
    fprintf(f, "  \"primary\": \"%s\",\n  \"estimates\": %llu,\n  \"truth\": %s,\n",
            r->args->estimator, (unsigned long long)r->estimates, r->truth_seen ? "true" : "false");
    const struct trace_timing *tm = trace_reader_timing(&r->reader);
    fprintf(f,
            "  \"time_base\": {\"period_ms\": %u, \"source\": \"%s\", \"t_ms_repeats\": %llu, "
            "\"t_ms_jumps\": %llu, \"max_jump_ms\": %lu, \"max_jump_line\": %lu},\n"
            "  \"partial_window_rows\": %llu,\n"
            "  \"distance_mode\": {\"mode\": \"%s\", \"range_max_mm\": %u, \"source\": \"%s\"},\n",
            r->period_ms, tm->period_from_meta ? "trace" : "default",
            (unsigned long long)tm->repeats, (unsigned long long)tm->jumps,
            (unsigned long)tm->max_jump_ms, tm->max_jump_line, (unsigned long long)r->partial_rows,
            vl53_distance_mode_name(r->distance_mode), vl53_range_max_mm(r->distance_mode),
            r->distance_source);
    fputs("  \"crb_alpha_deg\": ", f);
    json_number(f, rms(r->crb_sum2_alpha, r->crb_windows));
    fputs(",\n  \"crb_beta_deg\": ", f);
    json_number(f, rms(r->crb_sum2_beta, r->crb_windows));
    fputs(",\n  \"estimators\": {\n", f);
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct err_stats *s = &r->stats[e];
        fprintf(f,
                "    \"%s\": {\"ok\": %u, \"degraded\": %u, \"invalid\": %u, "
                "\"unflagged_wrong\": %u",
                attitude_estimator_name((enum attitude_estimator)e), s->status_count[0],
                s->status_count[1], s->status_count[2], r->unflagged_wrong[e]);
        static const char *const keys[6] = {"rms_alpha_deg", "mean_abs_alpha_deg", "max_alpha_deg",
                                            "rms_beta_deg",  "mean_abs_beta_deg",  "max_beta_deg"};
        const double vals[6] = {rms(s->sum2_alpha, s->n_alpha),
                                s->n_alpha ? s->sum_abs_alpha / (double)s->n_alpha : NO_VALUE,
                                s->n_alpha ? s->max_alpha : NO_VALUE,
                                rms(s->sum2_beta, s->n_beta),
                                s->n_beta ? s->sum_abs_beta / (double)s->n_beta : NO_VALUE,
                                s->n_beta ? s->max_beta : NO_VALUE};
        for (unsigned k = 0; k < 6; ++k) {
            fprintf(f, ", \"%s\": ", keys[k]);
            json_number(f, vals[k]);
        }
        write_calibration(f, r, e);
        fprintf(f, "}%s\n", e + 1u < ATTITUDE_EST_COUNT ? "," : "");
    }
    const struct sim_i2c_stats *b = &r->sim.rig.bus.stats;
    const double sim_s = (double)sim_clock_now(&r->sim.rig.clock) / 1e6;
    fprintf(f,
            "  },\n  \"bus\": {\"transactions\": %u, \"ok\": %u, \"tx_bytes\": %llu, "
            "\"rx_bytes\": %llu, \"utilization\": ",
            b->transactions, b->ok, (unsigned long long)b->tx_bytes,
            (unsigned long long)b->rx_bytes);
    json_number(f, sim_s > 0 ? (double)b->busy_ns / 1e9 / sim_s : NO_VALUE);
    fprintf(f, ", \"recoveries\": %u},\n", b->recoveries);
    const struct tof_app_counters *c = &r->app.counters;
    fprintf(f,
            "  \"firmware\": {\"iterations\": %u, \"samples\": %u, \"readings\": %u, "
            "\"reinits_ok\": %u, "
            "\"reinits_failed\": %u, \"bus_recoveries\": %u, \"overruns\": %u, "
            "\"max_iteration_us\": %u, \"late_readings\": %u, \"incomplete_samples\": %u, "
            "\"faults_stopped\": %s, \"recovery_us\": %lld},\n",
            c->iterations, c->samples, c->readings, c->reinits_ok, c->reinits_failed,
            c->bus_recoveries, c->overruns, c->max_iteration_us, r->app.assembler.counters.late,
            r->app.assembler.counters.incomplete, r->faults_stopped ? "true" : "false",
            (long long)r->recovery_us);
    fprintf(f,
            "  \"health_events\": {\"transitions\": %u, \"reinits\": %u, \"bus_recoveries\": %u, "
            "\"overruns\": %u},\n  \"sensors\": [",
            r->health_events, r->reinit_events, r->bus_recovery_events, r->overrun_events);
    for (unsigned i = 0; i < 4; ++i) {
        fprintf(f, "%s{\"name\": \"%c\", \"state\": \"%s\", \"losses\": %u, \"read_errors\": %u}",
                i ? ", " : "", 'A' + i, tof_health_name(r->app.health[i].state),
                r->app.health[i].losses, c->read_errors[i]);
    }
    fprintf(f, "]\n}\n");
    if (fclose(f) != 0) {
        fprintf(stderr, "host_sim replay: %s: write failed\n", path);
        return -1;
    }
    return 0;
}

static void print_summary(struct replay *r) {
    printf("replay %s: %llu rows, window %u (%s), %llu estimates, primary %s\n",
           r->args->trace_path, (unsigned long long)r->stream.next_index, r->args->window,
           r->args->sliding ? "sliding" : "tumbling", (unsigned long long)r->estimates,
           r->args->estimator);
    printf("time base: %s; windows counted in rows\n", time_base(r));
    printf("distance mode: %s (to %u mm; %s)\n", vl53_distance_mode_name(r->distance_mode),
           vl53_range_max_mm(r->distance_mode), r->distance_source);
    printf("%-16s %10s %10s %10s %10s %10s %10s %6s %6s %6s\n", "estimator", "rms_a[deg]",
           "mae_a[deg]", "max_a[deg]", "rms_b[deg]", "mae_b[deg]", "max_b[deg]", "ok", "degr",
           "inval");
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct err_stats *s = &r->stats[e];
        printf("%-16s %10.4f %10.4f %10.4f %10.4f %10.4f %10.4f %6u %6u %6u\n",
               attitude_estimator_name((enum attitude_estimator)e), rms(s->sum2_alpha, s->n_alpha),
               s->n_alpha ? s->sum_abs_alpha / (double)s->n_alpha : NO_VALUE,
               s->n_alpha ? s->max_alpha : NO_VALUE, rms(s->sum2_beta, s->n_beta),
               s->n_beta ? s->sum_abs_beta / (double)s->n_beta : NO_VALUE,
               s->n_beta ? s->max_beta : NO_VALUE, s->status_count[0], s->status_count[1],
               s->status_count[2]);
    }
    if (r->truth_seen) {
        printf("%-16s %10.4f %10s %10s %10.4f   (Cramer-Rao bound from each window's own sigma)\n",
               "bound", rms(r->crb_sum2_alpha, r->crb_windows), "", "",
               rms(r->crb_sum2_beta, r->crb_windows));
        printf("sd calibration (answered rows; goals: >= 95 %% within 3 sd, <= 0.1 %% beyond 6 sd, "
               "rms err / rms sd >= 0.5, >= 95 %% answered):\n");
        printf("%-16s %9s %9s %9s %9s %9s %9s %9s\n", "estimator", "answered", "a<=3sd", "a>6sd",
               "a_err/sd", "b<=3sd", "b>6sd", "b_err/sd");
        for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
            const struct err_stats *s = &r->stats[e];
            const struct calib_axis *a = &r->calib[e][0];
            const struct calib_axis *b = &r->calib[e][1];
            const uint64_t total =
                (uint64_t)s->status_count[0] + s->status_count[1] + s->status_count[2];
            printf("%-16s %8.1f%% %8.2f%% %8.2f%% %9.3f %8.2f%% %8.2f%% %9.3f\n",
                   attitude_estimator_name((enum attitude_estimator)e),
                   100.0 * share(s->status_count[0] + s->status_count[1], total),
                   100.0 * share(a->within3, a->n), 100.0 * share(a->beyond6, a->n), calib_ratio(a),
                   100.0 * share(b->within3, b->n), 100.0 * share(b->beyond6, b->n),
                   calib_ratio(b));
        }
    } else {
        printf("(no ground truth in this trace: errors and bound not available)\n");
    }
    printf("reasons (%s):", r->args->estimator);
    bool any = false;
    for (unsigned b = 0; b < WHY_BITS; ++b) {
        char name[ATTITUDE_WHY_TEXT_MAX];
        if (r->why_count[r->primary][b] != 0u &&
            attitude_why_format((attitude_why_t)1u << b, name, sizeof name) > 0) {
            printf(" %s %u", name, r->why_count[r->primary][b]);
            any = true;
        }
    }
    printf("%s\n", any ? "" : " none");
    const struct sim_i2c_stats *b = &r->sim.rig.bus.stats;
    printf("bus: %u transactions (%u ok), %u bus recoveries; firmware: %u reinits, %u overruns, "
           "max iteration %u us\n",
           b->transactions, b->ok, r->app.counters.bus_recoveries, r->app.counters.reinits_ok,
           r->app.counters.overruns, r->app.counters.max_iteration_us);
}

static int make_plot(struct replay *r) {
    if (fclose(r->plot_data) != 0) {
        r->plot_data = NULL;
        fprintf(stderr, "host_sim replay: %s: write failed\n", r->plot_data_path);
        return -1;
    }
    r->plot_data = NULL;
    if (strchr(r->plot_data_path, '\'') != NULL || strchr(r->args->trace_path, '\'') != NULL) {
        fprintf(stderr,
                "host_sim replay: --plot: paths with a quote character are not supported\n");
        return -1;
    }
    char cmd[12288];
    snprintf(cmd, sizeof cmd, "/usr/bin/python3 '%s/tools/plot_replay.py' '%s' '%s' --title '%s'",
             TOF_SOURCE_DIR, r->plot_data_path, r->args->plot_path, r->args->trace_path);
    const int rc = system(cmd);
    if (rc != 0) {
        fprintf(stderr,
                "host_sim replay: plotting failed (status %d); is python3-matplotlib installed? "
                "(tools/setup.sh)\n",
                rc);
        return -1;
    }
    remove(r->plot_data_path);
    return 0;
}

static void fill_result(const struct replay *r, struct replay_result *out) {
    memset(out, 0, sizeof *out);
    out->rows = r->stream.next_index;
    out->estimates = r->estimates;
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        memcpy(out->status_count[e], r->stats[e].status_count, sizeof out->status_count[e]);
        out->unflagged_wrong[e] = r->unflagged_wrong[e];
        out->rms_alpha_deg[e] = rms(r->stats[e].sum2_alpha, r->stats[e].n_alpha);
    }
    out->crb_alpha_deg = rms(r->crb_sum2_alpha, r->crb_windows);
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
        rc = check_trace_shape(&R);
    }
    if (R.est_out != NULL && fclose(R.est_out) != 0 && rc == 0) {
        fprintf(stderr, "host_sim replay: %s: write failed\n", args->out_path);
        rc = -1;
    }
    if (i2c_log_close(&R.i2c_log, &R.sim.rig.bus) != 0 && rc == 0) {
        rc = -1;
    }
    if (R.reader.file != NULL) {
        fclose(R.reader.file);
    }
    if (rc == 0 && args->report_path != NULL) {
        rc = write_report(&R, args->report_path);
    }
    if (rc == 0 && !args->quiet) {
        print_summary(&R);
    }
    if (R.plot_data != NULL) {
        if (rc == 0) {
            rc = make_plot(&R);
        } else {
            fclose(R.plot_data);
            remove(R.plot_data_path);
        }
    }
    fill_result(&R, result);
    return rc == 0 ? 0 : -1;
}
