/*
 * Consensus fusion of the five angle estimates of one window (Sec. III-A,
 * Eq. 2-4 and Alg. 1 of the first paper), two weighting rules.
 *
 * --- `paper`: exactly as published ------------------------------------------
 * w_ij = 1/c_ij with c_ij = cov(α_i, α_j) over the window (Eq. 3), rows
 * normalised P_ij = w_ij / Σ_k w_ik (Eq. 4), v ← P·v from the window means
 * until max|v_i − v_j| <= tol (Alg. 1). Where the paper is wrong: it claims P
 * is "symmetric", has positive entries and converges "by definition (Gershgorin
 * theorem)". None of that holds. c_13 = −var(x_B)/a²·(...) < 0 because α1 and α3
 * share B with opposite signs (likewise α2/α4 through D), so P has negative
 * entries; c_14 and c_23 (pairs with no common sensor) are zero in expectation,
 * so their sampled values are near zero with a random sign and 1/c_ij
 * dominates its row: P is close to a permutation swapping α1↔α4 and α2↔α3,
 * with an eigenvalue near −1, and a row sum Σ_k w_ik can be zero or negative.
 * Normalising rows does not make P symmetric either. A faithful P therefore can
 * oscillate, converge slowly, or diverge; the paper also does not say which
 * covariance normalisation it uses (irrelevant here: P is invariant to scaling
 * c) or what to do at zero covariance (1/0). What the paper also misses: W = [1/c_ij]
 * is symmetric, so P = D⁻¹W with D = diag(d), d_i = Σ_k 1/c_ik, and dᵀP = 1ᵀW = dᵀ:
 * when P converges with every d_i > 0 the result is Σ d_i v_i / Σ d_i, weights
 * dominated by the near-zero covariances, i.e. essentially random. P is similar
 * to the symmetric D^-½WD^-½, so its eigenvalues are real, and nothing keeps
 * them inside (−1, 1]: convergence, not the limit, is what fails.
 * This implementation computes P
 * faithfully and reports, as a status and never as a number: a variance <= 0,
 * a zero covariance, a zero or negative row sum (the published normalisation
 * then flips the row's sign), entries too large to be meaningful (overflow),
 * divergence, no convergence within the iteration cap, and a converged value
 * outside the range of the initial estimates (impossible in exact arithmetic
 * once all d_i > 0, kept as a guard for stopping at a tolerance).
 *
 * --- `consensus`: the product's rule (our design) ------------------------------
 * Facts it rests on (derivation and proof: docs/explanation/estimators.md):
 * 1. Work in slopes, not angles: with per-sensor window means m_k, the slopes
 *    s_i = tan α_i of Eq. 1 are linear in the ranges, so their means are
 *    unbiased; means of atan(·) are not (≈0.045° bias for α1 at 5° with
 *    σ = 2 mm, a = 30 mm). atan is applied once, to the fused slope.
 * 2. Cross-axis compensation: s1 = tan α + tan β, s2 = s3 = tan α − tan β,
 *    s4 = tan α + tan β, s5 = tan α. With t̂β5 = (m_B − m_D)/2a:
 *        v1 = s1 − t̂β5, v2 = s2 + t̂β5, v3 = s3 + t̂β5, v4 = s4 − t̂β5, v5 = s5
 *    are all unbiased for tan α at any β. (v1 = v2 = (M − m_A)/a and
 *    v3 = v4 = (m_C − M)/a with M = (m_B + m_D)/2: two independent-ish halves.)
 * 3. The weights π are the BLUE of the linear model of docs/explanation/architecture.md with the
 *    per-sensor variances of the window means V_k = s_k²/n_k (floored at the
 *    1 mm quantisation variance 1/12 mm², so all-equal readings are harmless):
 *    with m = (V_B + V_D)/4, the low side (v1, v2) gets 2m + V_C, the high side
 *    (v3, v4) gets 2m + V_A, normalised; v5 carries the common part. This
 *    attains the Cramér-Rao bound of the model; with equal noise it reduces to
 *    π = e5, i.e. mean(α5) as a slope.
 * 4. P = (1 − ε)I + ε·1πᵀ with ε = 1/2 and π >= 0, Σπ = 1: non-negative and
 *    row-stochastic by construction. πᵀP = πᵀ, so πᵀv is invariant and v
 *    converges to 1·πᵀv(0), the BLUE. Since P(v − c1) = (1 − ε)(v − c1) for
 *    c = πᵀv, the spread halves exactly each iteration:
 *        spread(k) = 2^−k spread(0),  k* = ceil(log2(spread(0)/tol)).
 *    In Q32 with rounding, spread(k+1) <= spread(k)/2 + 2 LSB, so k* + 1
 *    iterations always suffice while tol > 4 LSB (tol >= 1 udeg is 74 LSB);
 *    spread(0) < 2^62 bounds k* by 62 (CONSENSUS_PRODUCT_MAX_ITERATIONS).
 * Missing sensors: low side missing → v3, v4; high side missing → v1, v2; one
 * reference missing → v5 alone; otherwise the angle is unobservable. The β
 * axis is the same with (low, ref1, high, ref2) = (D, A, B, C).
 */
