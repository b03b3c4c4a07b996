/*
 * The estimator facade: the firmware calls attitude_push_sample() once per
 * four-sensor sample and gets, whenever a window is complete, the attitude
 * from each of the four estimators of docs/reference/tools.md:
 *
 *   consensus        the product's consensus rule (estimator/consensus.h)
 *   consensus-paper  the first paper's published weighting, with its failures
 *                    reported as statuses
 *   kalman           the 3-state Kalman filter of Eq. 5 (estimator/kalman.h)
 *   mean             the plain average of the five angle estimates
 *
 * Windows are counted in rows: window k covers rows kN .. kN+N−1 whatever the
 * readings' statuses. Tumbling mode reports once per window, at its last row,
 * and resets the statistics and the Kalman filter at its first row (the
 * paper's static-window protocol). Sliding mode reports at every row from row
 * N−1 on, over the last N rows, and nothing before (the first N−1 rows return
 * false); its Kalman filter runs continuously (never reset: give it process
 * noise Q if the plate moves), and the Kalman noise tracking learns from each
 * block of N rows.
 *
 * Everything is integer: angles in micro-degrees, distances in micrometres,
 * so the host and a Cortex-M image produce byte-identical text. No heap, no
 * globals: all state lives in the caller's struct attitude_state (about 5 KiB
 * with the default WINDOW_MAX_SAMPLES = 256).
 */
#ifndef ESTIMATOR_ATTITUDE_H
#define ESTIMATOR_ATTITUDE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "estimator/attitude_why.h"
#include "estimator/calibration.h"
#include "estimator/consensus.h"
#include "estimator/integrity.h"
#include "estimator/kalman.h"
#include "estimator/window_stats.h"

#define ATTITUDE_SENSORS    4u                 /* A, B, C, D */
#define ATTITUDE_WINDOW_MAX WINDOW_MAX_SAMPLES /* compile-time maximum N */

enum attitude_estimator {
    ATTITUDE_EST_CONSENSUS = 0, /* "consensus": the product rule */
    ATTITUDE_EST_PAPER = 1,     /* "consensus-paper" */
    ATTITUDE_EST_KALMAN = 2,    /* "kalman" */
    ATTITUDE_EST_MEAN = 3,      /* "mean" */
    ATTITUDE_EST_COUNT = 4,
};
#define ATTITUDE_EST_BIT(e) ((uint8_t)(1u << (unsigned)(e)))
#define ATTITUDE_EST_ALL    ((uint8_t)0x0Fu)
/* The estimators compiled into this image (a mask of ATTITUDE_EST_BIT; default all
 * four). A flight image built with fewer (the NUCLEO-L476RG: consensus and kalman,
 * cmake/toolchain/board-nucleo-l476rg.cmake) links none of the others' code;
 * attitude_init() rejects a configuration selecting one of them. */
#ifndef ATTITUDE_EST_BUILT
#define ATTITUDE_EST_BUILT ATTITUDE_EST_ALL
#endif

enum attitude_window_mode { ATTITUDE_TUMBLING = 0, ATTITUDE_SLIDING = 1 };

enum attitude_status {
    ATTITUDE_OK = 0,       /* all four sensors, every reading of the window used */
    ATTITUDE_DEGRADED = 1, /* estimated from fewer sensors or around flagged data */
    ATTITUDE_INVALID = 2,  /* no estimate: see the reason; the invalid axes read 0 */
};

/* Longest text attitude_why_format() can write, terminator included (every bit set). */
#define ATTITUDE_WHY_TEXT_MAX 569u

/* Errors of attitude_init, one per configuration field (negative), in the attitude
 * block -64..-79 of the one error convention (docs/reference/errors.md). */
