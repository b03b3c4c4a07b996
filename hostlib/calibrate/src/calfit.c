/* `host_sim calibrate`'s fit: stations from rows, each sensor's offset and gain (calfit.h). */
#include "calibrate/calfit.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene/geometry.h"

void calfit_init(struct calfit_data *d, double arm_mm, double quantum_mm) {
    memset(d, 0, sizeof *d);
    d->arm_mm = arm_mm;
    d->quantum_mm = quantum_mm;
}

void calfit_free(struct calfit_data *d) {
    free(d->stations);
    for (unsigned k = 0; k < CALFIT_SENSORS; ++k) {
        free(d->readings[k]);
    }
    memset(d, 0, sizeof *d);
}

/* Room for one more element of size `size` in *buf (count used of *cap). 0 or -1. */
static int grow(void **buf, size_t *cap, size_t used, size_t size) {
    if (used < *cap) {
        return 0;
    }
    const size_t n = *cap == 0u ? 256u : *cap * 2u;
    void *p = realloc(*buf, n * size);
    if (p == NULL) {
        return -1;
    }
    *buf = p;
    *cap = n;
    return 0;
}

/* The station a row with this truth belongs to: the open one if its truth is the same,
 * else a new one. NULL when out of memory. */
static struct calfit_station *station_for(struct calfit_data *d, double alpha, double beta,
                                          double distance, uint32_t t_ms, uint32_t line) {
    if (d->open && d->n_stations > 0u) {
        struct calfit_station *st = &d->stations[d->n_stations - 1u];
        if (st->alpha_deg == alpha && st->beta_deg == beta && st->distance_mm == distance) {
            return st;
        }
    }
    if (grow((void **)&d->stations, &d->cap_stations, d->n_stations, sizeof *d->stations) != 0) {
        return NULL;
    }
    struct calfit_station *st = &d->stations[d->n_stations++];
    memset(st, 0, sizeof *st);
    st->alpha_deg = alpha;
    st->beta_deg = beta;
    st->distance_mm = distance;
    st->first_line = line;
    st->t_first_ms = t_ms;
    scene_ideal_distances(d->arm_mm, distance, alpha, beta, st->x_mm);
    for (unsigned k = 0; k < CALFIT_SENSORS; ++k) {
        st->first[k] = d->n_readings[k];
    }
    if (d->n_stations == 1u || distance < d->distance_min_mm) {
        d->distance_min_mm = distance;
    }
    if (d->n_stations == 1u || distance > d->distance_max_mm) {
        d->distance_max_mm = distance;
    }
    d->open = true;
    return st;
}

int calfit_add(struct calfit_data *d, bool has_truth, double alpha_deg, double beta_deg,
               double distance_mm, const double raw[CALFIT_SENSORS],
               const bool valid[CALFIT_SENSORS], uint32_t t_ms, uint32_t line) {
    return calfit_add_temp(d, has_truth, alpha_deg, beta_deg, distance_mm, raw, valid, false, 0.0,
                           t_ms, line);
}

int calfit_add_temp(struct calfit_data *d, bool has_truth, double alpha_deg, double beta_deg,
                    double distance_mm, const double raw[CALFIT_SENSORS],
                    const bool valid[CALFIT_SENSORS], bool has_temp, double temp_c, uint32_t t_ms,
                    uint32_t line) {
    d->rows++;
    if (!has_truth) {
        d->open = false; /* the fixture moves: the next truth starts a new station */
        d->rows_no_truth++;
        return 0;
    }
    struct calfit_station *st = station_for(d, alpha_deg, beta_deg, distance_mm, t_ms, line);
    if (st == NULL) {
        return -1;
    }
    st->rows++;
    st->last_line = line;
    st->t_last_ms = t_ms;
    if (has_temp) {
        st->temp_rows++;
        st->temp_sum_c += temp_c;
        d->rows_with_temp++;
    }
    bool any_invalid = false;
    for (unsigned k = 0; k < CALFIT_SENSORS; ++k) {
        if (!valid[k]) {
            d->invalid[k]++;
            any_invalid = true;
            continue;
        }
        if (grow((void **)&d->readings[k], &d->cap_readings[k], d->n_readings[k],
                 sizeof *d->readings[k]) != 0) {
            return -1;
        }
        d->readings[k][d->n_readings[k]++] = raw[k];
        st->n[k]++;
    }
    d->rows_with_invalid += any_invalid ? 1u : 0u;
    return 0;
}

