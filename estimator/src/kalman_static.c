/* The Kalman filter's static run: Q = 0 rows as one LS correction each (kalman_internal.h). */
#include "kalman_internal.h"

/* With Q = 0 the information after n rows of four accepted readings with the same R is
 * y0·I + n·M, M = Σ_s h_s h_sᵀ/R_s; once the diffuse prior's y0 (2^-24 mm⁻²) is negligible
 * against n·M, P = M⁻¹/c with c = n (plus the prior's share). A row of four readings then
 * adds M: P' = M⁻¹/(c + 1), and the four scalar updates together move x by
 * P' Hᵀ R⁻¹ e = G e/(c + 1), G = M⁻¹ Hᵀ R⁻¹ the least-squares solution of one row (G H = I,
 * so G e is that row's solution minus x). No row has both slopes, so G is short: per axis
 * j with its minus and plus sensors m, p (α: A, C; β: D, B), S_j = R_m + R_p,
 *     δx̄ = κ (e_A + e_C) + (1/2 − κ)(e_B + e_D),            κ = S_β / (2 (S_α + S_β)),
 *     δθ_j = (R_m e_p − R_p e_m)/S_j − g_j δx̄,               g_j = (R_m − R_p)/S_j,
 * and M⁻¹ in closed form, Σ = S_α + S_β, o the other axis, Δ_j = R_m − R_p:
 *     M⁻¹_00 = S_α S_β/(4Σ),  M⁻¹_0j = −Δ_j S_o/(4Σ),  M⁻¹_12 = Δ_α Δ_β/(4Σ),
 *     M⁻¹_jj = R_m R_p/S_j − Δ_j M⁻¹_0j/S_j.
 * The run starts when P (from the scalar updates) is M⁻¹/c within 2^-18 of its diagonal,
 * c from P_00; what P differed by then shrinks as c/(c + rows) (the information's excess
 * stays, the rows' grows). Each reading is gated against the state before the row (the
 * sure-accept bound, true for any s >= R); one outside it, a reading missing, an R change
 * or a reset ends the run, and that row runs as four scalar updates. Cost: four
 * innovations, nine 32x32 products, one reciprocal of c + 1. */

#define STATIC_TOL_SHIFT 19u /* (M⁻¹_ii + M⁻¹_jj) / 2^19: 2^-18 of their mean */
#define STATIC_U_MAX     ((int64_t)1 << 61) /* c + 1 below 2^29 rows (Q32; one row is FIX_Q32_ONE) */

void kalman_static_try(struct kalman_state *k) {
    struct kalman_cov *cv = &k->cov;
    const fix_q32_t *r = k->r;
    bool ovf = false;
    const int64_t sa = r[ANGLES_A] + r[ANGLES_C]; /* each R <= 2^52 */
    const int64_t sb = r[ANGLES_B] + r[ANGLES_D];
    const int64_t s4 = 4 * (sa + sb);
    const int64_t da = r[ANGLES_A] - r[ANGLES_C];
    const int64_t db = r[ANGLES_D] - r[ANGLES_B];
    int64_t m[6];
    m[0] = fix_muldiv_s64(sa, sb, s4, &ovf);
    m[1] = -fix_muldiv_s64(da, sb, s4, &ovf);
    m[2] = -fix_muldiv_s64(db, sa, s4, &ovf);
    m[4] = fix_muldiv_s64(da, db, s4, &ovf);
    m[3] = fix_muldiv_s64(r[ANGLES_A], r[ANGLES_C], sa, &ovf) - fix_muldiv_s64(da, m[1], sa, &ovf);
    m[5] = fix_muldiv_s64(r[ANGLES_D], r[ANGLES_B], sb, &ovf) - fix_muldiv_s64(db, m[2], sb, &ovf);
    cv->still_broken = true; /* one try per start: a P that is not M⁻¹/c stays so */
    if (cv->p[0][0] <= 0 || m[0] <= 0 || m[3] <= 0 || m[5] <= 0) {
        return;
    }
    const int64_t c = fix_muldiv_s64(m[0], FIX_Q32_ONE, cv->p[0][0], &ovf); /* Q32 */
    if (ovf || c < FIX_Q32_ONE || c >= STATIC_U_MAX - FIX_Q32_ONE) {
        return;
    }
    const int64_t diag[3] = {m[0], m[3], m[5]};
    for (unsigned i = 0; i < 6u; ++i) {
        const unsigned a = kalman_packed_row(i);
        const unsigned b = kalman_packed_col(i);
        const int64_t v = fix_muldiv_s64(cv->p[a][b], c, FIX_Q32_ONE, &ovf);
        const int64_t tol = (diag[a] >> STATIC_TOL_SHIFT) + (diag[b] >> STATIC_TOL_SHIFT);
        const int64_t d = v - m[i];
        if (ovf || d > tol || d < -tol) {
            return;
        }
    }
    const int64_t one31 = (int64_t)1 << 31;
    cv->run_kappa = (int32_t)fix_muldiv_s64(sb, one31, 2 * (sa + sb), &ovf);
    cv->run_wp[0] = (int32_t)fix_muldiv_s64(r[ANGLES_A], one31, sa, &ovf); /* of e_C */
    cv->run_wm[0] = (int32_t)fix_muldiv_s64(r[ANGLES_C], one31, sa, &ovf); /* of e_A */
    cv->run_wp[1] = (int32_t)fix_muldiv_s64(r[ANGLES_D], one31, sb, &ovf); /* of e_B */
    cv->run_wm[1] = (int32_t)fix_muldiv_s64(r[ANGLES_B], one31, sb, &ovf); /* of e_D */
    if (ovf) {
        return;
    }
    for (unsigned i = 0; i < 6u; ++i) {
        cv->run_minv[i] = m[i];
    }
    cv->run_u = c + FIX_Q32_ONE;
    cv->still = true;
    cv->still_broken = false;
    cv->bvalid = false; /* p is left behind; the block is taken afresh after the run */
}

