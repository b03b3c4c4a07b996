/* host_sim calibrate's report: the fit per sensor and the residuals per station (JSON), and the
 * thermal fit's state as a phrase (also for stderr). */
#include <math.h>
#include <stdio.h>

#include "calibrate.h"
#include "calibrate/calfit.h"

void calibrate_thermal_why(const struct calfit_data *d, const struct calfit_result *res, char *buf,
                           size_t len) {
    switch (res->thermal_state) {
    case CALFIT_THERMAL_FITTED:
        snprintf(buf, len, "fitted");
        break;
    case CALFIT_THERMAL_NO_TEMP:
        snprintf(buf, len, "the trace has no temp_c (no station row carries a temperature)");
        break;
    case CALFIT_THERMAL_SOME_MISSING:
        snprintf(buf, len,
                 "%zu of %zu stations have rows without temp_c (the first: lines %u-%u): every "
                 "station needs its temperature",
                 res->stations_no_temp, d->n_stations, res->no_temp_first_line,
                 res->no_temp_last_line);
        break;
    case CALFIT_THERMAL_NARROW:
        snprintf(buf, len,
                 "the stations span %.2f C (%.2f..%.2f C), less than the %.0f C a coefficient "
                 "needs",
                 res->temp_max_c - res->temp_min_c, res->temp_min_c, res->temp_max_c,
                 CALFIT_MIN_TEMP_SPAN_C);
        break;
    default:
        snprintf(buf, len, "a sensor has fewer than %u stations, which a coefficient needs",
                 CALFIT_MIN_STATIONS_THERMAL);
        break;
    }
}

static void json_string(FILE *f, const char *s) {
    fputc('"', f);
    for (; *s != '\0'; ++s) {
        const unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') {
            fprintf(f, "\\%c", c);
        } else if (c < 0x20u) {
            fprintf(f, "\\u%04x", c);
        } else {
            fputc(c, f);
        }
    }
    fputc('"', f);
}

/* What more readings per station would give: the offset's sd from the noise alone falls as
 * 1/sqrt(n); reaching 0.05 mm (the calibration's goal) takes n · (sd / 0.05)² readings. A scatter
 * between stations beyond the noise (inflation > 1) does not fall with n: more stations. */
static double readings_for(const struct calfit_sensor *s, double per_station, double target) {
    const double r = s->offset_sd_within_mm / target;
    return ceil(per_station * r * r);
}

static void write_sensor(FILE *f, const struct calfit_sensor *s, unsigned k, bool gains,
                         bool thermal) {
    const double per_station = s->stations > 0u ? (double)s->readings / s->stations : 0.0;
    fprintf(f, "    {\"sensor\": \"%c\", \"offset_mm\": %.6f, \"offset_sd_mm\": %.6f, ", 'A' + k,
            s->offset_mm, s->offset_sd_mm);
    if (gains) {
        fprintf(f, "\"gain\": %.8f, \"gain_sd\": %.8f, \"offset_gain_corr\": %.6f, ", s->gain,
                s->gain_sd, s->corr);
    } else {
        fputs("\"gain\": null, \"gain_sd\": null, \"offset_gain_corr\": null, ", f);
    }
    fprintf(f,
            "\"offset_sd_within_mm\": %.6f, \"noise_sd_mm\": %.6f, \"noise_tau\": %.4f, "
            "\"noise_tau_settled\": %s, \"effective_readings\": %.1f, \"stations\": %u, "
            "\"readings\": %llu, \"chi2\": %.6f, \"dof\": %u, \"scatter_ratio\": %.6f, "
            "\"inflation\": %.6f, \"excess_sd_mm\": %.6f, \"residual_rms_mm\": %.6f, "
            "\"readings_per_station_for_0_05_mm\": %.0f, \"motion_ratio\": %.4f",
            s->offset_sd_within_mm, s->noise_sd_mm, s->tau, s->tau_settled ? "true" : "false",
            (double)s->readings / s->tau, s->stations, (unsigned long long)s->readings, s->chi2,
            s->dof, s->chi2_red, s->inflation, s->excess_sd_mm, s->residual_rms_mm,
            readings_for(s, per_station, 0.05), s->motion_ratio);
    if (thermal) {
        fprintf(f,
                ", \"temp_coeff_mm_per_c\": %.8f, \"temp_coeff_sd_mm_per_c\": %.8f, "
                "\"offset_coeff_corr\": %.6f, \"gain_coeff_corr\": %.6f}",
                s->temp_coeff_mm_per_c, s->temp_coeff_sd_mm_per_c, s->corr_offset_coeff,
                s->corr_gain_coeff);
    } else if (s->temp_probe) {
        fprintf(f,
                ", \"temp_coeff_mm_per_c\": null, \"temp_probe_mm_per_c\": %.8f, "
                "\"temp_probe_t\": %.3f, \"temp_probe_scatter_ratio\": %.6f}",
                s->temp_probe_mm_per_c, s->temp_probe_t, s->temp_probe_ratio);
    } else {
        fputs(", \"temp_coeff_mm_per_c\": null}", f);
    }
}

