/* host_sim replay's warnings, report JSON and summary table (replay_report.h). */
#include "replay_report.h"

#include <errno.h>
#include <string.h>
#include "firmware/calibration_record.h"

/* The time base in words: where the period the replay runs at came from. */
static const char *time_base(const struct replay *r, char *buf, size_t len) {
    if (trace_reader_timing(&r->reader)->period_from_meta) {
        snprintf(buf, len, "period_ms %u from the trace (line %lu)", r->period_ms,
                 trace_reader_meta_line(&r->reader, "period_ms"));
    } else {
        snprintf(buf, len, "period_ms %u, the default (the trace has no period_ms)", r->period_ms);
    }
    return buf;
}

/* Each irregular time stamp kept with its line, and their count. */
static void timing_warnings(const struct replay *r) {
    const char *path = r->args->trace_path;
    const struct trace_timing *tm = trace_reader_timing(&r->reader);
    for (unsigned i = 0; i < tm->note_count; ++i) {
        const struct trace_timing_note *note = &tm->notes[i];
        if (note->kind == TRACE_TIME_REPEAT) {
            fprintf(stderr,
                    "host_sim replay: warning: %s:%lu: t_ms %lu repeats the previous row's\n", path,
                    (unsigned long)note->line, (unsigned long)note->t_ms);
        } else {
            fprintf(stderr,
                    "host_sim replay: warning: %s:%lu: t_ms %lu is %lu ms after the previous "
                    "row's %lu, more than two periods\n",
                    path, (unsigned long)note->line, (unsigned long)note->t_ms,
                    (unsigned long)(note->t_ms - note->prev_t_ms), (unsigned long)note->prev_t_ms);
        }
    }
    const uint64_t irregular = tm->repeats + tm->jumps;
    if (irregular > 0u) {
        if (irregular > tm->note_count) {
            fprintf(stderr, "host_sim replay: warning: %s: %llu more irregular time stamps\n", path,
                    (unsigned long long)(irregular - tm->note_count));
        }
        char base[96];
        fprintf(stderr,
                "host_sim replay: warning: %s: %llu repeated t_ms and %llu jumps of more than "
                "two periods (largest %lu ms, line %lu); time base: %s; windows are counted in "
                "rows, t_ms only labels them\n",
                path, (unsigned long long)tm->repeats, (unsigned long long)tm->jumps,
                (unsigned long)tm->max_jump_ms, (unsigned long)tm->max_jump_line,
                time_base(r, base, sizeof base));
    }
}

int replay_report_shape(struct replay *r) {
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
    timing_warnings(r);
    return 0;
}

/* ---- the report ---- */

static void json_number(FILE *f, double v) {
    if (isfinite(v)) {
        fprintf(f, "%.6g", v);
    } else {
        fputs("null", f);
    }
}

/* The estimator's reason counts and, with truth, its sd calibration per axis. */
static void write_calibration(FILE *f, const struct replay *r, unsigned e) {
    const struct replay_stats *s = &r->stats;
    fputs(", \"reasons\": {", f);
    bool first = true;
    for (unsigned b = 0; b < WHY_BITS; ++b) {
        char name[ATTITUDE_WHY_TEXT_MAX];
        if (s->why_count[e][b] != 0u &&
            attitude_why_format((attitude_why_t)1u << b, name, sizeof name) > 0) {
            fprintf(f, "%s\"%s\": %u", first ? "" : ", ", name, s->why_count[e][b]);
            first = false;
        }
    }
    fputs("}, \"answered\": ", f);
    json_number(f, replay_answered(&s->est[e]));
    fputs(", \"calibration\": ", f);
    if (!s->truth_seen) {
        fputs("null", f);
        return;
    }
    fputc('{', f);
    for (unsigned ax = 0; ax < 2u; ++ax) {
        const struct calib_axis *c = &s->calib[e][ax];
        fprintf(f, "%s\"%s\": {\"rows\": %llu, \"within_3sd\": ", ax ? ", " : "",
                ax ? "beta" : "alpha", (unsigned long long)c->n);
        json_number(f, replay_share(c->within3, c->n));
        fputs(", \"beyond_6sd\": ", f);
        json_number(f, replay_share(c->beyond6, c->n));
        fputs(", \"rms_err_over_rms_sd\": ", f);
        json_number(f, replay_calib_ratio(c));
        fputs(", \"rms_sd_deg\": ", f);
        json_number(f, c->n > 0u ? sqrt(c->sum2_sd / (double)c->n) : NO_VALUE);
        fputc('}', f);
    }
    fputc('}', f);
}

