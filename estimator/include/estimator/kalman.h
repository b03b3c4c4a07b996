/*
 * Three-state Kalman filter of the first paper (Eq. 5, Alg. 2) in fixed point.
 *
 * State: θ = [x̄, a·tan α, a·tan β] in mm (Q32). Eq. 5 uses [x̄, tan α, tan β]
 * with rows [1, ∓a, 0] / [1, 0, ±a]; scaling the two slopes by a makes every
 * measurement row h_k a vector of 0 and ±1 (A: [1,−1,0], B: [1,0,1],
 * C: [1,1,0], D: [1,0,−1]), so P h is additions only and every entry of P is in
 * mm². Identity dynamics with a configurable process noise Q (diagonal; 0 for
 * the static-window protocol of the paper).
 *
 * One filter for any Q, the covariance form, the same code in every build. Each row is
 * four scalar updates, one per valid reading (R is diagonal, so no matrix inverse: Alg.
 * 2's [C P Cᵀ + R]⁻¹ becomes a division by a scalar s), skipping flagged sensors. The
 * covariance update is the Joseph form
 *     P' = (I − k hᵀ) P (I − k hᵀ)ᵀ + k R kᵀ = P − k gᵀ − g kᵀ + s k kᵀ,
 * g = P h, s = hᵀg + R, evaluated with exact 128-bit products and one rounding
 * per entry, upper triangle mirrored: symmetric by construction, and correct
 * for the gain k actually used (rounded to Q30), so rounding the gain only
 * costs second-order error; once P is well scaled, the updates run on 32-bit mantissas
 * of P with the exact decreases applied to P once per row (the block update,
 * kalman_track.c); with Q > 0 and R constant, once P has settled, a row is
 * x += k e alone (the steady state); with Q = 0, while every row since the start had four
 * accepted readings with the same R, P is M⁻¹/c (M = Σ h hᵀ/R) and a row is its own
 * least-squares correction over c + 1 (the static run, kalman_static.c). Where the paper
 * is unsafe: Alg. 2's P_post = P_pre − K C P_pre loses symmetry and definiteness in finite
 * precision. Every row also checks positive definiteness (positive diagonal,
 * P_ij² < P_ii P_jj); a failure restarts the filter and is counted, never hidden.
 *
 * Robustness the paper does not address:
 * - Measurement noise follows each sensor: R_k starts at the configured value,
 *   is replaced by the first window's gated sample variance of that sensor and
 *   then tracks it (R += (v − R)/2^shift per window), floored at 1/12 mm² (the
 *   1 mm quantisation) and capped at 2^20 mm² like a configured R, so unequal and
 *   drifting noise is weighted correctly. Each P_ii grows under Q up to 16·P0 at
 *   most (a long outage), so hᵀPh + R always fits int64.
 * - Innovation gate: a reading with e² > k²·s (and |e| > floor) is rejected.
 *   A gate is useless while P is still diffuse, so each (re)start buffers the
 *   first `warmup_rows` rows, gates them against the per-sensor median of those
 *   rows (robust to one outlier in three), then processes them and runs online.
 * - A filter that rejects KALMAN_LOCKOUT_ROWS readings of one sensor in a row
 *   restarts instead of locking itself out: the plate jumped, or (rare, with
 *   outliers in most warm-up rows of one sensor) the start itself was wrong and
 *   the gate now rejects the good readings while accepting the others. If that
 *   sensor's R is still the configured guess (no window statistics yet), the
 *   guess was probably too small and is raised x4 for the restart.
 */
#ifndef ESTIMATOR_KALMAN_H
#define ESTIMATOR_KALMAN_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/angles.h"
#include "estimator/fixmath.h"

#define KALMAN_STATES 3u
/* process_noise_auto: block lengths 32, 128, 512, 2048 rows (kalman_adapt.c) */
#define KALMAN_ADAPT_LEVELS 4u
#define KALMAN_WARMUP_MAX   8u
#define KALMAN_LOCKOUT_ROWS 4u
/* Smallest R: 1/12 mm² (Q32, rounded down), the variance of rounding to whole mm; a sensor
 * reporting whole millimetres cannot be more certain. */
#define KALMAN_R_MIN_Q32 ((int64_t)357913941)
/* Diffuse prior: σ = 4096 mm on each state (P0 = 2^24 mm²). */
#define KALMAN_P0_MM2_Q32 ((int64_t)1 << 56)

/* Errors of the Kalman filter's configuration, in its block -48..-63 of the one error
 * convention (docs/reference/errors.md). */