static void write_station(FILE *f, const struct calfit_station *st, size_t j) {
    fprintf(f,
            "    {\"station\": %zu, \"first_line\": %u, \"last_line\": %u, \"t_first_ms\": %u, "
            "\"t_last_ms\": %u, \"rows\": %u, \"alpha_deg\": %.6f, \"beta_deg\": %.6f, "
            "\"distance_mm\": %.3f, ",
            j, st->first_line, st->last_line, st->t_first_ms, st->t_last_ms, st->rows,
            st->alpha_deg, st->beta_deg, st->distance_mm);
    if (st->has_temp) {
        fprintf(f, "\"temp_c\": %.3f, \"sensors\": [", st->temp_c);
    } else {
        fputs("\"temp_c\": null, \"sensors\": [", f);
    }
    for (unsigned k = 0; k < CALFIT_SENSORS; ++k) {
        fprintf(f, "%s{\"sensor\": \"%c\", \"n\": %u, \"used\": %s, \"true_mm\": %.4f",
                k ? ", " : "", 'A' + k, st->n[k], st->used[k] ? "true" : "false", st->x_mm[k]);
        if (st->used[k]) {
            fprintf(f,
                    ", \"mean_mm\": %.4f, \"sd_mm\": %.4f, \"mean_sd_mm\": %.5f, "
                    "\"residual_mm\": %.5f, \"residual_sd\": %.3f",
                    st->mean_mm[k], st->sd_mm[k], st->mean_sd_mm[k], st->residual_mm[k],
                    st->residual_mm[k] / st->mean_sd_mm[k]);
        }
        fputc('}', f);
    }
    fputs("]}", f);
}

int calibrate_write_report(FILE *f, const char *trace, const struct calfit_data *d,
                           const struct calfit_result *res) {
    fputs("{\n  \"trace\": ", f);
    json_string(f, trace);
    fprintf(f,
            ",\n  \"fit\": \"%s\",\n  \"arm_mm\": %.6g,\n  \"rows\": %llu,\n"
            "  \"rows_without_truth\": %llu,\n  \"rows_partial_truth\": %llu,\n"
            "  \"rows_with_invalid_readings\": %llu,\n"
            "  \"invalid_readings\": [%llu, %llu, %llu, %llu],\n"
            "  \"distance_range_mm\": [%.3f, %.3f],\n",
            res->gains ? "offsets+gains" : "offsets", d->arm_mm, (unsigned long long)d->rows,
            (unsigned long long)d->rows_no_truth, (unsigned long long)d->rows_partial_truth,
            (unsigned long long)d->rows_with_invalid, (unsigned long long)d->invalid[0],
            (unsigned long long)d->invalid[1], (unsigned long long)d->invalid[2],
            (unsigned long long)d->invalid[3], d->distance_min_mm, d->distance_max_mm);
    char why[CALIBRATE_THERMAL_WHY_MAX];
    calibrate_thermal_why(d, res, why, sizeof why);
    fprintf(f, "  \"thermal\": {\"fitted\": %s, \"why\": ", res->thermal ? "true" : "false");
    json_string(f, why);
    fprintf(f, ", \"stations_without_temp\": %zu", res->stations_no_temp);
    if (res->stations_no_temp < d->n_stations) {
        fprintf(f, ", \"temp_range_c\": [%.3f, %.3f]", res->temp_min_c, res->temp_max_c);
    }
    if (res->thermal) {
        fprintf(f, ", \"cal_temp_c\": %.2f", res->cal_temp_c);
    }
    fputs("},\n  \"sensors\": [\n", f);
    for (unsigned k = 0; k < CALFIT_SENSORS; ++k) {
        write_sensor(f, &res->sensor[k], k, res->gains, res->thermal);
        fputs(k + 1u < CALFIT_SENSORS ? ",\n" : "\n", f);
    }
    fputs("  ],\n  \"stations\": [\n", f);
    for (size_t j = 0; j < d->n_stations; ++j) {
        write_station(f, &d->stations[j], j);
        fputs(j + 1u < d->n_stations ? ",\n" : "\n", f);
    }
    fputs("  ]\n}\n", f);
    return ferror(f) ? -1 : 0;
}
