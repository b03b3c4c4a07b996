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
 * Two forms of the same filter, chosen by Q:
 *
 * Q = 0 (the default, the paper's static-window protocol): the information form.
 * Without process noise Alg. 2 is recursive least squares, and its information
 * matrix Y = P⁻¹ = y0·I + Σ h hᵀ/R never couples a·tan α with a·tan β (no row has
 * both): the filter is, per sensor, the sum of the weights 1/R of its accepted
 * readings and of their weighted deviations, two additions per reading. x and P
 * follow in closed form (Schur complement on x̄, kalman.c) after each row, every
 * divisor a sum of positive terms: P is positive definite by construction, no
 * check or restart is needed. Each row's readings are gated against the state
 * of the rows before it (not against each other). While every row since the
 * start accepted all four readings with the same R (a uniform run, the common
 * case), x comes from the run's four means with coefficients fixed for the run
 * (the fast solve; the whole row about 560 instructions on a Cortex-M4).
 *
 * Q > 0: the covariance form. Each row is four scalar updates, one per valid
 * reading (R is diagonal, so no matrix inverse: Alg. 2's [C P Cᵀ + R]⁻¹ becomes
 * a division by a scalar s), skipping flagged sensors. The covariance update is
 * the Joseph form
 *     P' = (I − k hᵀ) P (I − k hᵀ)ᵀ + k R kᵀ = P − k gᵀ − g kᵀ + s k kᵀ,
 * g = P h, s = hᵀg + R, evaluated with exact 128-bit products and one rounding
 * per entry, upper triangle mirrored: symmetric by construction, and correct
 * for the gain k actually used (rounded to Q30), so rounding the gain only
 * costs second-order error. Where the paper is unsafe: Alg. 2's
 * P_post = P_pre − K C P_pre loses symmetry and definiteness in finite
 * precision. Every row also checks positive definiteness (positive
 * diagonal, P_ij² < P_ii P_jj); a failure restarts the filter and is counted,
 * never hidden.
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

#define KALMAN_STATES       3u
#define KALMAN_WARMUP_MAX   8u
#define KALMAN_LOCKOUT_ROWS 4u
/* Smallest R: 1/12 mm² (Q32, rounded down), the variance of rounding to whole mm; a sensor
 * reporting whole millimetres cannot be more certain. */
#define KALMAN_R_MIN_Q32 ((int64_t)357913941)
/* Diffuse prior: σ = 4096 mm on each state (P0 = 2^24 mm²). */
#define KALMAN_P0_MM2_Q32 ((int64_t)1 << 56)

/* The forms an image contains (cmake/TofOptions.cmake, TOF_KALMAN_FORMS; both by default):
 * the tracking (covariance) form runs any Q, and Q = 0 too when it is the only one built;
 * the information form runs Q = 0, and an image with only it refuses a non-zero Q. */
#ifndef KALMAN_TRACKING_BUILT
#define KALMAN_TRACKING_BUILT 1
#endif
#ifndef KALMAN_INFORMATION_BUILT
#define KALMAN_INFORMATION_BUILT 1
#endif

/* Words of storage for the form's private state (estimator/src/kalman_form.h lays it out
 * and checks at compile time that it fits). */
#define KALMAN_FORM_WORDS 27u /* the tracking form, the larger */

/* Errors of the Kalman filter's configuration, in its block -48..-63 of the one error
 * convention (docs/errors.md). */
enum kalman_error {
    KALMAN_OK = 0,
    KALMAN_ERR_PROCESS_NOISE = -48,     /* a Q entry negative or above P0, or non-zero
                                           without KALMAN_TRACKING_BUILT */
    KALMAN_ERR_MEASUREMENT_NOISE = -49, /* an initial R not in [1/12 mm², 2^20 mm²] */
    KALMAN_ERR_WARMUP = -50,            /* warmup_rows outside 1..KALMAN_WARMUP_MAX */
    KALMAN_ERR_NOISE_SHIFT = -51,       /* noise_shift above 8 */
    KALMAN_ERR_AUTO = -52,              /* process_noise_auto without KALMAN_TRACKING_BUILT */
};

struct kalman_config {
    fix_q32_t process_noise_mm2[KALMAN_STATES];  /* Q per row: x̄, a·tan α, a·tan β */
    fix_q32_t initial_noise_mm2[ANGLES_SENSORS]; /* R before any window statistics */
    uint16_t gate_sigmas_q8; /* innovation (and warm-up) gate k x 256; 0 disables */
    uint16_t gate_floor_mm;  /* never reject |e| <= this */
    uint8_t warmup_rows;     /* rows buffered at each (re)start */
    uint8_t noise_shift;     /* R tracking gain 2^-shift (0: replace each window) */
    bool process_noise_auto; /* Q and R learned from the data (kalman_form.h, "auto"): Q
                                starts at process_noise_mm2, R at initial_noise_mm2 */
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
    uint32_t numeric_restarts;            /* definiteness failures alone (covariance form) */
    uint64_t gate_s_max;                  /* s up to which s·k² fits 64 bits (fast gate) */
    uint64_t gate_accept[ANGLES_SENSORS]; /* e24² below this: inside the gate for any s >= R */
    bool process_noise;                   /* some Q entry is non-zero: the tracking form */
    struct {                              /* the running form's state (kalman_form.h) */
        uint64_t words[KALMAN_FORM_WORDS];
    } form;
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

/* One row. Covariance form: predict (P += Q), then one scalar update per valid
 * reading, A..D. Information form: every valid reading gated against the state
 * before the row, the accepted ones added, one solve.
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

/* The covariance of the state (Q32 mm²), either form. */
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