enum attitude_error {
    ATTITUDE_ERR_NONE = 0,
    ATTITUDE_ERR_ARM = -64,                  /* arm_um outside [1000, 1000000] */
    ATTITUDE_ERR_WINDOW = -65,               /* window outside [2, ATTITUDE_WINDOW_MAX] */
    ATTITUDE_ERR_MODE = -66,                 /* mode neither tumbling nor sliding */
    ATTITUDE_ERR_ESTIMATORS = -67,           /* estimators empty, with unknown bits or not built */
    ATTITUDE_ERR_TOLERANCE = -68,            /* consensus_tolerance_udeg outside [1, 10000000] */
    ATTITUDE_ERR_PAPER_ITERATIONS = -69,     /* paper_max_iterations is 0 */
    ATTITUDE_ERR_KALMAN_PROCESS_NOISE = -70, /* a process noise the filter refuses
                                                (kalman_config_check) */
    ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE = -71, /* a kalman_initial_noise_um2 below the
                                                    1/12 mm² of 1 mm rounding */
    ATTITUDE_ERR_KALMAN_WARMUP = -72,            /* kalman_warmup_rows outside 1..8 */
    ATTITUDE_ERR_KALMAN_NOISE_SHIFT = -73,       /* kalman_noise_shift above 8 */
    ATTITUDE_ERR_NULL = -74,                     /* a NULL pointer */
    ATTITUDE_ERR_INTEGRITY = -75,   /* an integrity field out of range (estimator/integrity.h) */
    ATTITUDE_ERR_BUFFER = -76,      /* attitude_why_format: the buffer is too small */
    ATTITUDE_ERR_CALIBRATION = -77, /* a calibrated head's offset, gain or sd beyond the
                                       bounds of estimator/calibration.h */
};

struct attitude_config {
    int32_t arm_um;                       /* a: each sensor's distance from the centre */
    uint16_t window;                      /* N rows per window */
    enum attitude_window_mode mode;       /* tumbling or sliding */
    uint8_t estimators;                   /* ATTITUDE_EST_BIT() mask of what to compute */
    int32_t consensus_tolerance_udeg;     /* spread tolerance of both consensus rules */
    uint16_t paper_max_iterations;        /* cap of the paper's iteration (it gives none) */
    uint16_t paper_consistency_sigmas_q8; /* flag a paper value farther than k·σ + tol
                                             from the product estimate; 0: no check */
    uint16_t gate_sigmas_q8; /* window gate: reject |x − median| > k·1.4826·MAD; 0: off */
    uint16_t gate_floor_mm;  /* ... but never closer than this */
    uint32_t kalman_process_noise_um2[KALMAN_STATES];    /* Q per row: x̄, a·tan α, a·tan β */
    uint32_t kalman_initial_noise_um2[ATTITUDE_SENSORS]; /* R until the first window, >= 83334 */
    uint16_t kalman_gate_sigmas_q8;                      /* innovation gate k; 0: off */
    uint8_t kalman_warmup_rows;                          /* robust start: rows buffered */
    uint8_t kalman_noise_shift;                          /* R tracking gain 2^-shift per window */
    bool kalman_process_noise_auto; /* Q (from kalman_process_noise_um2) and R learned by
                                       the filter (estimator/kalman.h) */
    /* Integrity (estimator/integrity.h, docs/explanation/estimators.md "Integrity"): */
    uint16_t range_max_mm;        /* a reading above this is `range:X` (the mode's range) */
    uint16_t parity_sigmas_q8;    /* parity test threshold k·256 (false-alarm rate there) */
    uint16_t motion_sigmas_q8;    /* motion test threshold k·256 */
    uint16_t offset_stability_um; /* prior 1σ of each sensor's offset, not learnable */
    uint16_t drift_flag_um;       /* learnt per-sensor drift 1σ above this: `drift` */
    uint8_t drift_shift;          /* drift learning gain 2^-shift per block of N rows */
    uint32_t period_us;           /* the row period, µs (1000..10000000): time for the drift
                                     allowance, which grows with rows × period since start */
    uint32_t offset_walk_um2_h;   /* prior random-walk rate of each sensor's offset, µm² per
                                     hour (0: none): the unseen drift's growth */
    uint32_t max_rate_mdeg_s;     /* the plate's rate bound, m°/s (a mission setting; 0: a
                                     plate known to be still, a fixture): α and β carry
                                     the lag a ramp at up to this rate leaves in a window
                                     (estimator/integrity.h); 0..360000 */
    uint16_t temp_sd_cdeg;        /* 1σ of the measured temperature as the parts' own, 0.01 °C
                                     (0..10000): a thermal calibration's correction carries
                                     coefficient × this in its sd (the sensor's error and
                                     its distance from the parts: docs/how-to/calibrate-a-head.md,
                                     "Temperature") */
    uint32_t calibration_age_s;   /* the calibration's age at attitude_init, seconds: the
                                     prior walk grows over it plus rows × period (the unit
                                     keeps it across resets: firmware/cal_age.h); 0: none */
    /* The head's calibration (estimator/calibration.h), applied to every reading before
     * any estimator: calibrated false is an uncalibrated head, never `ok` (why
     * `uncalibrated`; offset 0, gain 1, the parts' spread CALIBRATION_UNCAL_* in every
     * sd, and its other fields ignored). Read by attitude_init() only: a new calibration
     * takes effect through a new attitude_init(). Checked when calibrated: |offset_um|
     * and offset_sd_um <= CALIBRATION_OFFSET_MAX_UM, |gain_ppm| and gain_sd_ppm <=
     * CALIBRATION_GAIN_MAX_PPM (else ATTITUDE_ERR_CALIBRATION). */
    struct calibration_head calibration;
};

