/*
 * Window statistics over the last N rows (Alg. 1 of the first paper: "compute
 * N values of α_i, mean, cov"): per-sensor means and variances, the means of
 * α1..α5 and β1..β5 and their full 5×5 sample covariances, all from exact
 * integer sums, plus a robust per-sensor outlier gate.
 *
 * The rows live in a ring inside the caller's struct (WINDOW_MAX_SAMPLES at
 * compile time). Every reading with a valid status is added to 64-bit sums as
 * it arrives; a full ring drops its oldest row by subtracting exactly what it
 * added (recomputed from the stored ranges), so a sliding window costs O(1)
 * per row and the sums never drift. Tumbling windows call window_clear().
 *
 * The gate needs the whole window, so it runs in window_compute(): per
 * sensor, the median and the median absolute deviation (MAD) of its valid
 * readings in the window (found by bisection on the integer value between the
 * smallest and largest reading: log2(spread) counting passes, no sorting, no
 * scratch array), and a reading is rejected
 * when |x − median| > max(k·1.4826·MAD, floor). 1.4826·MAD estimates σ for
 * Gaussian noise and ignores up to half the window being outliers. Rejected
 * readings are subtracted from a copy of the sums, again exactly.
 *
 * Calibration: the ring keeps the readings as they came (whole mm, 10 bytes a
 * row); each row's angles and residual are computed from its readings corrected to
 * true = (raw − offset)/gain in fine units (angles.h, 2^-10 mm), recomputed exactly the
 * same way when the row is dropped or gated out; the per-sensor mean and variance are
 * corrected at the window's end (the correction is affine: exact from the raw sums).
 *
 * Which rows count: a sensor's reading is used when present, status 0 and not
 * rejected. α_i (β_i) uses the rows where both its sensors are used. The 5×5
 * covariances (what the paper's consensus needs) use the complete rows, where
 * all four sensors are used, so that every entry comes from the same samples.
 */
#ifndef ESTIMATOR_WINDOW_STATS_H
#define ESTIMATOR_WINDOW_STATS_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/angles.h"
#include "estimator/fixmath.h"

/* Largest window N. Sums of α_i·α_j (|α| < 90° = 9e7 udeg) over 1024 rows stay
 * below 8.3e18 < 2^63, so 1024 is the hard limit of exact 64-bit sums. */
#ifndef WINDOW_MAX_SAMPLES
#define WINDOW_MAX_SAMPLES 256u
#endif
#define WINDOW_MIN_SAMPLES 2u

/* Packed upper triangle of a 5×5 symmetric matrix: 15 entries. */
#define WINDOW_PAIRS 15u

/* Errors of window_init (negative, one per bad field), in the window's block -32..-47 of
 * the one error convention (docs/reference/errors.md). */
enum window_error {
    WINDOW_OK = 0,
    WINDOW_ERR_ARM = -32,    /* arm_um outside [ANGLES_ARM_MIN_UM, ANGLES_ARM_MAX_UM] */
    WINDOW_ERR_LENGTH = -33, /* length outside [WINDOW_MIN_SAMPLES, WINDOW_MAX_SAMPLES] */
};

struct window_config {
    int32_t arm_um;          /* a, micrometres */
    uint16_t length;         /* N rows */
    uint16_t gate_sigmas_q8; /* k x 256 of the MAD gate; 0 disables the gate */
    uint16_t gate_floor_mm;  /* the gate never rejects |x − median| <= this */
    /* The head's calibration (estimator/calibration.h: raw = gain · true + offset), applied
     * to every reading: offset in µm and gain − 1 in ppm, within CALIBRATION_OFFSET_MAX_UM
     * and CALIBRATION_GAIN_MAX_PPM (the caller checks). All 0: the readings as they are. */
    int32_t offset_um[ANGLES_SENSORS];
    int32_t gain_ppm[ANGLES_SENSORS];
};

/* One stored row: 10 bytes, so the ring of WINDOW_MAX_SAMPLES rows stays within the
 * interface MCU's RAM budget (docs/explanation/firmware.md). */
struct window_row {
    uint16_t range_mm[ANGLES_SENSORS];
    uint8_t masks; /* sensor masks: low nibble present (a reading arrived), high nibble
                      valid (present with status 0); read them with the two functions below */
    uint8_t aux;   /* free for the caller (the facade stores Kalman outcomes here) */
};

/* The sensors of a row that delivered a reading. */
static inline uint8_t window_row_present(const struct window_row *row) {
    return (uint8_t)(row->masks & 0x0Fu);
}

/* The sensors of a row with a status-0 reading (a subset of the present ones). */
static inline uint8_t window_row_valid(const struct window_row *row) {
    return (uint8_t)(row->masks >> 4);
}

/*
 * The exact sums of the rows held. β1..β4 are exact negations or copies of α values
 * (angles.h: β1 = −α2, β2 = α4, β3 = α1, β4 = −α3), so only α1..α5 and β5 are summed;
 * window_compute() derives the β statistics from them. Sums of products cover the
 * complete rows (all four readings used); the other rows add to the per-angle sums
 * only. |α| < 9e7 udeg, so every product sum over <= 1024 rows is below 8.3e18 < 2^63.
 */
