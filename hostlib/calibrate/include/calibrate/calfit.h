/*
 * `host_sim calibrate`'s fit (docs/explanation/architecture.md, §6;
 * docs/how-to/calibrate-a-head.md): each sensor's offset and gain in raw_i = gain_i · x_i +
 * offset_i + noise from a fixture's stations (a flat plate at known α, β and x̄, x_i from §2's
 * geometry), with their covariance from the data.
 *
 * Rows are added one at a time; a station is a run of consecutive rows with the same
 * truth (α, β, x̄); a row without truth (the fixture moving) ends the station. Each
 * sensor is fitted on its own, from its station means, by weighted least squares:
 *  - a station's mean has variance s² · τ / n: s² the readings' scatter about the station
 *    mean, n the valid readings, τ the sensor's integrated autocorrelation time (pooled over
 *    its stations, Sokal's self-consistent window M >= 5τ, floored at 1), so correlated
 *    noise does not shrink the sd (n / τ is the effective sample size);
 *  - the means' scatter about the fit is compared with those variances: the reduced
 *    chi-square χ²/(J − p) (J stations, p parameters), floored at 1, multiplies the
 *    covariance (drift during the run, fixture errors, anything the noise does not explain).
 * With one fixture distance only the gain is not determined: the offsets are fitted with
 * gain 1 (p = 1) and no gain is stated.
 *
 * Temperature (docs/how-to/calibrate-a-head.md, "Temperature"): a station's temperature is the
 * mean of its rows' measured temp_c. When every station has one (every row of it) and they
 * span at least CALFIT_MIN_TEMP_SPAN_C, each sensor's offset temperature coefficient k is fitted
 * jointly: mean = gain · x + offset + k · (T − cal_temp), cal_temp the stations' mean
 * temperature (to 0.01 °C), so the offset holds there and its error is nearly independent of
 * k's. Otherwise the coefficient is unknown (calfit_result.thermal_state says why) and nothing
 * about it is stated; a coefficient fitted on a narrow span would be mostly noise and a wrong
 * sign at worst, which the estimator's sd could not know.
 */
#ifndef CALIBRATE_CALFIT_H
#define CALIBRATE_CALFIT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "scene/row.h"

#define CALFIT_SENSORS             4u
#define CALFIT_MIN_READINGS        10u /* valid readings a sensor needs at a station to use it */
#define CALFIT_MIN_STATIONS_GAIN   3u  /* gain and offset, and one degree of freedom for scatter */
#define CALFIT_MIN_STATIONS_OFFSET 2u
#define CALFIT_MAX_LAG             2000u /* autocorrelation lags examined at most (40 s at 20 ms) */
#define CALFIT_VAR_FLOOR_MM2       1e-12 /* numerical floor of a station mean's variance */
/* The stations' temperatures must span this for a coefficient. The fit's own sd falls as
 * 1/span (fixture-thermal, 30 stations x 300 readings: 0.0052 mm/°C at 10.5 °C, 0.0019 at
 * 30 °C), and the sd carries it; what the sd cannot carry is an error of the stations'
 * temperatures themselves (the unit's sensor reads the board, the parts lag or lead it by a
 * degree or two), whose share of the coefficient is that error over the span: 10-20 % at
 * 10 °C, a third and more at a room's 6 °C. */
#define CALFIT_MIN_TEMP_SPAN_C      10.0
#define CALFIT_MIN_STATIONS_THERMAL 4u /* gain, offset, coefficient and one for the scatter */

struct calfit_station {
    double alpha_deg, beta_deg, distance_mm; /* the truth */
    uint32_t first_line, last_line;          /* trace lines (0 when not from a file) */
    uint32_t t_first_ms, t_last_ms;
    uint32_t rows;
    /* per sensor */
    size_t first[CALFIT_SENSORS]; /* its first reading in calfit_data.readings[k] */
    uint32_t n[CALFIT_SENSORS];   /* valid readings */
    double x_mm[CALFIT_SENSORS];  /* true distance, docs/explanation/architecture.md */
    /* filled by calfit_run */
    bool used[CALFIT_SENSORS];          /* n >= CALFIT_MIN_READINGS */
    double mean_mm[CALFIT_SENSORS];     /* mean reading */
    double sd_mm[CALFIT_SENSORS];       /* readings' sd about the mean */
    double mean_sd_mm[CALFIT_SENSORS];  /* sd of the mean: sd · sqrt(τ / n), floored */
    double residual_mm[CALFIT_SENSORS]; /* mean − (gain · x + offset [+ k (T − cal_temp)]) */
    uint32_t temp_rows;                 /* rows with a temperature */
    double temp_sum_c;
    bool has_temp; /* every row has one (filled by calfit_run) */
    double temp_c; /* their mean (filled by calfit_run) */
};

struct calfit_data {
    double arm_mm;
    double quantum_mm; /* readings' resolution: 1 for traces (whole mm), 0 for exact values */
    struct calfit_station *stations;
    size_t n_stations, cap_stations;
    double *readings[CALFIT_SENSORS];
    size_t n_readings[CALFIT_SENSORS], cap_readings[CALFIT_SENSORS];
    bool open; /* the last station may still grow */
    /* the rows seen */
    uint64_t rows, rows_no_truth, rows_partial_truth;
    uint64_t invalid[CALFIT_SENSORS]; /* readings not valid (status != 0 or none) in stations */
    uint64_t rows_with_invalid;       /* rows of stations with any reading not valid */
    double distance_min_mm, distance_max_mm;
    uint64_t rows_with_temp; /* station rows with a temperature */
};