/* The head's calibration as the firmware's boot put it into the estimator's configuration
 * (attitude_config.calibration), and where it came from. */
static void write_head_calibration(FILE *f, const struct replay *r) {
    static const char *const states[] = {"none",        "applied",      "corrupt",  "version",
                                         "other-head",  "other-mode",   "rejected", "no-storage",
                                         "other-parts", "other-budget", "other-arm"};
    const struct calibration_head *c = &r->app.estimator.cfg.calibration;
    fprintf(f, "  \"calibration\": {\"source\": \"%s\", \"state\": \"%s\", \"calibrated\": %s",
            r->cal.source,
            r->cal_state >= 0 && r->cal_state <= TOF_CAL_STATE_LAST ? states[r->cal_state] : "?",
            c->calibrated ? "true" : "false");
    const char *const names[5] = {"offset_um", "gain_ppm", "offset_sd_um", "gain_sd_ppm",
                                  "offset_gain_corr_q15"};
    for (unsigned k = 0; k < 5u && c->calibrated; ++k) {
        fprintf(f, ", \"%s\": [", names[k]);
        for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
            const long v = k == 0u   ? (long)c->offset_um[i]
                           : k == 1u ? (long)c->gain_ppm[i]
                           : k == 2u ? (long)c->offset_sd_um[i]
                           : k == 3u ? (long)c->gain_sd_ppm[i]
                                     : (long)c->offset_gain_corr_q15[i];
            fprintf(f, "%s%ld", i > 0u ? ", " : "", v);
        }
        fputc(']', f);
    }
    if (c->calibrated && c->thermal) {
        fprintf(f, ", \"cal_temp_c\": %.2f", c->cal_temp_cdeg / 100.0);
        for (unsigned k = 0; k < 2u; ++k) {
            fprintf(f, ", \"%s\": [", k == 0u ? "temp_coeff_nm_per_c" : "temp_coeff_sd_nm_per_c");
            for (unsigned i = 0; i < CALIBRATION_SENSORS; ++i) {
                fprintf(f, "%s%ld", i > 0u ? ", " : "",
                        k == 0u ? (long)c->temp_coeff_nm_per_c[i]
                                : (long)c->temp_coeff_sd_nm_per_c[i]);
            }
            fputc(']', f);
        }
    }
    fputs("},\n", f);
}

/* The trace, the windows, the time base and the distance mode. */
static void write_head(FILE *f, const struct replay *r) {
    fprintf(f,
            "{\n  \"trace\": \"%s\",\n  \"rows\": %llu,\n  \"window\": %u,\n  \"mode\": \"%s\",\n",
            r->args->trace_path, (unsigned long long)r->stream.next_index, r->args->window,
            r->args->sliding ? "sliding" : "tumbling");
    fprintf(f,
            "  \"primary\": \"%s\",\n  \"estimates\": %llu,\n  \"estimates_after_end\": %llu,\n"
            "  \"truth\": %s,\n",
            r->args->estimator, (unsigned long long)r->stats.estimates,
            (unsigned long long)r->after_end, r->stats.truth_seen ? "true" : "false");
    const struct trace_timing *tm = trace_reader_timing(&r->reader);
    fprintf(f,
            "  \"time_base\": {\"period_ms\": %u, \"source\": \"%s\", \"t_ms_repeats\": %llu, "
            "\"t_ms_jumps\": %llu, \"max_jump_ms\": %lu, \"max_jump_line\": %lu},\n"
            "  \"partial_window_rows\": %llu,\n"
            "  \"distance_mode\": {\"mode\": \"%s\", \"range_max_mm\": %u, \"source\": \"%s\"},\n",
            r->period_ms, tm->period_from_meta ? "trace" : "default",
            (unsigned long long)tm->repeats, (unsigned long long)tm->jumps,
            (unsigned long)tm->max_jump_ms, (unsigned long)tm->max_jump_line,
            (unsigned long long)r->partial_rows, vl53_distance_mode_name(r->distance.mode),
            vl53_range_max_mm(r->distance.mode), r->distance.source);
    write_head_calibration(f, r);
    fputs("  \"crb_alpha_deg\": ", f);
    json_number(f, replay_rms(r->stats.crb_sum2_alpha, r->stats.crb_windows));
    fputs(",\n  \"crb_beta_deg\": ", f);
    json_number(f, replay_rms(r->stats.crb_sum2_beta, r->stats.crb_windows));
}