struct window_sums {
    uint32_t sum_mm[ANGLES_SENSORS];
    uint64_t sum_sq_mm2[ANGLES_SENSORS];
    uint16_t count[ANGLES_SENSORS];
    uint16_t complete;                   /* rows with all four readings used */
    int64_t residual_sum_fine;           /* Σ(x_A + x_C − x_B − x_D), complete rows, fine
                                            units of the corrected readings */
    int64_t alpha_sum[ANGLES_PER_AXIS];  /* Σα_i, complete rows */
    int64_t alpha_prod[WINDOW_PAIRS];    /* Σα_iα_j, complete rows, i <= j packed */
    int64_t beta5_sum;                   /* Σβ5, complete rows */
    int64_t beta5_prod[ANGLES_PER_AXIS]; /* Σβ5·α1..Σβ5·α4 and Σβ5², complete rows */
    int64_t partial_alpha_sum[ANGLES_PER_AXIS]; /* Σα_i over the incomplete rows where valid */
    uint16_t partial_alpha_count[ANGLES_PER_AXIS];
    uint16_t partial_beta5_count;
    int64_t partial_beta5_sum;
};

struct window_state {
    struct window_config cfg;
    struct angles_arm arm; /* cfg.arm_um prepared for the per-row angles */
    /* the calibration prepared for the per-row correction (window_correct): the offset in
     * fine units and 1/gain − 1 in Q32, so true = d + d·r/2^32 with d = raw − offset */
    int32_t cal_offset_fine[ANGLES_SENSORS];
    int32_t cal_base_offset_fine[ANGLES_SENSORS]; /* ... the calibration's own, at its
                                                     temperature (window_shift_offsets) */
    int32_t cal_inv_gain_q32[ANGLES_SENSORS];
    int64_t cal_inv_gain2_q32[ANGLES_SENSORS]; /* 1/gain² − 1 in Q32: the variances' */
    int32_t newest_fine[ANGLES_SENSORS];       /* the newest row's corrected readings, fine units */
    uint16_t newest_mm[ANGLES_SENSORS];        /* ... in whole mm with the previous rows'
                                                  rounding carried (0 below 0): what a consumer
                                                  of whole mm (the Kalman filter) takes */
    uint32_t newest_carry[ANGLES_SENSORS];     /* the rounding left over, fine units + 1/2 mm:
                                                 0 .. 1023 (window_internal.h) */
    struct window_row ring[WINDOW_MAX_SAMPLES];
    uint16_t oldest;          /* ring index of the oldest row */
    uint16_t fill;            /* rows held, <= cfg.length */
    struct window_sums sums;  /* every status-valid reading of the rows held */
    struct window_sums gated; /* scratch of window_compute: sums after the gate */
};

/* Per sensor: the statistics of the corrected readings (mean, variance); the gate (median,
 * half-width) works on the readings as they came. */
struct window_sensor_stats {
    uint16_t used;        /* present, status 0, not rejected */
    uint16_t flagged;     /* present with a non-zero range status */
    uint16_t missing;     /* no reading at all */
    uint16_t rejected;    /* status 0 but outside the gate */
    fix_q32_t mean_mm;    /* mean of the used readings (0 if none) */
    fix_q32_t var_mm2;    /* their sample variance, n − 1 (0 if fewer than 2) */
    int32_t median_x2_mm; /* 2 × median of the status-valid readings (gate centre) */
    int32_t gate_x2_mm;   /* 2 × the gate half-width actually applied (0: gate off) */
};

struct window_axis_stats {
    fix_udeg_q16_t mean[ANGLES_PER_AXIS]; /* per-estimate mean over its own rows */
    uint16_t count[ANGLES_PER_AXIS];
    fix_udeg_q16_t complete_mean[ANGLES_PER_AXIS]; /* means over complete rows */
    int64_t cov[ANGLES_PER_AXIS][ANGLES_PER_AXIS]; /* udeg², complete rows, n − 1, rounded */
};

struct window_stats {
    uint16_t rows;     /* rows in the window */
    uint16_t complete; /* rows with all four readings used */
    struct window_sensor_stats sensor[ANGLES_SENSORS];
    struct window_axis_stats alpha;
    struct window_axis_stats beta;
    bool residual_valid; /* complete > 0 */
    int32_t residual_um; /* mean flatness residual over complete rows */
};

/* Checks cfg and starts an empty window. Returns WINDOW_OK or the window_error
 * naming the bad field (w is then unusable). */
int window_init(struct window_state *w, const struct window_config *cfg);

/* Empties the window (the start of a tumbling window). */
void window_clear(struct window_state *w);

/* Appends one row: ranges of A..D, the sensors that delivered a reading and
 * those among them with status 0. A full window first drops its oldest row.
 * Returns the new row (window_row_at(w, 0)). */
struct window_row *window_push(struct window_state *w, const uint16_t range_mm[ANGLES_SENSORS],
                               uint8_t present_mask, uint8_t valid_mask);

/* Moves each sensor's offset to the calibration's plus shift_fine[k] (fine units: the offsets'
 * change with temperature, estimator/calibration.h) for every row held and to come: the held
 * rows' sums are summed again with it, so a row dropped later still subtracts exactly what it
 * added. O(rows held); free on an empty window. */
void window_shift_offsets(struct window_state *w, const int32_t shift_fine[ANGLES_SENSORS]);

/* Rows currently held (0..length). */
uint16_t window_fill(const struct window_state *w);

/* The row `age` rows back (0 = newest); NULL if age >= window_fill(). */
struct window_row *window_row_at(struct window_state *w, uint16_t age);

/* Gates the window and computes its statistics into out. O(N) with the gate (per
 * sensor one min/max pass and about 3·log2(spread) counting passes), otherwise O(1)
 * plus the divisions. */
void window_compute(struct window_state *w, struct window_stats *out);

/* Index of (i, j) in the packed upper triangle, any order, i, j < 5. */
unsigned window_pair_index(unsigned i, unsigned j);

#endif /* ESTIMATOR_WINDOW_STATS_H */