enum kalman_error {
    KALMAN_OK = 0,
    KALMAN_ERR_PROCESS_NOISE = -48,     /* a Q entry negative or above P0 */
    KALMAN_ERR_MEASUREMENT_NOISE = -49, /* an initial R not in [1/12 mm², 2^20 mm²] */
    KALMAN_ERR_WARMUP = -50,            /* warmup_rows outside 1..KALMAN_WARMUP_MAX */
    KALMAN_ERR_NOISE_SHIFT = -51,       /* noise_shift above 8 */
};

struct kalman_config {
    fix_q32_t process_noise_mm2[KALMAN_STATES];  /* Q per row: x̄, a·tan α, a·tan β */
    fix_q32_t initial_noise_mm2[ANGLES_SENSORS]; /* R before any window statistics */
    uint16_t gate_sigmas_q8; /* innovation (and warm-up) gate k x 256; 0 disables */
    uint16_t gate_floor_mm;  /* never reject |e| <= this */
    uint8_t warmup_rows;     /* rows buffered at each (re)start */
    uint8_t noise_shift;     /* R tracking gain 2^-shift (0: replace each window) */
    bool process_noise_auto; /* Q and R learned from the data (kalman_track.c, "auto"): Q
                                starts at process_noise_mm2, R at initial_noise_mm2 */
};

/* The covariance and what makes its updates cheap (kalman_track.c): P, and the block
 * update's form of P (mantissas P ≈ bm · 2^be, packed upper triangle, while bvalid, taken
 * from p brows rows ago); each update's gain for the steady state (Q > 0); the static
 * run (Q = 0); what process_noise_auto learns from. */
struct kalman_cov {
    fix_q32_t p[KALMAN_STATES][KALMAN_STATES];
    int32_t be;
    int32_t bm[6];
    int32_t gain[ANGLES_SENSORS][KALMAN_STATES]; /* each update's gain, Q31 (steady state) */
    /* process_noise_auto (kalman_adapt.c): per block length 32·4^l rows, running means
     * of the samples of q_x̄ and q_t (Q24 mm² per row), the block sums of y_x̄, y_α, y_β
     * (this block's and the one before); each sensor's squared consecutive difference
     * (Q16 mm²) */
    int32_t mean_q[KALMAN_ADAPT_LEVELS][2];
    int32_t mean_d[ANGLES_SENSORS];
    int32_t blk_sum[KALMAN_ADAPT_LEVELS][KALMAN_STATES];
    int32_t blk_prev[KALMAN_ADAPT_LEVELS][KALMAN_STATES];
    /* the squares of y's consecutive differences summed over the same blocks (this block's
     * and the one before): the white noise under each block difference, from its own rows */
    uint32_t blk_dsq[KALMAN_ADAPT_LEVELS][KALMAN_STATES];
    uint32_t blk_dsq_prev[KALMAN_ADAPT_LEVELS][KALMAN_STATES];
    uint16_t last_mm[ANGLES_SENSORS];     /* the previous row's readings (last_valid) */
    uint16_t n_q[KALMAN_ADAPT_LEVELS][2]; /* samples in mean_q (saturating) */
    int32_t fall[KALMAN_ADAPT_LEVELS][2]; /* the test for a fall of q (Q12) */
    uint32_t sum_d2[ANGLES_SENSORS];      /* this block's squared differences, per sensor */
    uint8_t cnt_d[ANGLES_SENSORS];        /* ... how many */
    uint8_t n_d[ANGLES_SENSORS];          /* blocks of differences so far (saturating) */
    uint8_t blk_sub[KALMAN_ADAPT_LEVELS]; /* rows (level 0) or sub-blocks in this block */
    uint8_t last_valid;
    uint8_t blk_prev_valid; /* bit l: level l has the block before */
    uint8_t brows;
    bool bvalid;
    bool steady;          /* the gains above are at the fixed point: kalman_track_row */
    bool predict_pending; /* kalman_track_predict() done, P += Q not yet applied */
    /* the static run (Q = 0, kalman_static.c): while `still`, P = M⁻¹/(u − 1), not in p */
    bool still;
    bool still_broken;   /* a row since the start was not four accepted readings (or R
                            changed): P is no longer M⁻¹/c */
    int32_t run_kappa;   /* x̄'s weight of e_A + e_C, Q31 */
    int32_t run_wp[2];   /* per slope α, β: the weight of e_p (C, B), Q31 */
    int32_t run_wm[2];   /* ... and of e_m (A, D), Q31 */
    int64_t run_u;       /* c + 1 of the next row, Q32 */
    int64_t run_minv[6]; /* M⁻¹ of the run's R, packed upper triangle, Q32 mm² */
};

