/*
 * Integrity of a window: which readings a part cannot give as valid, whether
 * the four sensors agree with a flat plate (the parity test), whether the plate moved
 * inside the window, and what one window cannot see: the learnt drift of the sensors'
 * offsets, its growth since the start (a prior random walk; `recalibrate` when
 * the parity shows more), a stated offset-stability prior and the 1 mm quantisation. The facade
 * (estimator/attitude.h) turns these facts into each estimator's standard deviation and
 * `why` set; docs/explanation/estimators.md "Integrity" derives every term and says which are
 * learnt and which are prior.
 *
 * Units: per-sensor quantities in Q32 mm / mm²; axis quantities as y = a·tan α,
 * a·tan β (mm) and x̄ (mm), so one coefficient table serves every estimator. Integer
 * only, no heap, every loop bounded by the window length.
 */
#ifndef ESTIMATOR_INTEGRITY_H
#define ESTIMATOR_INTEGRITY_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/angles.h"
#include "estimator/attitude_why.h"
#include "estimator/fixmath.h"
#include "estimator/window_stats.h"

/* The readings no VL53 part gives as a measurement (UM2039 / UM2356: 8190 and 8191 are
 * the VL53L0X's "no target" / out-of-range values, which popular Arduino libraries log
 * with status 0; 65535 is an unanswered or saturated 16-bit read). */
#define INTEGRITY_NO_TARGET_8190  8190u
#define INTEGRITY_NO_TARGET_8191  8191u
#define INTEGRITY_NO_TARGET_65535 65535u

/* A motion statistic beyond 3σ (two-sided Gaussian 0.27 %) goes into the sd as the lag
 * of the window mean behind its last row, even below the `motion` threshold: a ramp too
 * small to be called motion must not leave more than 3σ of lag out of the sd. */
#define INTEGRITY_MOTION_ALLOW_Q8 (3u * 256u)

/* The learnt drift is said (`drift`) only beyond this many of its own white-noise sd
 * (k·256). A mean of a few χ²₁ samples is skewed, and at N = 10 the window gate makes the
 * windows under-predict their noise, so k = 5 (not a Gaussian 3): white noise alone is
 * `drift` after one block in 0.5 % of runs, over the first 16 blocks in 0.1 % of windows,
 * then 0.02 % (0.17 % at N = 10): docs/explanation/estimators.md "Integrity". */
#define INTEGRITY_DRIFT_SIGNIFICANCE_Q8 (5u * 256u)

/* `recalibrate` when the drift the parity shows (its per-sensor mean square beyond white
 * noise over the recent blocks, not clipped at the parity threshold as D is, and
 * significant as for `drift`) exceeds k² times the allowance since the start, offset
 * stability² + walk·t: k = 3, the parity beyond 3σ of what the model allows (a χ²₁ of a
 * slow wander beyond 9: 0.27 % of the time for a head that drifts exactly as the prior
 * says): docs/explanation/estimators.md "Integrity", "Drift since the start". */
#define INTEGRITY_RECALIBRATE_SIGMAS_Q8 (3u * 256u)

/* The row period's bounds (µs): the trace format's 1..10 000 ms. */
#define INTEGRITY_PERIOD_US_MIN 1000u
#define INTEGRITY_PERIOD_US_MAX 10000000u
/* The largest rate bound: 360°/s, a turn a second, far beyond any plate a capture
 * interface closes on (the bound's products stay within 64 bits below it). */
#define INTEGRITY_MAX_RATE_MDEG_S_MAX 360000u

/* The three axes of an estimate, as y = a·tan α, y = a·tan β and x̄. */
enum integrity_axis { INTEGRITY_ALPHA = 0, INTEGRITY_BETA = 1, INTEGRITY_DISTANCE = 2 };
#define INTEGRITY_AXES 3u

