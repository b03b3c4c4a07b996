/* The Kalman filter's steady state at Q > 0: a settled P's gains kept, and the rows that
 * reuse them (kalman_track.c calls down into this file). */
#include "kalman_internal.h"

/* --- the steady state -------------------------------------------------------------------
 * With Q > 0 and R constant, P converges to the fixed point of the Riccati recursion, and
 * with it the four scalar updates' gains: once a row with all four readings (every one a
 * block update, none gated out) leaves P settled (below), its gains are kept and the following rows
 * with all four readings are x += k_s e_s alone, A..D, P left at that fixed point
 * (tests/estimator/ref_tracking.cpp: the ratio to the optimal filter is unchanged to three
 * decimals). Anything else ends it: a reading missing, one outside the gate's sure-accept bound
 * (the row then runs in full, gated exactly), an R or Q change, a reset. */
#define STEADY_TOL_SHIFT 8u
/* With process_noise_auto the Q itself is learnt to within a factor 1.5 (kalman_adapt.c),
 * so gains within 2^-5 of the fixed point's (P settled to 2^-4 of Q a row) cost nothing
 * measurable (tests/estimator/ref_tracking.cpp: the sweep's ratios unchanged to 0.01), while a Q
 * change settles in fewer full rows: the M4 cost of a row with `auto` 2 082 -> 1 892. */
#define STEADY_TOL_SHIFT_AUTO 4u

/* One steady row, all four readings; false (x unchanged) when one may be gated out or
 * is 128 mm or more from its prediction. */
bool kalman_steady_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS], bool gate) {
    const struct kalman_cov *cv = &k->cov;
    const fix_q32_t x0 = k->x[0];
    const fix_q32_t x1 = k->x[1];
    const fix_q32_t x2 = k->x[2];
    const bool gated = gate && k->cfg.gate_sigmas_q8 != 0u;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const unsigned j = kalman_h_index(s);
        const fix_q32_t pred = kalman_h_minus(s) ? k->x[0] - k->x[j] : k->x[0] + k->x[j];
        const fix_q32_t e = ((fix_q32_t)range_mm[s] << FIX_Q32_SHIFT) - pred;
        const uint32_t e_hi = (uint32_t)((uint64_t)e >> 32) + 128u;
        const int32_t e24 = fix_shr_to_s32(e + 128, 8u);
        const int64_t e24_sq = (int64_t)e24 * e24;
        if (e_hi > 255u || (gated && (uint64_t)e24_sq > k->gate_accept[s])) {
            k->x[0] = x0;
            k->x[1] = x1;
            k->x[2] = x2;
            return false;
        }
        for (unsigned i = 0; i < KALMAN_STATES; ++i) {
            k->x[i] += fix_round_shr_s64((int64_t)cv->gain[s][i] * e24, 23u);
        }
    }
    return true;
}

/* P settled: every entry moved by at most 2^-STEADY_TOL_SHIFT of the smallest non-zero Q
 * since the row before (`before`, packed upper triangle). Near the fixed point a row
 * moves P by about Q/P of its remaining distance (the recursion contracts by 1 − Q/P per
 * row, P ≈ √(QR) in the scalar case), so the distance left is below 2^-STEADY_TOL_SHIFT
 * of P: the kept gains are within that of the fixed point's, costing the estimate's
 * variance only that squared. */
bool kalman_steady_settled(const struct kalman_state *k, const fix_q32_t before[6]) {
    const struct kalman_cov *cv = &k->cov;
    const fix_q32_t *q = k->cfg.process_noise_mm2;
    uint64_t q_min = UINT64_MAX;
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        q_min = q[i] != 0 && (uint64_t)q[i] < q_min ? (uint64_t)q[i] : q_min;
    }
    const uint64_t tol =
        q_min >> (k->cfg.process_noise_auto ? STEADY_TOL_SHIFT_AUTO : STEADY_TOL_SHIFT);
    const fix_q32_t now[6] = {cv->p[0][0], cv->p[0][1], cv->p[0][2],
                              cv->p[1][1], cv->p[1][2], cv->p[2][2]};
    for (unsigned i = 0; i < 6u; ++i) {
        if (fix_abs_u64(now[i] - before[i]) > tol) {
            return false;
        }
    }
    return true;
}
