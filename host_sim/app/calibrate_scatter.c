/* host_sim calibrate's checks of a fit's scatter: the likely cause named, what it refuses
 * (calibrate.h). */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "calibrate.h"
#include "calibrate/calfit.h"
#include "scene/geometry.h"

/* The stations' means scattering about the fit this many times more (in variance) than
 * their noise explains is not a head to calibrate but a wrong geometry: a wrong arm_mm (40 mm
 * for a 30 mm head: 15-33 on 6 stations of 100 readings, 214-239 on the fixture's 20 of
 * 750), or station truths that are not the fixture's. Nothing is written, whatever the
 * options. */
#define GEOMETRY_SCATTER_MAX 100.0

/* A scatter ratio above this is named with its likely cause (a right model leaves about 1;
 * over the fixture's 18 or more degrees of freedom a ratio of 3 has a probability below 1e-4
 * under white noise): correct fixtures read 0.6-2.9 (fixture, fixture-ar1, fixture-drift,
 * fixture-one-distance, seeds 1-3). */
#define SCATTER_NAMED 3.0

/* Above this, a scatter between stations (temperature, arm, or no cause found) refuses the
 * fit unless --accept-scatter: the stated sd, widened by sqrt(ratio), then describes stations
 * that differ by something the model leaves out, which another temperature or distance does
 * not repeat. Readings wandering within stations (motion) are written with a warning: their
 * slow noise is what the widened sd describes (fixture-realnoise: 9.8-44, its stated sd
 * matching the actual error, docs/explanation/calibration.md). */
#define SCATTER_REFUSE 10.0

/* A diagnostic's t (a coefficient, an arm error over its sd) beyond this names the cause. */
#define CAUSE_T_MIN 5.0

/* Half-station means differing this many times (in variance) more than their noise allows:
 * the readings move within stations. */
#define MOTION_RATIO_MIN 3.0

/* An arm error this many sd from 0 in every sensor, all of the same sign, is a wrong arm_mm.
 * Chosen before looking: it refused none of 40 correct fixture traces (fixture, fixture-ar1,
 * fixture-drift, fixture-realnoise, fixture-one-distance, seeds 1-8) and refuses the
 * fixture (20 stations x 750 readings, arm 30 mm) stated at 32 mm or more (11.7 sd), and 6
 * stations of 100 readings stated at 40 mm (5.5-11.5 sd). */
#define ARM_ERROR_T_MIN 5.0

/*
 * Sensor k's station means fitted with an arm error as another parameter: mean = g·x + o +
 * c·u [+ t·(T − cal_temp) when the fit is thermal], u the change of the true distance x per mm
 * of arm (scene_ideal_distances), by weighted least squares (weights 1/mean_sd²).
 * *arm_err_mm = c/g, *t = c over its sd, the sd scaled by the reduced chi-square of this fit
 * when above 1 (scatter the arm does not explain widens it). false when it cannot be fitted
 * (without gains, too few stations, singular).
 */