struct calfit_sensor {
    double offset_mm, offset_sd_mm, gain, gain_sd;
    double corr;                /* correlation of the offset's and the gain's errors (0: no gain) */
    double offset_sd_within_mm; /* the offset's sd from the station noise alone (no inflation) */
    double noise_sd_mm;         /* pooled readings' sd within stations */
    double tau;                 /* integrated autocorrelation time, readings (>= 1) */
    bool tau_settled;           /* Sokal's window found within CALFIT_MAX_LAG */
    uint32_t stations;          /* stations used */
    uint64_t readings;          /* valid readings in them */
    double chi2, chi2_red;      /* station means about the fit; chi2_red = chi2 / dof */
    uint32_t dof;
    double inflation;       /* max(1, chi2_red): the covariance's factor */
    double residual_rms_mm; /* RMS of the station means' residuals */
    double excess_sd_mm;    /* sd between stations beyond the noise (0 if none) */
    /* thermal: the coefficient, mm/°C, its sd (inflated as the others) and its error's
     * correlation with the offset's and the gain's */
    double temp_coeff_mm_per_c, temp_coeff_sd_mm_per_c, corr_offset_coeff, corr_gain_coeff;
    /* Diagnostics for a scatter the model does not explain (all 0 when not computed):
     * a coefficient fitted although the span is too narrow to state it (every station with a
     * temperature, not thermal, span > 0): its t (k over its sd) and the scatter ratio with it */
    bool temp_probe;
    double temp_probe_mm_per_c, temp_probe_t, temp_probe_ratio;
    /* each station's first and second half means compared with their sd (τ included): the
     * mean of z² over the stations, about 1 when the readings hold still within a station */
    double motion_ratio;
};

enum calfit_thermal_state {
    CALFIT_THERMAL_FITTED,       /* coefficients fitted */
    CALFIT_THERMAL_NO_TEMP,      /* no station row has a temperature (no temp_c column) */
    CALFIT_THERMAL_SOME_MISSING, /* some stations lack one (rows without temp_c) */
    CALFIT_THERMAL_NARROW,       /* the span is below CALFIT_MIN_TEMP_SPAN_C */
    CALFIT_THERMAL_FEW_STATIONS, /* a sensor has fewer than CALFIT_MIN_STATIONS_THERMAL */
};

struct calfit_result {
    bool gains; /* false: one distance, offsets only (gain 1, no gain stated) */
    bool thermal;
    enum calfit_thermal_state thermal_state;
    double cal_temp_c;             /* thermal: where the offsets hold (stations' mean, 0.01 °C) */
    double temp_min_c, temp_max_c; /* the stations' temperatures (those that have one) */
    size_t stations_no_temp;       /* stations with a row without temperature */
    uint32_t no_temp_first_line, no_temp_last_line; /* the first such station's lines */
    struct calfit_sensor sensor[CALFIT_SENSORS];
};

/* Empty data for a head with arm arm_mm (> 0) whose readings have resolution quantum_mm. */
void calfit_init(struct calfit_data *d, double arm_mm, double quantum_mm);

/* Frees what calfit_add_* allocated. */
void calfit_free(struct calfit_data *d);

/*
 * One row: readings raw[k] (used when valid[k]) and its truth if has_truth. A row whose
 * truth differs from the open station's starts a new station; a row without truth
 * (has_truth false) closes it. line and t_ms are kept for the report. Returns 0, or -1
 * when out of memory.
 */
int calfit_add(struct calfit_data *d, bool has_truth, double alpha_deg, double beta_deg,
               double distance_mm, const double raw[CALFIT_SENSORS],
               const bool valid[CALFIT_SENSORS], uint32_t t_ms, uint32_t line);

/* calfit_add with the row's measured head temperature (has_temp false: none). */
int calfit_add_temp(struct calfit_data *d, bool has_truth, double alpha_deg, double beta_deg,
                    double distance_mm, const double raw[CALFIT_SENSORS],
                    const bool valid[CALFIT_SENSORS], bool has_temp, double temp_c, uint32_t t_ms,
                    uint32_t line);

/* calfit_add for a trace row (its temp_c too): truth when alpha, beta and distance are all present
 * (a row with some but not all is counted in rows_partial_truth, not in rows_no_truth, and not
 * used; it ends the open station as a row without truth does). */
int calfit_add_row(struct calfit_data *d, const struct scene_row *row, uint32_t line);

/*
 * The fit. Returns 0 with *res, or -1 with what is missing or cannot be determined in err
 * (no station, too few stations for a sensor, its stations' true distances all equal).
 */
int calfit_run(struct calfit_data *d, struct calfit_result *res, char *err, size_t errlen);

/* ---- statistics (calfit_stats.c) ---- */

/* Sensor k's integrated autocorrelation time over the used stations (their readings about
 * their own means), Sokal's window; *settled false when not found within the lags. */
double calfit_tau(const struct calfit_data *d, unsigned k, bool *settled);

/* Weighted least squares of y on x (w the weights, p = 2 with a gain, 1 without: gain 1):
 * coef[0] offset, coef[1] gain; cov[0] var offset, cov[1] cov, cov[2] var gain (unscaled).
 * Returns 0, or -1 when singular. */
int calfit_wls(const double *x, const double *y, const double *w, size_t n, unsigned p,
               double coef[2], double cov[3]);

#define CALFIT_WLS_MAX_P 4u

/* Weighted least squares of y on p <= CALFIT_WLS_MAX_P features (f[i * p + j]: feature j of
 * observation i): coef[p], cov[p * p] the unscaled covariance (the normal matrix's inverse).
 * Returns 0, or -1 when singular. */
int calfit_wls_general(const double *f, const double *y, const double *w, size_t n, unsigned p,
                       double *coef, double *cov);

#endif /* CALIBRATE_CALFIT_H */