struct integrity_config {
    int32_t arm_um;
    uint16_t range_max_mm;        /* a reading above this is implausible (`range:X`) */
    uint16_t parity_sigmas_q8;    /* parity threshold k·256 */
    uint16_t motion_sigmas_q8;    /* motion threshold k·256 */
    uint16_t offset_stability_um; /* prior per-sensor offset 1σ (not learnable) */
    uint16_t drift_flag_um;       /* learnt drift 1σ above this (and significant): `drift` */
    uint8_t drift_shift;          /* learning gain 2^-shift per block, after a start-up mean */
    uint32_t period_us;           /* row period: the time since the start is rows × period */
    uint32_t offset_walk_um2_h;   /* prior random-walk rate of each offset, µm²/h */
    uint32_t calibration_age_s;   /* the calibration's age at the start: the walk's time
                                     is this plus rows × period */
    uint32_t max_rate_mdeg_s;     /* the plate's rate bound, millidegrees per second
                                     (0: a plate known to be still): the lag a ramp at
                                     up to this rate leaves, as a prior on α and β */
    /* What the head's calibration leaves, per sensor (estimator/calibration.h; the parts'
     * spread for an uncalibrated head): 1σ of its offset and gain errors and their
     * correlation. Each sensor mean's variance carries them at its distance. */
    int32_t cal_gain_ppm[ANGLES_SENSORS]; /* the gain correction (0 uncalibrated): the ring's
                                             readings are raw, the statistics not; the offset
                                             in force is the window's (window_shift_offsets) */
    uint32_t cal_offset_sd_um[ANGLES_SENSORS];
    uint32_t cal_gain_sd_ppm[ANGLES_SENSORS];
    int16_t cal_corr_q15[ANGLES_SENSORS];
};

/* What is learnt across windows: the per-sensor drift variance from the parity
 * residual's mean square beyond the white noise the windows themselves predict, and the
 * lag a steady motion leaves, from the last four blocks' means (a ramp too slow for one
 * window's statistics to see still puts the window mean behind its last row; held for
 * the sliding windows until the next block). */
struct integrity_state {
    fix_q32_t
        drift_mm2; /* per-sensor drift variance, Q32 mm² (an unbiased mean: may dip below 0) */
    fix_q32_t drift_var_mm4; /* its variance from white noise alone, Q32 mm⁴ (`drift` test) */
    uint16_t blocks;         /* blocks learnt, saturating at 2^drift_shift */
    uint8_t block_used[3];   /* the previous three blocks' sensor sets */
    fix_q32_t block_mean_mm[3][ANGLES_SENSORS]; /* ... and their sensor means, newest first */
    fix_q32_t steady_lag2_mm2[INTEGRITY_AXES];  /* learnt lag² per axis, Q32 mm², held
                                                   until the next block */
    /* Drift since the start (docs/explanation/estimators.md "Drift since the start"): */
    uint32_t rows;            /* rows since the start at this window's end */
    uint32_t long_blocks;     /* blocks in drift_long_mm2 (no cap: the whole run) */
    fix_q32_t drift_long_mm2; /* the parity's drift samples' mean over the whole run */
    fix_q32_t shown_mm2;      /* ... the recent blocks' mean not clipped above: the drift the
                                 parity shows, for `recalibrate` */
    fix_q32_t walk_mm2;       /* the prior walk's variance at the last block, Q32 mm² */
    /* Set by the caller before each integrity_assess (0 without a temperature correction):
     * the variance, µm², that each sensor's offset correction for temperature leaves
     * (estimator/calibration.h): the coefficient's sd times the distance from the
     * calibration temperature, and the correction's own step. */
    int64_t thermal_var_um2[ANGLES_SENSORS];
};

/* Per-sensor sums of the used readings of a window against their row index (0 = the
 * oldest), for the motion statistics. int32 suffices: i < 256 and a used reading is
 * plausible (<= 8189 mm), so Σi² < 5.6e6, Σx < 2.1e6 and Σi·x < 5.4e8. */
struct integrity_ramp_sums {
    int32_t n;
    int32_t si;
    int32_t sii;
    int32_t sx;
    int32_t six;
    int32_t tail_n[2]; /* the newest N/8 and N/4 rows: a late step */
    int32_t tail_sx[2];
    int32_t tail_out_n; /* valid readings of the newest N/8 rows the gate dropped */
    int32_t tail_out_sx;
};

/* Block lengths 2^0 .. 2^(INTEGRITY_OSC_LEVELS − 1) rows of the oscillation test. */
#define INTEGRITY_OSC_LEVELS 6u

/* One level's block sums of u_α = x_C − x_A and u_β = x_B − x_D (integrity_oscillation.c). */
struct integrity_osc_level {
    int32_t run[2];  /* the open block's sums (|.| < 2^16 · 32) */
    int32_t sum[2];  /* Σ closed block sums (|.| < 2^16 · 1024) */
    int64_t sum2[2]; /* Σ closed block sums² */
    uint32_t blocks; /* closed blocks */
};