/* Counts over the rows of the window, per sensor. */
struct attitude_sensor_counts {
    uint16_t used;     /* readings that went into the estimate */
    uint16_t flagged;  /* non-zero range status */
    uint16_t missing;  /* no reading (present flag false) */
    uint16_t rejected; /* status 0 but gated out as an outlier */
};

struct attitude_estimate {
    enum attitude_status status;
    enum attitude_reason reason;
    bool alpha_valid; /* the α value is an estimate (else 0) */
    bool beta_valid;
    bool distance_valid;
    int32_t alpha_udeg;       /* rotation about z, micro-degrees */
    int32_t beta_udeg;        /* rotation about y, micro-degrees */
    int32_t distance_um;      /* mean distance x̄, micrometres */
    int32_t alpha_sigma_udeg; /* white-noise 1σ the estimator itself predicts (consensus,
                                 kalman); 0: not provided. alpha_sd_udeg is the honest one */
    int32_t beta_sigma_udeg;
    /* One standard deviation of the error against the attitude at the row's time: the
     * window's white noise, the learnt drift, the offset-stability prior, the 1 mm
     * quantisation and any motion inside the window (docs/explanation/estimators.md
     * "Integrity"). Meaningful only with the matching *_valid flag, then >= 1; an axis
     * that cannot be observed has no sd (the field reads 0, never a claimed sd of 0). */
    int32_t alpha_sd_udeg;
    int32_t beta_sd_udeg;
    int32_t distance_sd_um;
    attitude_why_t why;        /* the reasons for anything not ok (empty when ok) */
    uint16_t alpha_iterations; /* consensus iterations (0 for kalman and mean) */
    uint16_t beta_iterations;
    bool flatness_valid;          /* some row had all four readings */
    int32_t flatness_residual_um; /* window mean of x_A + x_C − x_B − x_D */
    struct attitude_sensor_counts counts[ATTITUDE_SENSORS];
};

struct attitude_output {
    uint32_t first_row; /* trace row (0-based) the window starts at */
    uint32_t last_row;  /* ... and ends at: the row this estimate belongs to */
    uint16_t rows;      /* N */
    struct attitude_estimate est[ATTITUDE_EST_COUNT]; /* indexed by enum attitude_estimator */
};

struct attitude_state {
    struct attitude_config cfg;
    struct window_state window;
    struct window_stats stats; /* scratch of the last window */
    struct kalman_state kalman;
    uint32_t rows;                      /* rows pushed since attitude_init */
    uint32_t kalman_rows_since_restart; /* since the filter last restarted (UINT32_MAX: never) */
    bool kalman_restart_due;            /* restart before the next row (R guessed wrong) */
    uint8_t kalman_lag_blocks;          /* blocks in the learnt lag below (saturating) */
    int64_t kalman_lag_udeg[2];         /* learnt: mean over blocks of the filter minus the
                                           window's end point, α and β (µdeg) */
    int64_t kalman_lag_var_udeg2[2];    /* ... and that mean's noise variance (µdeg²) */
    struct integrity_config icfg;
    struct integrity_state integrity; /* learnt drift */
    struct integrity_window iw;       /* scratch: the last window's integrity facts */
    int32_t extra_udeg[2];            /* ... what they add to α and β, as 1σ in µdeg */
    bool cal_spread;   /* the calibration leaves an sd (uncalibrated, or a stated sd) */
    bool temp_known;   /* the rows being pushed have a measured temperature ... */
    int16_t temp_cdeg; /* ... this one, 0.01 °C (attitude_set_temperature) */
    /* A thermal calibration's correction (attitude_thermal.c): each offset's change per
     * 0.01 °C in fine units, Q32; and the temperature distance from the calibration's that the
     * window's offsets are at (0 until a temperature was measured). */
    int64_t thermal_fine_q32[ATTITUDE_SENSORS];
    int32_t thermal_dt_cdeg;
    bool thermal_in_force;         /* a temperature was measured since attitude_init */
    uint32_t thermal_unknown_rows; /* rows since the last one (saturating) */
};