int calfit_add_row(struct calfit_data *d, const struct scene_row *row, uint32_t line) {
    double raw[CALFIT_SENSORS];
    bool valid[CALFIT_SENSORS];
    for (unsigned k = 0; k < CALFIT_SENSORS; ++k) {
        raw[k] = (double)row->range_mm[k];
        valid[k] = scene_row_valid(row, k);
    }
    const bool all = row->has_alpha && row->has_beta && row->has_distance;
    const bool some = row->has_alpha || row->has_beta || row->has_distance;
    if (some && !all) {
        /* Not a station's row (its true distances are not known) and not the fixture
         * moving either: counted on its own, and it ends the open station. */
        d->rows++;
        d->rows_partial_truth++;
        d->open = false;
        return 0;
    }
    return calfit_add_temp(d, all, row->alpha_deg, row->beta_deg, row->distance_mm, raw, valid,
                           row->has_temp, row->temp_c, row->t_ms, line);
}

/* Each station's mean and sd for sensor k; the number of stations it can use. */
static uint32_t station_moments(struct calfit_data *d, unsigned k) {
    uint32_t used = 0;
    for (size_t j = 0; j < d->n_stations; ++j) {
        struct calfit_station *st = &d->stations[j];
        const double *r = d->readings[k] + st->first[k];
        const uint32_t n = st->n[k];
        st->used[k] = n >= CALFIT_MIN_READINGS;
        if (!st->used[k]) {
            continue;
        }
        used++;
        double sum = 0.0;
        for (uint32_t t = 0; t < n; ++t) {
            sum += r[t];
        }
        const double m = sum / n;
        double ss = 0.0;
        for (uint32_t t = 0; t < n; ++t) {
            ss += (r[t] - m) * (r[t] - m);
        }
        st->mean_mm[k] = m;
        st->sd_mm[k] = sqrt(ss / (n - 1u));
    }
    return used;
}

/* Variance of a station mean: s² τ / n, and never below what whole-millimetre readings
 * leave when the noise does not dither them: rounding biases a mean by up to q/2, a bias
 * whose square averages q²/12 at σ = 0 and falls as exp(−4π²σ²/q²) (the first Fourier
 * term of the rounding error, Sheppard's setting) as the noise grows. */
static double mean_variance(const struct calfit_data *d, const struct calfit_station *st,
                            unsigned k, double tau) {
    const double s2 = st->sd_mm[k] * st->sd_mm[k];
    double v = s2 * tau / st->n[k];
    const double q = d->quantum_mm;
    if (q > 0.0) {
        const double floor_q = q * q / 12.0 * exp(-4.0 * SCENE_PI * SCENE_PI * s2 / (q * q));
        v = v > floor_q ? v : floor_q;
    }
    return v > CALFIT_VAR_FLOOR_MM2 ? v : CALFIT_VAR_FLOOR_MM2;
}

struct sensor_arrays {
    double *x, *y, *w;
};

/* Sensor k's station means fitted with a temperature term, p + 1 parameters: features
 * [1, x, T − tc] (gains) or [1, T − tc] on mean − x (p = 1). coef[0] offset, coef[1] gain (1
 * without gains), coef[2] the coefficient; cov the unscaled covariance over those three (gain
 * rows 0 without gains). *chi2 (chi2 may be NULL) the weighted residual sum. 0, or -1 when
 * singular. */
static int fit_thermal(const struct calfit_data *d, unsigned k, unsigned p, struct sensor_arrays a,
                       size_t n, double tc, double coef[3], double cov[3][3], double *chi2) {
    const unsigned q = p + 1u;
    double *f = malloc(n * q * sizeof *f);
    double *y = malloc(n * sizeof *y);
    int rc = f != NULL && y != NULL ? 0 : -1;
    size_t i = 0;
    for (size_t j = 0; rc == 0 && j < d->n_stations; ++j) {
        const struct calfit_station *st = &d->stations[j];
        if (!st->used[k]) {
            continue;
        }
        double *fi = f + i * q;
        fi[0] = 1.0;
        if (p == 2u) {
            fi[1] = st->x_mm[k];
        }
        fi[q - 1u] = st->temp_c - tc;
        y[i] = p == 2u ? a.y[i] : a.y[i] - a.x[i];
        ++i;
    }
    double c[CALFIT_WLS_MAX_P];
    double v[CALFIT_WLS_MAX_P * CALFIT_WLS_MAX_P];
    if (rc == 0 && calfit_wls_general(f, y, a.w, n, q, c, v) != 0) {
        rc = -1;
    }
    if (rc == 0) {
        /* into (offset, gain, coefficient) order, the gain's row 0 without gains */
        enum { NOT_FITTED = CALFIT_WLS_MAX_P };
        const unsigned at[3] = {0u, p == 2u ? 1u : NOT_FITTED, q - 1u};
        for (unsigned r = 0; r < 3u; ++r) {
            coef[r] = at[r] == NOT_FITTED ? 1.0 : c[at[r]];
            for (unsigned s2 = 0; s2 < 3u; ++s2) {
                cov[r][s2] =
                    at[r] == NOT_FITTED || at[s2] == NOT_FITTED ? 0.0 : v[at[r] * q + at[s2]];
            }
        }
    }
    if (rc == 0 && chi2 != NULL) {
        *chi2 = 0.0;
        for (size_t m = 0; m < n; ++m) {
            const double *fm = f + m * q;
            double fit = 0.0;
            for (unsigned r = 0; r < q; ++r) {
                fit += c[r] * fm[r];
            }
            *chi2 += (y[m] - fit) * (y[m] - fit) * a.w[m];
        }
    }
    free(f);
    free(y);
    return rc;
}

