/*
 * The Kalman filter's private layouts and the interface between its shared part
 * (kalman.c: init, gate, warm-up, lock-out, noise tracking, estimate) and its forms:
 * the tracking (covariance) form, kalman_track.c, for any Q; the information form,
 * kalman_info.c, for Q = 0; its fast solve, kalman_info_fast.c. Which forms an image
 * contains is a build option (KALMAN_TRACKING_BUILT, KALMAN_INFORMATION_BUILT:
 * cmake/TofOptions.cmake); nothing outside estimator/src includes this header but the
 * Kalman filter's own white-box tests.
 */
#ifndef ESTIMATOR_KALMAN_FORM_H
#define ESTIMATOR_KALMAN_FORM_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/kalman.h"
#include "fix_inline.h"

/* Largest accepted R: 2^20 mm² (σ = 1024 mm). */
#define KALMAN_R_MAX_Q32 ((int64_t)1 << 52)
/* Bound of every state, 2^24 mm (16.8 km): far beyond any 16-bit reading, and small
 * enough that a prediction h·x and an innovation z − h·x stay far inside int64. */
#define KALMAN_X_LIMIT_Q32 ((int64_t)1 << 56)
/* Cap of each P_ii under process noise: 16 x the diffuse prior, far above any state worth
 * estimating, and low enough that hᵀPh + R (at most 4 x 2^60 + 2^52) stays inside int64. */
#define KALMAN_P_MAX_Q32 (KALMAN_P0_MM2_Q32 << 4)

/* The information form's state (Q = 0; kalman_info.c): per sensor the weight of one reading
 * (≈ 2^e / R in units of 2^-e mm⁻²) and the exact sums of the accepted readings' weights
 * and of weight · (z − x0_mm); while every row since the start accepted all four readings
 * with the same weights (a uniform run), also the rows and the per-sensor sums of the
 * deviations, and the run's constant coefficients of the fast solve (kalman_info_fast.c). */
struct kalman_info {
    int32_t e;
    int32_t x0_mm;
    int32_t w[ANGLES_SENSORS];
    uint64_t a[ANGLES_SENSORS];
    int64_t z[ANGLES_SENSORS];
    uint16_t rows_to_check; /* rows until the sums' headroom is checked again */
    bool uniform;
    bool fast_ready;                /* the coefficients below are set for this run */
    uint32_t n;                     /* rows of the uniform run */
    uint32_t n_fast;                /* from this row on the fast solve's prior term is exact */
    int64_t dsum[ANGLES_SENSORS];   /* Σ (z − x0_mm) over the run, whole mm */
    int32_t pi[ANGLES_SENSORS];     /* w_s / (w_m + w_p) of its axis, Q31 */
    int32_t kappa;                  /* the α pair's share of x̄, Q31 (β: 1/2 − κ) */
    int32_t inv_q16[KALMAN_STATES]; /* 1/d0, 1/W_α, 1/W_β without the prior, mm² Q16 */
};

/* The tracking form's state (any Q; kalman_track.c): P, and the steady-state updates' form
 * of P ("the block update"): mantissas P ≈ bm · 2^be (packed upper triangle) while bvalid,
 * taken from p brows rows ago. */
struct kalman_cov {
    fix_q32_t p[KALMAN_STATES][KALMAN_STATES];
    int32_t be;
    int32_t bm[6];
    int32_t gain[ANGLES_SENSORS][KALMAN_STATES]; /* each update's gain, Q31 (steady state) */
    /* process_noise_auto (kalman_track.c): running means of the samples of q_x̄ and q_t
     * (Q24 mm² per row) and of each sensor's squared consecutive difference (Q16 mm²); the
     * block sums of y_x̄, y_α, y_β (this block's and the one before) */
    int32_t mean_q[2];
    int32_t mean_d[ANGLES_SENSORS];
    int32_t blk_sum[KALMAN_STATES];
    int32_t blk_prev[KALMAN_STATES];
    uint16_t last_mm[ANGLES_SENSORS]; /* the previous row's readings (last_valid) */
    uint16_t n_q;                     /* blocks sampled so far (saturating) */
    uint16_t n_d;                     /* rows sampled so far (saturating) */
    uint8_t last_valid;
    uint8_t blk_rows;
    bool blk_prev_valid;
    uint8_t brows;
    bool bvalid;
    bool steady;          /* the gains above are at the fixed point: kalman_track_row */
    bool predict_pending; /* kalman_track_predict() done, P += Q not yet applied */
};

/* The forms share the state's storage (struct kalman_state's `form`); may_alias: that
 * storage is declared as words, and only ever read and written through this union. */