/* Integrity defaults (sources in docs/explanation/estimators.md "Integrity"):
 * range 4000 mm: the VL53L1X long-distance mode's maximum (UM2356 Table 1); the
 * VL53L0X's long-range mode reaches 2000 mm, so a VL53L0X build may lower it.
 * parity and motion k = 4: two-sided Gaussian false-alarm rate 6.3e-5 per window.
 * offset stability 120 um: the excess over white noise of the change between consecutive
 * 2 s window means of one real static VL53L0X over one hour (the tomisuarez2 log of
 * ../shared/traces/external: 0.015 mm² beyond 0.045 mm²), drift no single window sees.
 * drift flag 500 um: a learnt per-sensor drift above 0.5 mm 1σ, a quarter of the
 * VL53L0X's white noise (2.1 mm 1σ on the same log).
 * period 20 000 us: the firmware's 50 Hz (firmware/src/config.c); host_sim and the twin
 * set the trace's own.
 * offset walk 576 000 um²/h (160 um²/s): the random-walk slope of the same log's Allan
 * variance of block means, tau 36 s .. 15 min (tools/drift_allan.py; docs/explanation/estimators.md
 * "Integrity", "Drift since the start"): 0.76 mm 1σ after an hour, 1.5 mm after four.
 * rate bound 1000 m°/s: a plate turning at 1°/s at most. Docking standards bound contact
 * rates at about 0.2°/s per axis (the International Docking System Standard's capture
 * envelope); a bench plate turned by hand reaches 10°/s: a mission sets its own. */
#define ATTITUDE_RANGE_MAX_MM_DEFAULT        4000u
#define ATTITUDE_PARITY_SIGMAS_Q8_DEFAULT    (4u * 256u)
#define ATTITUDE_MOTION_SIGMAS_Q8_DEFAULT    (4u * 256u)
#define ATTITUDE_OFFSET_STABILITY_UM_DEFAULT 120u
#define ATTITUDE_DRIFT_FLAG_UM_DEFAULT       500u
#define ATTITUDE_PERIOD_US_DEFAULT           20000u
#define ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT   576000u
#define ATTITUDE_MAX_RATE_MDEG_S_DEFAULT     1000u
/* 1 °C: the STM32L4 sensor read against its two factory points (TS_CAL1, TS_CAL2; RM0351
 * "Temperature sensor") is within a degree or two of the die, and the die of a board beside
 * the head within a degree of the parts when neither dissipates much (an assumption a
 * mission checks: docs/how-to/calibrate-a-head.md, "Temperature"). */
#define ATTITUDE_TEMP_SD_CDEG_DEFAULT 100u

/*
 * The default configuration as an initializer, so a const configuration (the
 * firmware's) can embed it: a = 30 mm, N = 100, tumbling, every estimator built,
 * tolerance 1000 udeg (the paper's 1e-3 deg), 200 paper iterations, paper
 * consistency 1.5σ (a paper value merely noisier than the efficient product differs
 * from it by sqrt(var_paper − var_product) ≈ 0.3σ (Hausman), so 1.5σ + tol flags only
 * values the paper's weights pulled off), MAD gate 5σ with a 3 mm floor, Kalman Q = 0,
 * R = (2 mm)² (the paper's jitter), innovation gate 5σ, 5 warm-up rows, noise shift 2,
 * and no calibration: an uncalibrated head, never `ok` (set .calibration to fly).
 */