/* The fit of sensor k on its used stations (n of them, arrays a), with the temperature term
 * when d's stations are thermal (tc the calibration temperature). 0 or -1 (singular). */
static int fit_sensor(struct calfit_data *d, unsigned k, unsigned p, bool thermal, double tc,
                      struct sensor_arrays a, size_t n, struct calfit_sensor *out) {
    double coef[3] = {0.0, 1.0, 0.0};
    double cov[3] = {0.0, 0.0, 0.0};
    double tcov[3][3] = {{0}};
    if (thermal) {
        if (fit_thermal(d, k, p, a, n, tc, coef, tcov, NULL) != 0) {
            return -1;
        }
        cov[0] = tcov[0][0];
        cov[1] = tcov[0][1];
        cov[2] = tcov[1][1];
    } else if (calfit_wls(a.x, a.y, a.w, n, p, coef, cov) != 0) {
        return -1;
    }
    const unsigned params = thermal ? p + 1u : p;
    double chi2 = 0.0;
    double r2 = 0.0;
    double vsum = 0.0;
    size_t i = 0;
    for (size_t j = 0; j < d->n_stations; ++j) {
        struct calfit_station *st = &d->stations[j];
        if (!st->used[k]) {
            continue;
        }
        const double res = st->mean_mm[k] - (coef[0] + coef[1] * st->x_mm[k] +
                                             (thermal ? coef[2] * (st->temp_c - tc) : 0.0));
        st->residual_mm[k] = res;
        chi2 += res * res * a.w[i];
        r2 += res * res;
        vsum += 1.0 / a.w[i];
        ++i;
    }
    out->dof = (uint32_t)(n - params);
    out->chi2 = chi2;
    out->chi2_red = chi2 / out->dof;
    out->inflation = out->chi2_red > 1.0 ? out->chi2_red : 1.0;
    out->residual_rms_mm = sqrt(r2 / (double)n);
    out->excess_sd_mm = sqrt((out->inflation - 1.0) * vsum / (double)n);
    out->offset_mm = coef[0];
    out->gain = coef[1];
    out->offset_sd_within_mm = sqrt(cov[0]);
    out->offset_sd_mm = sqrt(cov[0] * out->inflation);
    out->gain_sd = sqrt(cov[2] * out->inflation);
    out->corr = p == 2u ? cov[1] / sqrt(cov[0] * cov[2]) : 0.0;
    if (thermal) {
        out->temp_coeff_mm_per_c = coef[2];
        out->temp_coeff_sd_mm_per_c = sqrt(tcov[2][2] * out->inflation);
        out->corr_offset_coeff = tcov[0][2] / sqrt(tcov[0][0] * tcov[2][2]);
        out->corr_gain_coeff = p == 2u ? tcov[1][2] / sqrt(tcov[1][1] * tcov[2][2]) : 0.0;
    }
    return 0;
}

/* A coefficient fitted on temperatures too narrow to state it, only to tell whether the
 * scatter follows temperature (calfit_sensor.temp_probe). */