static bool arm_error(const struct calfit_data *d, const struct calfit_result *res, unsigned k,
                      double *arm_err_mm, double *t) {
    const unsigned p = res->thermal ? 4u : 3u;
    if (!res->gains || d->n_stations < p + 1u) {
        return false;
    }
    double *f = malloc(d->n_stations * p * sizeof *f);
    double *y = malloc(d->n_stations * sizeof *y);
    double *w = malloc(d->n_stations * sizeof *w);
    bool ok = f != NULL && y != NULL && w != NULL;
    size_t n = 0;
    for (size_t j = 0; ok && j < d->n_stations; ++j) {
        const struct calfit_station *st = &d->stations[j];
        if (!st->used[k] || !(st->mean_sd_mm[k] > 0.0)) {
            continue;
        }
        double x1[4];
        scene_ideal_distances(d->arm_mm + 1.0, st->distance_mm, st->alpha_deg, st->beta_deg, x1);
        double *fi = f + n * p;
        fi[0] = st->x_mm[k];
        fi[1] = 1.0;
        fi[2] = x1[k] - st->x_mm[k];
        if (res->thermal) {
            fi[3] = st->temp_c - res->cal_temp_c;
        }
        y[n] = st->mean_mm[k];
        w[n] = 1.0 / (st->mean_sd_mm[k] * st->mean_sd_mm[k]);
        ++n;
    }
    double c[CALFIT_WLS_MAX_P];
    double cov[CALFIT_WLS_MAX_P * CALFIT_WLS_MAX_P];
    ok = ok && n >= p + 1u && calfit_wls_general(f, y, w, n, p, c, cov) == 0;
    double chi2 = 0.0;
    for (size_t i = 0; ok && i < n; ++i) {
        double fit = 0.0;
        for (unsigned r = 0; r < p; ++r) {
            fit += c[r] * f[i * p + r];
        }
        chi2 += (y[i] - fit) * (y[i] - fit) * w[i];
    }
    free(f);
    free(y);
    free(w);
    if (!ok) {
        return false;
    }
    const double red = chi2 / (double)(n - p);
    const double sd = sqrt(cov[2 * p + 2] * (red > 1.0 ? red : 1.0));
    if (!(sd > 0.0) || !(c[0] > 0.0)) {
        return false;
    }
    *arm_err_mm = c[2] / c[0];
    *t = c[2] / sd;
    return true;
}

/* Why the coefficient was not fitted, for the temperature cause. */
static const char *thermal_why(const struct calfit_result *res) {
    switch (res->thermal_state) {
    case CALFIT_THERMAL_NARROW:
        return "the span is below the 10 C a coefficient needs";
    case CALFIT_THERMAL_FEW_STATIONS:
        return "too few stations for it";
    case CALFIT_THERMAL_SOME_MISSING:
        return "some stations have no temp_c";
    case CALFIT_THERMAL_NO_TEMP:
        return "the trace has no temp_c";
    default:
        return "";
    }
}

/* The likely cause of sensor k's scatter into buf; *between true when it lies between stations
 * (temperature, arm, none found), false when the readings move within stations. */
static void cause_of(const struct calfit_data *d, const struct calfit_result *res, unsigned k,
                     char *buf, size_t len, bool *between) {
    const struct calfit_sensor *s = &res->sensor[k];
    size_t n = 0;
    buf[0] = '\0';
    *between = false;
    if (s->temp_probe && fabs(s->temp_probe_t) > CAUSE_T_MIN &&
        s->temp_probe_ratio < s->chi2_red / 2.0) {
        n += (size_t)snprintf(buf + n, len - n,
                              "temperature: the station means follow the stations' temperatures "
                              "(%.1f..%.1f C; a coefficient of %.4f mm/C at %.1f sd leaves a "
                              "ratio of %.2f), and no coefficient was fitted (%s): record "
                              "stations spanning 10 C or more",
                              res->temp_min_c, res->temp_max_c, s->temp_probe_mm_per_c,
                              fabs(s->temp_probe_t), s->temp_probe_ratio, thermal_why(res));
        *between = true;
    }
    double arm_err = 0.0;
    double t = 0.0;
    if (n < len && arm_error(d, res, k, &arm_err, &t) && fabs(t) > CAUSE_T_MIN) {
        n += (size_t)snprintf(buf + n, len - n,
                              "%sarm: its station means fit an arm of %.3f mm (%.1f sd from the "
                              "trace's arm_mm %.6g): check the head's arm",
                              n ? "; " : "", d->arm_mm + arm_err, fabs(t), d->arm_mm);
        *between = true;
    }
    if (n < len && s->motion_ratio > MOTION_RATIO_MIN) {
        n += (size_t)snprintf(buf + n, len - n,
                              "%smotion: its readings move within stations (half-station means "
                              "differ %.1f times their noise in variance): the plate or head was "
                              "not still, or the offset wanders faster than a station",
                              n ? "; " : "", s->motion_ratio);
    }
    if (n == 0u) {
        *between = true;
        if (!res->thermal && (res->thermal_state == CALFIT_THERMAL_NO_TEMP ||
                              res->thermal_state == CALFIT_THERMAL_SOME_MISSING)) {
            snprintf(buf, len,
                     "the stations differ by something the fit leaves out, not the arm and not "
                     "motion within stations: most likely temperature, which this trace cannot "
                     "show (%s: record it), or a drift over the run; else the stations' alpha, "
                     "beta or distance",
                     thermal_why(res));
        } else {
            snprintf(buf, len,
                     "the stations differ by something the fit leaves out (not temperature, arm "
                     "or motion within stations): a drift over the run, or the stations' alpha, "
                     "beta or distance");
        }
    }
}