/* |e| < 32 mm: e in Q24 then fits 30 bits, and every sum below int64. */
FIX_INLINE bool innovation24(const struct kalman_state *k, unsigned s, uint16_t z, bool gated,
                             int32_t *e24) {
    const unsigned j = kalman_h_index(s);
    const fix_q32_t pred = kalman_h_minus(s) ? k->x[0] - k->x[j] : k->x[0] + k->x[j];
    const fix_q32_t e = ((fix_q32_t)z << FIX_Q32_SHIFT) - pred;
    const uint32_t e_hi = (uint32_t)((uint64_t)e >> 32) + 32u;
    if (e_hi > 63u) {
        return false;
    }
    const int32_t v = fix_shr_to_s32(e + 128, 8u); /* rounded to Q24 */
    *e24 = v;
    const int64_t v2 = (int64_t)v * v;
    return !gated || (uint64_t)v2 <= k->gate_accept[s];
}

bool kalman_static_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS], bool gate) {
    struct kalman_cov *cv = &k->cov;
    const bool gated = gate && k->cfg.gate_sigmas_q8 != 0u;
    int32_t e[ANGLES_SENSORS];
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if (!innovation24(k, s, range_mm[s], gated, &e[s])) {
            return false;
        }
    }
    if (cv->run_u >= STATIC_U_MAX) {
        return false;
    }
    const int32_t ka = cv->run_kappa;           /* of e_A + e_C */
    const int32_t kb = ((int32_t)1 << 30) - ka; /* of e_B + e_D */
    const int64_t dx55 =
        (int64_t)ka * (e[ANGLES_A] + e[ANGLES_C]) + (int64_t)kb * (e[ANGLES_B] + e[ANGLES_D]);
    const int32_t dx = (int32_t)fix_round_shr_s64(dx55, 31u);
    const int64_t da55 = (int64_t)cv->run_wp[0] * e[ANGLES_C] -
                         (int64_t)cv->run_wm[0] * e[ANGLES_A] -
                         (int64_t)(cv->run_wp[0] - cv->run_wm[0]) * dx;
    const int64_t db55 = (int64_t)cv->run_wp[1] * e[ANGLES_B] -
                         (int64_t)cv->run_wm[1] * e[ANGLES_D] -
                         (int64_t)(cv->run_wp[1] - cv->run_wm[1]) * dx;
    const int32_t da = (int32_t)fix_round_shr_s64(da55, 31u);
    const int32_t db = (int32_t)fix_round_shr_s64(db55, 31u);
    /* x += δ/u: u = sm·2^es (Q32), rm ≈ 2^61/sm; δ in Q24 -> Q32: δ·rm / 2^(21 + es) */
    int32_t es;
    const uint32_t sm = fix_norm31_inline((uint64_t)cv->run_u, &es);
    const int64_t rm = fix_recip31_inline(sm);
    const int32_t sh_signed = 21 + es; /* u >= 2^33: es >= 3 */
    const unsigned sh = (unsigned)sh_signed;
    k->x[0] += fix_round_shr_s64((int64_t)dx * rm, sh);
    k->x[1] += fix_round_shr_s64((int64_t)da * rm, sh);
    k->x[2] += fix_round_shr_s64((int64_t)db * rm, sh);
    cv->run_u += FIX_Q32_ONE;
    return true;
}

void kalman_static_covariance(const struct kalman_state *k,
                              fix_q32_t p[KALMAN_STATES][KALMAN_STATES]) {
    const struct kalman_cov *cv = &k->cov;
    const int64_t c = cv->run_u - FIX_Q32_ONE; /* the rows so far */
    for (unsigned i = 0; i < 6u; ++i) {
        const unsigned a = kalman_packed_row(i);
        const unsigned b = kalman_packed_col(i);
        p[a][b] = fix_muldiv_s64(cv->run_minv[i], FIX_Q32_ONE, c, NULL);
        p[b][a] = p[a][b];
    }
}

void kalman_static_leave(struct kalman_state *k) {
    kalman_static_covariance(k, k->cov.p);
    k->cov.still = false;
    k->cov.bvalid = false;
}