static void temp_probe(struct calfit_data *d, unsigned k, unsigned p, double tc,
                       struct sensor_arrays a, size_t n, struct calfit_sensor *out) {
    double coef[3];
    double cov[3][3];
    double chi2 = 0.0;
    if (n < p + 2u || fit_thermal(d, k, p, a, n, tc, coef, cov, &chi2) != 0 || !(cov[2][2] > 0.0)) {
        return;
    }
    const double red = chi2 / (double)(n - p - 1u);
    out->temp_probe = true;
    out->temp_probe_ratio = red;
    out->temp_probe_mm_per_c = coef[2];
    out->temp_probe_t = coef[2] / sqrt(cov[2][2] * (red > 1.0 ? red : 1.0));
}

/* Each used station's first and second half means of sensor k against their sd (τ
 * included): mean z² (calfit_sensor.motion_ratio). */
static double motion_ratio(const struct calfit_data *d, unsigned k, double tau) {
    double sum = 0.0;
    unsigned count = 0;
    for (size_t j = 0; j < d->n_stations; ++j) {
        const struct calfit_station *st = &d->stations[j];
        if (!st->used[k] || st->n[k] < 2u * CALFIT_MIN_READINGS || !(st->sd_mm[k] > 0.0)) {
            continue;
        }
        const double *r = d->readings[k] + st->first[k];
        const uint32_t n1 = st->n[k] / 2u;
        const uint32_t n2 = st->n[k] - n1;
        double m1 = 0.0;
        double m2 = 0.0;
        for (uint32_t t = 0; t < n1; ++t) {
            m1 += r[t];
        }
        for (uint32_t t = n1; t < st->n[k]; ++t) {
            m2 += r[t];
        }
        m1 /= n1;
        m2 /= n2;
        const double var = st->sd_mm[k] * st->sd_mm[k] * tau * (1.0 / n1 + 1.0 / n2);
        sum += (m2 - m1) * (m2 - m1) / var;
        ++count;
    }
    return count > 0u ? sum / count : 0.0;
}

/* Sensor k's fit with p parameters (and the temperature term when res->thermal). 0, -1 with
 * err, or -2 when thermal and the sensor has fewer than CALFIT_MIN_STATIONS_THERMAL stations. */
static int run_sensor(struct calfit_data *d, unsigned k, unsigned p,
                      const struct calfit_result *res, struct calfit_sensor *out, char *err,
                      size_t errlen) {
    const char name = (char)('A' + k);
    memset(out, 0, sizeof *out);
    const uint32_t used = station_moments(d, k);
    const uint32_t need = p == 2u ? CALFIT_MIN_STATIONS_GAIN : CALFIT_MIN_STATIONS_OFFSET;
    if (used < need) {
        snprintf(err, errlen,
                 "sensor %c: %u station%s with at least %u valid readings, the fit needs %u "
                 "(%s)",
                 name, used, used == 1u ? "" : "s", CALFIT_MIN_READINGS, need,
                 p == 2u ? "offset, gain and one to check the scatter"
                         : "offset and one to check the scatter");
        return -1;
    }
    if (res->thermal && used < CALFIT_MIN_STATIONS_THERMAL) {
        return -2;
    }
    out->tau = calfit_tau(d, k, &out->tau_settled);
    struct sensor_arrays a = {malloc(used * sizeof(double)), malloc(used * sizeof(double)),
                              malloc(used * sizeof(double))};
    int rc = a.x != NULL && a.y != NULL && a.w != NULL ? 0 : -1;
    if (rc != 0) {
        snprintf(err, errlen, "out of memory");
    }
    size_t n = 0;
    double ss = 0.0;
    double dof_within = 0.0;
    for (size_t j = 0; rc == 0 && j < d->n_stations; ++j) {
        struct calfit_station *st = &d->stations[j];
        if (!st->used[k]) {
            continue;
        }
        const double v = mean_variance(d, st, k, out->tau);
        st->mean_sd_mm[k] = sqrt(v);
        a.x[n] = st->x_mm[k];
        a.y[n] = st->mean_mm[k];
        a.w[n] = 1.0 / v;
        ++n;
        ss += st->sd_mm[k] * st->sd_mm[k] * (st->n[k] - 1u);
        dof_within += st->n[k] - 1u;
        out->readings += st->n[k];
    }
    if (rc == 0 && fit_sensor(d, k, p, res->thermal, res->cal_temp_c, a, n, out) != 0) {
        snprintf(err, errlen,
                 "sensor %c: its stations' true distances are all %.3f mm: the gain cannot be "
                 "told from the offset (singular design)",
                 name, a.x[0]);
        rc = -1;
    }
    const bool temps_known = res->thermal_state == CALFIT_THERMAL_NARROW ||
                             res->thermal_state == CALFIT_THERMAL_FEW_STATIONS;
    if (rc == 0 && !res->thermal && temps_known && res->temp_max_c - res->temp_min_c > 0.0) {
        temp_probe(d, k, p, res->cal_temp_c, a, n, out);
    }
    if (rc == 0) {
        out->motion_ratio = motion_ratio(d, k, out->tau);
    }
    out->stations = used;
    out->noise_sd_mm = sqrt(ss / dof_within);
    free(a.x);
    free(a.y);
    free(a.w);
    return rc;
}