struct kalman_state {
    struct kalman_config cfg;
    fix_q32_t x[KALMAN_STATES];
    fix_q32_t r[ANGLES_SENSORS];
    bool r_tracked[ANGLES_SENSORS]; /* R already replaced by window statistics */
    bool started;                   /* warm-up done, running online */
    uint8_t warm_rows;
    uint16_t warm_range[KALMAN_WARMUP_MAX][ANGLES_SENSORS];
    uint8_t warm_valid[KALMAN_WARMUP_MAX];
    uint8_t reject_run[ANGLES_SENSORS]; /* consecutive gated-out readings per sensor */
    uint32_t restarts; /* lock-outs, definiteness failures, and the facade's restart on a wrong R
                          guess */
    uint32_t numeric_restarts;            /* definiteness failures alone */
    uint64_t gate_s_max;                  /* s up to which s·k² fits 64 bits (fast gate) */
    uint64_t gate_accept[ANGLES_SENSORS]; /* e24² below this: inside the gate for any s >= R */
    bool process_noise;                   /* some Q entry is non-zero, or auto: the filter
                                             tracks (no restart at a window's start) */
    struct kalman_cov cov;
};

/* Outcome of one kalman_push_row(): the rows it processed, oldest first (a
 * warm-up flush processes several at once, a buffered row none). */
struct kalman_rows {
    uint8_t count;
    uint8_t used[KALMAN_WARMUP_MAX];     /* sensor mask of accepted readings */
    uint8_t rejected[KALMAN_WARMUP_MAX]; /* sensor mask of gated-out readings */
};

struct kalman_result {
    bool alpha_observable; /* var(a·tan α) well below the prior */
    bool beta_observable;
    fix_udeg_t alpha_udeg;
    fix_udeg_t beta_udeg;
    fix_q32_t distance_mm;
    fix_udeg_t alpha_sigma_udeg; /* from P */
    fix_udeg_t beta_sigma_udeg;
    fix_q32_t p_mm2[KALMAN_STATES][KALMAN_STATES]; /* the covariance itself */
};

/* KALMAN_OK, or the kalman_error naming cfg's bad field; touches no state, so a caller
 * can refuse a configuration before it resets anything. */
int kalman_config_check(const struct kalman_config *cfg);

/* Checks cfg (kalman_config_check()) and resets the filter. */
int kalman_init(struct kalman_state *k, const struct kalman_config *cfg);

/* Forgets the state (diffuse prior, warm-up again) but keeps the learned R:
 * the start of a static window. */
void kalman_reset(struct kalman_state *k);

/* The process noise per row in use (Q32 mm²: x̄, a·tan α, a·tan β): the configured one,
 * or with process_noise_auto the one learned so far. */
void kalman_process_noise(const struct kalman_state *k, fix_q32_t q[KALMAN_STATES]);

/* One row: predict (P += Q), then one scalar update per valid reading, A..D.
 * valid_mask: sensors present with status 0. Reports what was processed. */
void kalman_push_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                     uint8_t valid_mask, struct kalman_rows *out);

/* Processes any rows still buffered for warm-up (a window shorter than the
 * warm-up, or the end of the data). */
void kalman_flush(struct kalman_state *k, struct kalman_rows *out);

/* One measurement of sensor `sensor` (no prediction), gated when `gate` is set.
 * Returns true if the reading was accepted; false also before the warm-up has
 * started the filter (kalman_push_row, kalman_flush): the reading is not used. */
bool kalman_update(struct kalman_state *k, unsigned sensor, uint16_t range_mm, bool gate);

/* The covariance of the state (Q32 mm²). */
void kalman_covariance(const struct kalman_state *k, fix_q32_t p[KALMAN_STATES][KALMAN_STATES]);

/* Feeds the gated sample variance (Q32 mm²) of `count` readings of a sensor in
 * the last window to its R (first time: replace; then track). count < 2: ignored, and
 * ignored with process_noise_auto, which learns R from consecutive readings instead.
 * True when it replaced the configured guess by a value more than twice it (four times
 * from 8 to 31 readings; never from fewer): the rows so far were gated and weighed with
 * an R too small, so they count too much (a guess too large only wastes some of them). */
bool kalman_track_noise(struct kalman_state *k, unsigned sensor, fix_q32_t var_mm2, uint16_t count);

/* Current estimate, angles through atan of the state over a, and P. */
void kalman_estimate(const struct kalman_state *k, int32_t arm_um, struct kalman_result *out);

#endif /* ESTIMATOR_KALMAN_H */