/* Each estimator's statuses, errors, reasons and calibration. */
static void write_estimators(FILE *f, const struct replay *r) {
    fputs(",\n  \"estimators\": {\n", f);
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct err_stats *s = &r->stats.est[e];
        fprintf(f,
                "    \"%s\": {\"ok\": %u, \"degraded\": %u, \"invalid\": %u, "
                "\"unflagged_wrong\": %u",
                attitude_estimator_name((enum attitude_estimator)e), s->status_count[0],
                s->status_count[1], s->status_count[2], r->stats.unflagged_wrong[e]);
        static const char *const keys[6] = {"rms_alpha_deg", "mean_abs_alpha_deg", "max_alpha_deg",
                                            "rms_beta_deg",  "mean_abs_beta_deg",  "max_beta_deg"};
        const double vals[6] = {replay_rms(s->sum2_alpha, s->n_alpha),
                                s->n_alpha ? s->sum_abs_alpha / (double)s->n_alpha : NO_VALUE,
                                s->n_alpha ? s->max_alpha : NO_VALUE,
                                replay_rms(s->sum2_beta, s->n_beta),
                                s->n_beta ? s->sum_abs_beta / (double)s->n_beta : NO_VALUE,
                                s->n_beta ? s->max_beta : NO_VALUE};
        for (unsigned k = 0; k < 6; ++k) {
            fprintf(f, ", \"%s\": ", keys[k]);
            json_number(f, vals[k]);
        }
        write_calibration(f, r, e);
        fprintf(f, "}%s\n", e + 1u < ATTITUDE_EST_COUNT ? "," : "");
    }
}

/* The bus, the firmware's counters, its health events and each sensor. */
static void write_system(FILE *f, const struct replay *r) {
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
            "\"overruns\": %u},\n",
            r->health_events, r->reinit_events, r->bus_recovery_events, r->overrun_events);
    fprintf(f,
            "  \"temperature\": {\"sensor\": %s, \"offsets_follow\": \"%s\", \"read_errors\": %u, "
            "\"updates_begun\": %u, \"updates\": %u, \"updates_failed\": %u, "
            "\"part_updates\": [%u, %u, %u, %u]},\n",
            r->platform.temp.ops != NULL ? "true" : "false",
            !r->app.estimator.cfg.calibration.thermal ? "no-coefficients"
            : r->platform.temp.ops != NULL            ? "temperature"
                                                      : "calibration-temperature",
            c->temp_errors, r->temp_update_events, c->temp_updates, c->temp_updates_failed,
            r->sim.rig.sensor[0].stats.temperature_updates,
            r->sim.rig.sensor[1].stats.temperature_updates,
            r->sim.rig.sensor[2].stats.temperature_updates,
            r->sim.rig.sensor[3].stats.temperature_updates);
    fprintf(f, "  \"sensors\": [");
    for (unsigned i = 0; i < 4; ++i) {
        fprintf(f, "%s{\"name\": \"%c\", \"state\": \"%s\", \"losses\": %u, \"read_errors\": %u}",
                i ? ", " : "", 'A' + i, tof_health_name(r->app.health[i].state),
                r->app.health[i].losses, c->read_errors[i]);
    }
    fprintf(f, "]\n}\n");
}

int replay_report_write(const struct replay *r, const char *path) {
    FILE *f = fopen(path, "w");
    if (f == NULL) {
        fprintf(stderr, "host_sim replay: %s: %s\n", path, strerror(errno));
        return -1;
    }
    write_head(f, r);
    write_estimators(f, r);
    write_system(f, r);
    if (fclose(f) != 0) {
        fprintf(stderr, "host_sim replay: %s: write failed\n", path);
        return -1;
    }
    return 0;
}