#if defined(__GNUC__)
#define KALMAN_MAY_ALIAS __attribute__((may_alias))
#else
#define KALMAN_MAY_ALIAS
#endif
union KALMAN_MAY_ALIAS kalman_forms {
#if KALMAN_INFORMATION_BUILT
    struct kalman_info info;
#endif
#if KALMAN_TRACKING_BUILT
    struct kalman_cov cov;
#endif
};
/* (the storage is uint64_t words: aligned for every member, all of at most 64 bits) */
_Static_assert(sizeof(union kalman_forms) <= sizeof(uint64_t) * KALMAN_FORM_WORDS,
               "KALMAN_FORM_WORDS (estimator/kalman.h) too small for the built forms");

#if KALMAN_INFORMATION_BUILT
static inline struct kalman_info *kalman_info_of(struct kalman_state *k) {
    return &((union kalman_forms *)(void *)k->form.words)->info;
}
static inline const struct kalman_info *kalman_info_of_c(const struct kalman_state *k) {
    return &((const union kalman_forms *)(const void *)k->form.words)->info;
}
#endif
#if KALMAN_TRACKING_BUILT
static inline struct kalman_cov *kalman_cov_of(struct kalman_state *k) {
    return &((union kalman_forms *)(void *)k->form.words)->cov;
}
static inline const struct kalman_cov *kalman_cov_of_c(const struct kalman_state *k) {
    return &((const union kalman_forms *)(const void *)k->form.words)->cov;
}
#endif

/* h = e0 + σ e_j (kalman.h): A (j 1, −), B (j 2, +), C (j 1, +), D (j 2, −). */
FIX_INLINE unsigned kalman_h_index(unsigned sensor) {
    return (sensor & 1u) != 0u ? 2u : 1u;
}
FIX_INLINE bool kalman_h_minus(unsigned sensor) {
    return sensor == (unsigned)ANGLES_A || sensor == (unsigned)ANGLES_D;
}

/* floor(v / 2^sh) as int32 for sh in [1, 62] when the result fits int32 and, for
 * sh >= 32, |v| < 2^62: from the two 32-bit halves (the low word of the floor is the same
 * bits for either sign). */
FIX_INLINE int32_t shr_to_s32(int64_t v, unsigned sh) {
    const uint64_t u = (uint64_t)v;
    const uint32_t lo = (uint32_t)u;
    const uint32_t hi = (uint32_t)(u >> 32);
    uint32_t r;
    if (sh < 32u) {
        r = (lo >> sh) | (hi << (32u - sh));
    } else {
        /* the high word alone, in [−2^30, 2^30): shifted with the bias 2^30 (which 2^s2
         * divides) it stays unsigned */
        const unsigned s2 = sh - 32u;
        r = ((hi + 0x40000000u) >> s2) - (0x40000000u >> s2);
    }
    return (int32_t)r; /* two's complement bits: in range by the precondition */
}

/* --- shared (kalman.c) --- */

/* The innovation gate: e² > max(k²·s, floor²), e in Q32 mm, s in Q32 mm². */
bool kalman_gated_out(const struct kalman_state *k, fix_q32_t e, fix_q32_t s);

/* --- the tracking form (kalman_track.c) --- */

/* The diffuse prior. */
void kalman_track_reset(struct kalman_state *k);
/* R changed (k->r). */
void kalman_track_r_changed(struct kalman_state *k);
/* The prediction of one row: P += Q (bounded). */
void kalman_track_predict(struct kalman_state *k);
/* One row's valid readings, A..D, each a scalar update (gated when `gate`); the
 * definiteness check (a failure restarts P, counted). Returns the sensors accepted,
 * *rejected those gated out. */
uint8_t kalman_track_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                         uint8_t valid_mask, bool gate, uint8_t *rejected);
void kalman_track_covariance(const struct kalman_state *k,
                             fix_q32_t p[KALMAN_STATES][KALMAN_STATES]);
/* process_noise_auto: one row's samples of Q and R before its prediction (valid_mask: the
 * readings to use); true when it set a new R (the caller then updates what depends on R). */
bool kalman_track_adapt(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                        uint8_t valid_mask);

/* --- the information form (kalman_info.c, kalman_info_fast.c) --- */

/* The prior (no reading; x0_mm 0). */
void kalman_info_reset(struct kalman_state *k);
/* The warm-up's start k->x[0] becomes the prior mean, rounded to whole mm. */
void kalman_info_start(struct kalman_state *k);
void kalman_info_r_changed(struct kalman_state *k);
/* One row: every valid reading gated against the state before the row, the accepted ones
 * added, one solve. Returns the sensors accepted, *rejected those gated out. */
uint8_t kalman_info_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                        uint8_t valid_mask, bool gate, uint8_t *rejected);
void kalman_info_covariance(const struct kalman_state *k,
                            fix_q32_t p[KALMAN_STATES][KALMAN_STATES]);
/* The fast solve's coefficients for the current uniform run, and the solve from the
 * run's means (false: the run does not allow it, nothing changed). */
void kalman_info_fast_prepare(struct kalman_info *in);
bool kalman_info_fast_solve(struct kalman_state *k);

#endif /* ESTIMATOR_KALMAN_FORM_H */