#ifndef ESTIMATOR_CONSENSUS_H
#define ESTIMATOR_CONSENSUS_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/angles.h"
#include "estimator/fixmath.h"

#define CONSENSUS_PRODUCT_MAX_ITERATIONS 64u
/* Entries of the paper's P beyond ±2^16 are reported as overflow. */
#define CONSENSUS_PAPER_MAX_ENTRY_LOG2 16u
/* A paper iterate beyond ±360° is divergence. */
#define CONSENSUS_PAPER_DIVERGED_UDEG 360000000

enum consensus_status {
    CONSENSUS_OK = 0,
    CONSENSUS_UNOBSERVABLE,         /* too few sensors for this angle */
    CONSENSUS_TOO_FEW_ROWS,         /* paper: fewer than 2 complete rows */
    CONSENSUS_NONPOSITIVE_VARIANCE, /* paper: some c_ii <= 0 (w_ii undefined) */
    CONSENSUS_ZERO_COVARIANCE,      /* paper: some c_ij == 0 (w_ij = 1/0) */
    CONSENSUS_ZERO_ROW_SUM,         /* paper: Σ_k w_ik == 0 (P undefined) */
    CONSENSUS_NEGATIVE_ROW_SUM,     /* paper: Σ_k w_ik < 0 (normalisation flips the row) */
    CONSENSUS_OVERFLOW,             /* paper: |P_ij| > 2^16, or an intermediate overflowed */
    CONSENSUS_DIVERGED,             /* paper: an iterate left ±360° */
    CONSENSUS_NO_CONVERGENCE,       /* iteration cap reached above tolerance */
    CONSENSUS_OUTSIDE_HULL,         /* paper: result outside [min, max] of v(0) ± tol, or ±90° */
};

/* Short stable name of a status ("ok", "diverged", ...). */
const char *consensus_status_name(enum consensus_status status);

/* --- product rule ------------------------------------------------------------- */

struct consensus_sensor {
    bool used;         /* at least one reading of this sensor in the window */
    uint16_t count;    /* readings used, n_k >= 1 when used */
    fix_q32_t mean_mm; /* their mean */
    fix_q32_t var_mm2; /* their sample variance (0 if n_k < 2: the floor applies) */
};

struct consensus_product_input {
    struct consensus_sensor sensor[ANGLES_SENSORS];
    int32_t arm_um;            /* a, valid per angles_arm_valid() */
    fix_udeg_t tolerance_udeg; /* spread tolerance, >= 1 */
};

struct consensus_axis {
    enum consensus_status status;       /* OK or UNOBSERVABLE (NO_CONVERGENCE: a bug) */
    fix_q32_t tan_q32;                  /* fused tan(angle) */
    fix_udeg_t angle_udeg;              /* atan of it */
    fix_udeg_t sigma_udeg;              /* predicted 1σ from the window variances */
    uint16_t iterations;                /* v ← P·v steps taken */
    uint8_t used;                       /* bit i: compensated estimate i+1 took part */
    fix_q32_t initial[ANGLES_PER_AXIS]; /* v(0): compensated slopes */
    fix_q30_t weight[ANGLES_PER_AXIS];  /* π, sums to 2^30 over `used` */
};

struct consensus_product_result {
    struct consensus_axis alpha;
    struct consensus_axis beta;
    bool distance_valid;
    fix_q32_t distance_mm; /* BLUE of x̄ */
};

/* Fuses one window with the product rule. Needs only per-sensor means,
 * variances and counts. Every loop is bounded (at most 64 iterations). */
void consensus_product(const struct consensus_product_input *in,
                       struct consensus_product_result *out);

/* --- paper rule ------------------------------------------------------------------ */

struct consensus_paper_config {
    fix_udeg_t tolerance_udeg; /* spread tolerance (paper: 1e-3 deg), >= 1 */
    uint16_t max_iterations;   /* cap (the paper gives none) */
};

struct consensus_paper_result {
    enum consensus_status status;
    fix_udeg_t angle_udeg; /* mean of the converged vector; 0 unless status is OK */
    uint16_t iterations;
    fix_q30_t matrix[ANGLES_PER_AXIS][ANGLES_PER_AXIS]; /* P as computed (0 if not reached) */
};

/*
 * Alg. 1 on one axis: mean[] the window means of the five estimates (udeg Q16),
 * cov[][] their covariance (udeg², any common scale), complete the rows behind
 * them. The result is a number only when status is CONSENSUS_OK.
 */
void consensus_paper(const fix_udeg_q16_t mean[ANGLES_PER_AXIS],
                     const int64_t cov[ANGLES_PER_AXIS][ANGLES_PER_AXIS], uint16_t complete,
                     const struct consensus_paper_config *cfg, struct consensus_paper_result *out);

#endif /* ESTIMATOR_CONSENSUS_H */