/* ---- the summary ---- */

/* The sd calibration table of every estimator (traces with truth). */
static void print_calibration(const struct replay *r) {
    printf("sd calibration (answered rows; goals: >= 95 %% within 3 sd, <= 0.1 %% beyond 6 sd, "
           "rms err / rms sd >= 0.5, >= 95 %% answered):\n");
    printf("%-16s %9s %9s %9s %9s %9s %9s %9s\n", "estimator", "answered", "a<=3sd", "a>6sd",
           "a_err/sd", "b<=3sd", "b>6sd", "b_err/sd");
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct calib_axis *a = &r->stats.calib[e][0];
        const struct calib_axis *b = &r->stats.calib[e][1];
        printf("%-16s %8.1f%% %8.2f%% %8.2f%% %9.3f %8.2f%% %8.2f%% %9.3f\n",
               attitude_estimator_name((enum attitude_estimator)e),
               100.0 * replay_answered(&r->stats.est[e]), 100.0 * replay_share(a->within3, a->n),
               100.0 * replay_share(a->beyond6, a->n), replay_calib_ratio(a),
               100.0 * replay_share(b->within3, b->n), 100.0 * replay_share(b->beyond6, b->n),
               replay_calib_ratio(b));
    }
}

/* The primary estimator's reasons, the bus and the firmware's counters. */
static void print_tail(const struct replay *r) {
    printf("reasons (%s):", r->args->estimator);
    bool any = false;
    for (unsigned b = 0; b < WHY_BITS; ++b) {
        char name[ATTITUDE_WHY_TEXT_MAX];
        if (r->stats.why_count[r->primary][b] != 0u &&
            attitude_why_format((attitude_why_t)1u << b, name, sizeof name) > 0) {
            printf(" %s %u", name, r->stats.why_count[r->primary][b]);
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

void replay_report_summary(const struct replay *r) {
    const struct replay_stats *st = &r->stats;
    char base[96];
    printf("replay %s: %llu rows, window %u (%s), %llu estimates, primary %s\n",
           r->args->trace_path, (unsigned long long)r->stream.next_index, r->args->window,
           r->args->sliding ? "sliding" : "tumbling", (unsigned long long)st->estimates,
           r->args->estimator);
    printf("time base: %s; windows counted in rows\n", time_base(r, base, sizeof base));
    printf("distance mode: %s (to %u mm; %s)\n", vl53_distance_mode_name(r->distance.mode),
           vl53_range_max_mm(r->distance.mode), r->distance.source);
    printf("%-16s %10s %10s %10s %10s %10s %10s %6s %6s %6s\n", "estimator", "rms_a[deg]",
           "mae_a[deg]", "max_a[deg]", "rms_b[deg]", "mae_b[deg]", "max_b[deg]", "ok", "degr",
           "inval");
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct err_stats *s = &st->est[e];
        printf("%-16s %10.4f %10.4f %10.4f %10.4f %10.4f %10.4f %6u %6u %6u\n",
               attitude_estimator_name((enum attitude_estimator)e),
               replay_rms(s->sum2_alpha, s->n_alpha),
               s->n_alpha ? s->sum_abs_alpha / (double)s->n_alpha : NO_VALUE,
               s->n_alpha ? s->max_alpha : NO_VALUE, replay_rms(s->sum2_beta, s->n_beta),
               s->n_beta ? s->sum_abs_beta / (double)s->n_beta : NO_VALUE,
               s->n_beta ? s->max_beta : NO_VALUE, s->status_count[0], s->status_count[1],
               s->status_count[2]);
    }
    if (st->truth_seen) {
        printf("%-16s %10.4f %10s %10s %10.4f   (Cramer-Rao bound from each window's own sigma)\n",
               "bound", replay_rms(st->crb_sum2_alpha, st->crb_windows), "", "",
               replay_rms(st->crb_sum2_beta, st->crb_windows));
        print_calibration(r);
    } else {
        printf("(no ground truth in this trace: errors and bound not available)\n");
    }
    print_tail(r);
}
