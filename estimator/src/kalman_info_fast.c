/* The information form's fast solve of a uniform run (Q = 0): see estimator/kalman.h. */
#include "kalman_form.h"

/* --- the fast solve of a uniform run ----------------------------------------------------
 * While every row since the start accepted all four readings with the same weights w_s,
 * a_s = n·w_s and ζ_s = w_s·D_s (D_s the sum of sensor s's deviations): Y = n·(M0 + εI)
 * with M0 = Σ w_s h_s h_sᵀ constant and ε = y0/n, and Y δ = n·Σ h_s w_s μ_s with the means
 * μ_s = D_s/n. So δ = (M0 + εI)⁻¹ b = δ0 − ε·G·δ0 + O(ε²‖G‖²), G = M0⁻¹, δ0 = G b. From
 * the Schur formulas with y0 = 0, δ0 is a fixed mix of the four means:
 *     δx̄  = κ (μ_A + μ_C) + (1/2 − κ)(μ_D + μ_B),   κ = q_α/(2 d0)
 *     δθ_j = π_p μ_p − π_m μ_m − g_j δx̄,            π_s = w_s/W_j, g_j = π_p − π_m
 * (q_j = 4 w_m w_p / W_j, d0 = q_α + q_β), and G δ0 follows from 1/d0, 1/W_α, 1/W_β:
 * (Gδ)_0 = (δ0 − g_α δα − g_β δβ)/d0, (Gδ)_j = δ_j/W_j − g_j (Gδ)_0. The coefficients are
 * set once per run; a row costs one reciprocal of n and a dozen 32x32 products. The
 * prior's term is first order: the run uses it from the row n_fast on, where
 * ε‖G‖ < 2^-16 (its square, the neglected term, below 2^-32); before that, and whenever
 * a mean is 128 mm or more from x0, the general solve. P always comes from the sums. */

/* 2^(e + 16) / den (mm² Q16 for den in units), or −1 from 256 mm² on (the fast solve's
 * products stay below 2^62 with that bound). */
static int32_t info_inv_q16(uint64_t den, int32_t e) {
    const int32_t sh = e + 16;
    if (den == 0u || sh > 62) {
        return -1;
    }
    const uint64_t v = (sh >= 0 ? (uint64_t)1 << (unsigned)sh : 0u) / den;
    return v < ((uint64_t)1 << 24) ? (int32_t)v : -1;
}

/* The run's coefficients from its weights (once per run; exact 64-bit divisions). A run
 * they do not suit (noise beyond 256 mm²) never takes the fast solve (n_fast: never). */
void kalman_info_fast_prepare(struct kalman_info *in) {
    in->fast_ready = true;
    in->n_fast = UINT32_MAX;
    const uint64_t w[ANGLES_SENSORS] = {(uint64_t)in->w[0], (uint64_t)in->w[1], (uint64_t)in->w[2],
                                        (uint64_t)in->w[3]};
    const uint64_t w_al = w[ANGLES_A] + w[ANGLES_C]; /* <= 2^31 */
    const uint64_t w_be = w[ANGLES_B] + w[ANGLES_D];
    const uint64_t pi_a = (w[ANGLES_A] << 31) / w_al; /* < 2^31: w_C >= 1 */
    const uint64_t pi_c = (w[ANGLES_C] << 31) / w_al;
    const uint64_t pi_b = (w[ANGLES_B] << 31) / w_be;
    const uint64_t pi_d = (w[ANGLES_D] << 31) / w_be;
    in->pi[ANGLES_A] = (int32_t)pi_a;
    in->pi[ANGLES_C] = (int32_t)pi_c;
    in->pi[ANGLES_B] = (int32_t)pi_b;
    in->pi[ANGLES_D] = (int32_t)pi_d;
    /* q_j = 4 w_lo w_hi / W_j with 29 fraction bits: w_lo · π_hi (below 2^61), so the
     * weaker pair's share keeps its bits (whole units would cost κ up to 2^-19: review) */
    const uint64_t qh_al = w[ANGLES_A] < w[ANGLES_C] ? w[ANGLES_A] * pi_c : w[ANGLES_C] * pi_a;
    const uint64_t qh_be = w[ANGLES_D] < w[ANGLES_B] ? w[ANGLES_D] * pi_b : w[ANGLES_B] * pi_d;
    const uint64_t qh_sum = qh_al + qh_be; /* below 2^63 */
    if (qh_sum == 0u) {
        return; /* unreachable: every weight >= 1, so q_α > 0 */
    }
    const int32_t drop_exp = (int32_t)fix_bitlen_u64(qh_sum) - 33;
    const unsigned drop = drop_exp > 0 ? (unsigned)drop_exp : 0u;
    const uint64_t kappa = ((qh_al >> drop) << 30) / (qh_sum >> drop); /* q_α/(2 d0), Q31 */
    in->kappa = (int32_t)kappa;
    const uint64_t d0 = qh_sum >> 29; /* q_α + q_β in units */
    in->inv_q16[0] = info_inv_q16(d0, in->e);
    in->inv_q16[1] = info_inv_q16(w_al, in->e);
    in->inv_q16[2] = info_inv_q16(w_be, in->e);
    int32_t top = 0;
    for (unsigned j = 0; j < KALMAN_STATES; ++j) {
        if (in->inv_q16[j] < 0) {
            return;
        }
        top = in->inv_q16[j] > top ? in->inv_q16[j] : top;
    }
    /* ε‖G‖ <= 2^-24 · 3 · 2 · max(1/d0, 1/W) / n < 2^-16: n > 6 · top (Q16) / 2^24 */
    in->n_fast = 1u + (uint32_t)(((uint64_t)top * 6u) >> 24);
}