/* The oscillation test's sums over the window's used complete rows: every level's blocks,
 * and the parity's Σp, Σp² (p = x_A + x_C − x_B − x_D). */
struct integrity_osc_sums {
    struct integrity_osc_level level[INTEGRITY_OSC_LEVELS];
    int64_t sp;
    int64_t spp;
    uint32_t n;
};

/* The facts of one window, common to every estimator. */
struct integrity_window {
    attitude_why_t why;                  /* per-sensor bits (no-target, range, flagged, missing)
                                            and parity, motion, drift */
    uint8_t used;                        /* sensors with a used reading (the window's set) */
    fix_q32_t white_mm2[ANGLES_SENSORS]; /* var of each sensor's window mean: s²/n */
    fix_q32_t extra_mm2[ANGLES_SENSORS]; /* drift + prior + quantisation + calibration per
                                            sensor mean */
    fix_q32_t tan_q32[2];                /* slopes for the delta method (0 if unknown) */
    fix_q32_t parity_mm;                 /* x_A + x_C − x_B − x_D of the means (all four) */
    bool parity_failed;
    fix_q32_t lag_mm[INTEGRITY_AXES];                /* end-of-window minus window-mean, LS ramp */
    fix_q32_t lag_var_mm2[INTEGRITY_AXES];           /* its white-noise variance */
    bool moved[INTEGRITY_AXES];                      /* lag beyond motion_sigmas: `motion` */
    struct integrity_ramp_sums ramp[ANGLES_SENSORS]; /* scratch of the motion statistics */
    struct integrity_osc_sums osc;                   /* scratch of the oscillation test */
    fix_q32_t motion_mm[3][ANGLES_SENSORS];          /* per sensor: ramp lag, newest N/8 and N/4 */
    fix_q32_t motion_var_mm2[3][ANGLES_SENSORS];     /* ... and their white-noise variances */
    fix_q32_t extra_var_mm2[INTEGRITY_AXES];         /* what each axis adds to a window estimator's
                                                       white variance: drift, prior, quantisation,
                                                       a failed parity and a detected motion */
};

/* Config fields as attitude_init checks them: true when usable. */
bool integrity_config_valid(const struct integrity_config *cfg);

/* Starts the learning from nothing. */
void integrity_init(struct integrity_state *st);

/* The readings of one sample a part cannot give as valid: bit k set when present[k]
 * and range_mm[k] is 0, a no-target value or above range_max_mm (< 8190, so the no-target
 * values are above it). Inline: it runs on every sample. 0 − 1 wraps to 65535, so one
 * unsigned comparison per reading says 0 or above the max. */
static inline uint8_t integrity_implausible(const uint16_t range_mm[ANGLES_SENSORS],
                                            uint8_t present_mask, uint16_t range_max_mm) {
    uint8_t m = 0;
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        if ((uint16_t)(range_mm[k] - 1u) >= range_max_mm) {
            m = (uint8_t)(m | (1u << k));
        }
    }
    return (uint8_t)(m & present_mask);
}

/* Window facts from the window's rows (w, as window_compute left it) and statistics s.
 * rows: rows since the start at this window's end (time = rows × cfg->period_us).
 * learn: this window ends a block of N rows, so the drift learning takes it in. */
void integrity_assess(struct integrity_state *st, const struct integrity_config *cfg,
                      struct window_state *w, const struct window_stats *s, uint32_t rows,
                      bool learn, struct integrity_window *out);

/* Each sensor's drift variance (Q32 mm², >= 0) the sd carries beyond the offset-stability
 * prior: the largest of the learnt drift D (recent blocks), its mean over the whole run
 * and the prior walk's offset_walk · t since the start (docs/explanation/estimators.md
 * "Drift since the start"). */
fix_q32_t integrity_drift_var(const struct integrity_state *st);

/* Variance (Q32 mm², saturating) of the axis' least-squares combination of the sensor
 * means over the set `used` (docs/explanation/architecture.md: y_α = (x_C − x_A)/2 with all four,
 * ...), for per-sensor variances v[]; false (and 0) when `used` does not observe the axis. */
bool integrity_axis_var(enum integrity_axis axis, uint8_t used, const fix_q32_t v[ANGLES_SENSORS],
                        fix_q32_t *var_mm2);

#endif /* ESTIMATOR_INTEGRITY_H */