int calibrate_check_scatter(const char *trace, const struct calfit_data *d,
                            const struct calfit_result *res, bool accept, char *accepted,
                            size_t accepted_len) {
    accepted[0] = '\0';
    /* Every sensor alike fitting another arm: the trace's arm_mm is wrong. */
    double err[4], t[4];
    bool all = res->gains;
    for (unsigned k = 0; k < 4u && all; ++k) {
        all = arm_error(d, res, k, &err[k], &t[k]) && fabs(t[k]) > ARM_ERROR_T_MIN &&
              (t[k] > 0.0) == (t[0] > 0.0);
    }
    if (all) {
        for (unsigned k = 0; k < 4u; ++k) {
            fprintf(stderr,
                    "host_sim calibrate: %s: sensor %c: scatter ratio %.1f over %u dof; its "
                    "station means fit an arm of %.3f mm (%.1f sd from the trace's arm_mm "
                    "%.6g, every sensor alike): the trace's arm_mm is not the head's: nothing "
                    "written\n",
                    trace, 'A' + k, res->sensor[k].chi2_red, res->sensor[k].dof, d->arm_mm + err[k],
                    fabs(t[k]), d->arm_mm);
        }
        return -1;
    }
    int rc = 0;
    size_t used = 0;
    for (unsigned k = 0; k < 4u; ++k) {
        const struct calfit_sensor *s = &res->sensor[k];
        if (s->dof == 0u || s->chi2_red <= SCATTER_NAMED) {
            continue;
        }
        char cause[900];
        bool between = false;
        cause_of(d, res, k, cause, sizeof cause, &between);
        const bool geometry = !(s->chi2_red <= GEOMETRY_SCATTER_MAX);
        const bool refuse = geometry || (between && s->chi2_red > SCATTER_REFUSE && !accept);
        const char *action = NULL;
        char widened[160];
        snprintf(widened, sizeof widened, "its sd widened %.1f times by the scatter",
                 sqrt(s->inflation));
        if (geometry) {
            action = "more than 100: the station means do not fit any offset and gain at this "
                     "arm_mm; nothing written";
        } else if (refuse) {
            action = "nothing written (--accept-scatter writes it, its sd widened by the "
                     "scatter)";
        }
        fprintf(stderr,
                "host_sim calibrate: %s: %ssensor %c: scatter ratio %.1f over %u dof: the "
                "fit's model does not explain its station means; likely cause: %s; %s%s\n",
                trace, refuse ? "" : "warning: ", 'A' + k, s->chi2_red, s->dof, cause,
                action != NULL ? action : "written, ", action != NULL ? "" : widened);
        if (refuse) {
            rc = -1;
        } else if (between && s->chi2_red > SCATTER_REFUSE && used < accepted_len) {
            used += (size_t)snprintf(accepted + used, accepted_len - used, "%s%c %.2f",
                                     used ? ", " : "scatter_accepted=", 'A' + k, s->chi2_red);
        }
    }
    return rc;
}
