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
    return calfit_add(d, all, row->alpha_deg, row->beta_deg, row->distance_mm, raw, valid,
                      row->t_ms, line);
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

/* The fit of sensor k on its used stations (n of them, arrays a). 0 or -1 (singular). */
static int fit_sensor(struct calfit_data *d, unsigned k, unsigned p, struct sensor_arrays a,
                      size_t n, struct calfit_sensor *out) {
    double coef[2];
    double cov[3];
    if (calfit_wls(a.x, a.y, a.w, n, p, coef, cov) != 0) {
        return -1;
    }
    double chi2 = 0.0;
    double r2 = 0.0;
    double vsum = 0.0;
    size_t i = 0;
    for (size_t j = 0; j < d->n_stations; ++j) {
        struct calfit_station *st = &d->stations[j];
        if (!st->used[k]) {
            continue;
        }
        const double res = st->mean_mm[k] - (coef[0] + coef[1] * st->x_mm[k]);
        st->residual_mm[k] = res;
        chi2 += res * res * a.w[i];
        r2 += res * res;
        vsum += 1.0 / a.w[i];
        ++i;
    }
    out->dof = (uint32_t)(n - p);
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
    return 0;
}

/* Sensor k's fit with p parameters. 0, or -1 with err. */
static int run_sensor(struct calfit_data *d, unsigned k, unsigned p, struct calfit_sensor *out,
                      char *err, size_t errlen) {
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
    if (rc == 0 && fit_sensor(d, k, p, a, n, out) != 0) {
        snprintf(err, errlen,
                 "sensor %c: its stations' true distances are all %.3f mm: the gain cannot be "
                 "told from the offset (singular design)",
                 name, a.x[0]);
        rc = -1;
    }
    out->stations = used;
    out->noise_sd_mm = sqrt(ss / dof_within);
    free(a.x);
    free(a.y);
    free(a.w);
    return rc;
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
    for (unsigned k = 0; k < CALFIT_SENSORS; ++k) {
        if (run_sensor(d, k, p, &res->sensor[k], err, errlen) != 0) {
            return -1;
        }
    }
    return 0;
}