/* x from the run's means; false (nothing changed) when the run does not allow it. The
 * products are 32x32 -> 64 and every shift takes the 32-bit result from the two halves
 * (shr_to_s32): the solve costs about 200 instructions on a Cortex-M4. */
bool kalman_info_fast_solve(struct kalman_state *k) {
    struct kalman_info *in = kalman_info_of(k);
    if (in->n < in->n_fast) {
        return false;
    }
    int32_t en;
    const uint32_t mn = fix_norm31_inline(in->n, &en); /* en <= 0 below 2^31 rows */
    const int32_t rn = fix_recip31_inline(mn);         /* 1/n = rn · 2^(−61 − en) */
    const int32_t mean_exp = 37 + en;                  /* μ (Q24) = D · rn / 2^(37 + en) */
    const unsigned mean_shift = (unsigned)mean_exp;
    /* every |μ| = |D|/n below 128 mm (Q24 in an int32), so |D| < 2^31 below 2^24 rows */
    if (in->n >= ((uint32_t)1 << 24)) {
        return false;
    }
    const int64_t lim = (int64_t)in->n << 7;
    int32_t mu[ANGLES_SENSORS];
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const int64_t dsum = in->dsum[s];
        if (dsum >= lim || dsum <= -lim) {
            return false;
        }
        mu[s] = shr_to_s32((int64_t)(int32_t)dsum * rn, mean_shift);
    }
    /* δ0 in Q55 (Q31 × Q24), then Q24 */
    const int32_t kb = (int32_t)0x40000000 - in->kappa;
    const int64_t dx55 = (int64_t)in->kappa * mu[ANGLES_A] + (int64_t)in->kappa * mu[ANGLES_C] +
                         (int64_t)kb * mu[ANGLES_D] + (int64_t)kb * mu[ANGLES_B];
    const int32_t dx = shr_to_s32(dx55, 31u); /* |δx̄| < 128 mm */
    const int32_t ga = in->pi[ANGLES_C] - in->pi[ANGLES_A];
    const int32_t gb = in->pi[ANGLES_B] - in->pi[ANGLES_D];
    const int64_t ta55 = (int64_t)in->pi[ANGLES_C] * mu[ANGLES_C] -
                         (int64_t)in->pi[ANGLES_A] * mu[ANGLES_A] - (int64_t)ga * dx;
    const int64_t tb55 = (int64_t)in->pi[ANGLES_B] * mu[ANGLES_B] -
                         (int64_t)in->pi[ANGLES_D] * mu[ANGLES_D] - (int64_t)gb * dx;
    /* |δθ| below 128 mm as well (Q24 in an int32): data far from the model (A + C far from
     * B + D, a pair of unequal weights) can reach 256 mm with every mean below 128 mm
     * (found by review); those rows take the general solve */
    const int64_t theta_limit = (int64_t)1 << 62;
    if (ta55 >= theta_limit || ta55 <= -theta_limit || tb55 >= theta_limit ||
        tb55 <= -theta_limit) {
        return false;
    }
    const int32_t ta = shr_to_s32(ta55, 31u);
    const int32_t tb = shr_to_s32(tb55, 31u);
    /* The prior: − ε G δ0 with ε = 2^-24/n mm⁻², at most 2^-16 of δ0 (n >= n_fast): ten bits
     * of it are enough, so δ in Q16 and G δ in Q8 (mm³), 32-bit. */
    const int32_t dx16 = shr_to_s32(dx, 8u);
    const int32_t ta16 = shr_to_s32(ta, 8u);
    const int32_t tb16 = shr_to_s32(tb, 8u);
    const int32_t c0 = dx16 - shr_to_s32((int64_t)ga * ta16 + (int64_t)gb * tb16, 31u); /* Q16 */
    const int32_t g0 = shr_to_s32((int64_t)c0 * in->inv_q16[0], 24u); /* (Gδ)_0, Q8 */
    const int32_t g1 =
        shr_to_s32((int64_t)ta16 * in->inv_q16[1], 24u) - shr_to_s32((int64_t)ga * g0, 31u);
    const int32_t g2 =
        shr_to_s32((int64_t)tb16 * in->inv_q16[2], 24u) - shr_to_s32((int64_t)gb * g0, 31u);
    /* ε (Gδ) in Q32 = (Gδ)_Q8 · 2^24 · 2^-24 / n = (Gδ)_Q8 · rn / 2^(61 + en) */
    const int32_t corr_exp = 61 + en;
    const unsigned corr_shift = (unsigned)corr_exp;
    k->x[0] = ((int64_t)in->x0_mm << FIX_Q32_SHIFT) + (int64_t)dx * 256 -
              shr_to_s32((int64_t)g0 * rn, corr_shift);
    k->x[1] = (int64_t)ta * 256 - shr_to_s32((int64_t)g1 * rn, corr_shift);
    k->x[2] = (int64_t)tb * 256 - shr_to_s32((int64_t)g2 * rn, corr_shift);
    return true;
}