/* Every sensor's fit: 0, -1 with err, or -2 (run_sensor's). */
static int run_sensors(struct calfit_data *d, unsigned p, struct calfit_result *res, char *err,
                       size_t errlen) {
    for (unsigned k = 0; k < CALFIT_SENSORS; ++k) {
        const int rc = run_sensor(d, k, p, res, &res->sensor[k], err, errlen);
        if (rc != 0) {
            return rc;
        }
    }
    return 0;
}

/* The stations' temperatures and whether they can give the coefficients (calfit.h). */
static void thermal_state(struct calfit_data *d, struct calfit_result *res) {
    double sum = 0.0;
    size_t with = 0;
    for (size_t j = 0; j < d->n_stations; ++j) {
        struct calfit_station *st = &d->stations[j];
        st->has_temp = st->rows > 0u && st->temp_rows == st->rows;
        st->temp_c = st->temp_rows > 0u ? st->temp_sum_c / st->temp_rows : 0.0;
        if (!st->has_temp) {
            if (res->stations_no_temp++ == 0u) {
                res->no_temp_first_line = st->first_line;
                res->no_temp_last_line = st->last_line;
            }
            continue;
        }
        res->temp_min_c = with == 0u || st->temp_c < res->temp_min_c ? st->temp_c : res->temp_min_c;
        res->temp_max_c = with == 0u || st->temp_c > res->temp_max_c ? st->temp_c : res->temp_max_c;
        sum += st->temp_c;
        ++with;
    }
    /* the stations' mean temperature, to the 0.01 °C the HEAD.cal states it with */
    res->cal_temp_c = with > 0u ? round(sum / (double)with * 100.0) / 100.0 : 0.0;
    if (d->rows_with_temp == 0u) {
        res->thermal_state = CALFIT_THERMAL_NO_TEMP;
    } else if (res->stations_no_temp > 0u) {
        res->thermal_state = CALFIT_THERMAL_SOME_MISSING;
    } else if (res->temp_max_c - res->temp_min_c < CALFIT_MIN_TEMP_SPAN_C) {
        res->thermal_state = CALFIT_THERMAL_NARROW;
    } else {
        res->thermal_state = CALFIT_THERMAL_FITTED;
        res->thermal = true;
    }
}

int calfit_run(struct calfit_data *d, struct calfit_result *res, char *err, size_t errlen) {
    memset(res, 0, sizeof *res);
    if (d->n_stations == 0u) {
        if (d->rows_partial_truth > 0u) {
            snprintf(err, errlen,
                     "no row carries all of alpha_deg, beta_deg and distance_mm (%llu rows have "
                     "some): the true distances need all three",
                     (unsigned long long)d->rows_partial_truth);
        } else {
            snprintf(err, errlen,
                     "no row carries truth (alpha_deg, beta_deg, distance_mm): nothing to fit "
                     "(a calibration trace holds a fixture's stations at known attitudes and "
                     "distances)");
        }
        return -1;
    }
    /* The gain needs two fixture distances; tilts alone move x by a·tan(α), a few mm, too
     * little to tell a gain from an offset. */
    res->gains = d->distance_max_mm - d->distance_min_mm > 1e-9;
    const unsigned p = res->gains ? 2u : 1u;
    const size_t need = res->gains ? CALFIT_MIN_STATIONS_GAIN : CALFIT_MIN_STATIONS_OFFSET;
    if (d->n_stations < need) {
        snprintf(err, errlen,
                 "%zu station%s (runs of rows with the same truth), the fit needs at least %zu",
                 d->n_stations, d->n_stations == 1u ? "" : "s", need);
        return -1;
    }
    thermal_state(d, res);
    int rc = run_sensors(d, p, res, err, errlen);
    if (rc == -2) { /* too few stations for the coefficient: every sensor without it */
        res->thermal = false;
        res->thermal_state = CALFIT_THERMAL_FEW_STATIONS;
        rc = run_sensors(d, p, res, err, errlen);
    }
    return rc == 0 ? 0 : -1;
}