#define ATTITUDE_CONFIG_DEFAULT                                                                    \
    {                                                                                              \
        .arm_um = 30000, .window = 100, .mode = ATTITUDE_TUMBLING,                                 \
        .estimators = ATTITUDE_EST_BUILT, .consensus_tolerance_udeg = 1000,                        \
        .paper_max_iterations = 200, .paper_consistency_sigmas_q8 = 384u,                          \
        .gate_sigmas_q8 = 5u * 256u, .gate_floor_mm = 3, .kalman_process_noise_um2 = {0, 0, 0},    \
        .kalman_initial_noise_um2 = {4000000u, 4000000u, 4000000u, 4000000u},                      \
        .kalman_gate_sigmas_q8 = 5u * 256u, .kalman_warmup_rows = 5, .kalman_noise_shift = 2,      \
        .range_max_mm = ATTITUDE_RANGE_MAX_MM_DEFAULT,                                             \
        .parity_sigmas_q8 = ATTITUDE_PARITY_SIGMAS_Q8_DEFAULT,                                     \
        .motion_sigmas_q8 = ATTITUDE_MOTION_SIGMAS_Q8_DEFAULT,                                     \
        .offset_stability_um = ATTITUDE_OFFSET_STABILITY_UM_DEFAULT,                               \
        .drift_flag_um = ATTITUDE_DRIFT_FLAG_UM_DEFAULT, .drift_shift = 4,                         \
        .period_us = ATTITUDE_PERIOD_US_DEFAULT,                                                   \
        .offset_walk_um2_h = ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT,                                   \
        .max_rate_mdeg_s = ATTITUDE_MAX_RATE_MDEG_S_DEFAULT,                                       \
        .temp_sd_cdeg = ATTITUDE_TEMP_SD_CDEG_DEFAULT, .calibration = {.calibrated = false},       \
    }

/* Fills cfg with ATTITUDE_CONFIG_DEFAULT. */
void attitude_config_default(struct attitude_config *cfg);

/* Checks cfg and starts st. Returns ATTITUDE_ERR_NONE or the attitude_error
 * naming the bad field; every check comes before st is touched, so after an error st
 * is as it was (a running estimator keeps running; a fresh one is still unusable). */
int attitude_init(struct attitude_state *st, const struct attitude_config *cfg);

/* Message naming what is wrong for an attitude_error code ("" for none). */
const char *attitude_error_message(int err);

/*
 * One sample: range_mm[A..D] as reported, range_status[] (0 = valid) and
 * present[] (false: the sensor produced no reading; its range and status are
 * ignored). Returns true when a window estimate is ready in *out (out is not
 * touched otherwise).
 */
bool attitude_push_sample(struct attitude_state *st, const uint16_t range_mm[ATTITUDE_SENSORS],
                          const uint8_t range_status[ATTITUDE_SENSORS],
                          const bool present[ATTITUDE_SENSORS], struct attitude_output *out);

/* "consensus", "consensus-paper", "kalman", "mean" (docs/reference/tools.md), or "unknown". */
/* The head's temperature for the rows pushed after this call, until the next call: known
 * false when the unit has none for them (no sensor, a failed read). A thermal calibration
 * (calibration_head.thermal) corrects each part's offset to it; without a temperature the
 * sd's drift prior falls back to time alone. attitude_init starts with none. */
void attitude_set_temperature(struct attitude_state *st, bool known, int16_t temp_cdeg);

const char *attitude_estimator_name(enum attitude_estimator e);
/* "ok", "degraded", "invalid", or "unknown". */
const char *attitude_status_name(enum attitude_status s);
/* Short kebab-case name of a reason ("paper-diverged", ...), or "unknown". */
const char *attitude_reason_name(enum attitude_reason r);

/*
 * Writes the names of the reasons in `why`, joined by '+', into buf (cap bytes,
 * always NUL-terminated): per-sensor names first (no-target:A .. rejected:D), then
 * parity, motion, drift, uncalibrated, then the attitude_reason names; "" when why is empty.
 * Returns the length written, or ATTITUDE_ERR_BUFFER (buf then holds "") when cap is
 * too small (ATTITUDE_WHY_TEXT_MAX always suffices), ATTITUDE_ERR_NULL for a NULL buf.
 */
int attitude_why_format(attitude_why_t why, char *buf, size_t cap);

#endif /* ESTIMATOR_ATTITUDE_H */
