/* The Kalman filter's innovation gate: see kalman_internal.h and estimator/kalman.h. */
#include "kalman_internal.h"

void kalman_gate_init(struct kalman_state *k) {
    const uint64_t q2 = (uint64_t)k->cfg.gate_sigmas_q8 * k->cfg.gate_sigmas_q8;
    k->gate_s_max = q2 == 0u ? 0u : UINT64_MAX / q2;
}

/* e² > max(k²·s, floor²) with e in Q32 mm and s in Q32 mm², exactly. */
static bool outside_gate(const struct kalman_state *k, fix_q32_t e, fix_q32_t s) {
    const fix_s128 e2 = fix_s128_mul(e, e); /* Q64 */
    const int64_t g = k->cfg.gate_sigmas_q8;
    /* k² s in Q64 = s · g² · 2^16 (g in Q8, s in Q32) */
    const fix_s128 ks = fix_s128_shl(fix_s128_mul(s, g * g), 16u);
    const int64_t fl = k->cfg.gate_floor_mm;
    const fix_s128 fl2 = fix_s128_shl(fix_s128_from_s64(fl * fl), 64u);
    return fix_s128_cmp(e2, ks) > 0 && fix_s128_cmp(e2, fl2) > 0;
}

/* Gate with 64-bit products when they cannot overflow (e in Q24, s·k² below 2^64):
 * e24² (Q48) against s·k² (Q32·Q16); else exactly in 128 bits. */
bool kalman_gated_out(const struct kalman_state *k, fix_q32_t e, fix_q32_t s) {
    if (e < ((int64_t)1 << 39) && e > -((int64_t)1 << 39) && (uint64_t)s <= k->gate_s_max) {
        const int64_t e24 = fix_round_shr_s64(e, 8u);
        const uint64_t m = (uint64_t)(e24 < 0 ? -e24 : e24);
        const uint64_t q = k->cfg.gate_sigmas_q8;
        return m * m > (uint64_t)s * (q * q) && m > ((uint64_t)k->cfg.gate_floor_mm << 24);
    }
    return outside_gate(k, e, s);
}

/* The gate's sure-accept threshold per sensor: |e24|² (Q48) below q²·R (Q32·Q16) or the
 * floor is inside the gate for any s >= R. */
void kalman_gate_refresh(struct kalman_state *k) {
    const uint64_t q2 = (uint64_t)k->cfg.gate_sigmas_q8 * k->cfg.gate_sigmas_q8;
    const uint64_t fl = (uint64_t)k->cfg.gate_floor_mm;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const uint64_t r = (uint64_t)k->r[s];
        const uint64_t a = r > UINT64_MAX / (q2 + 1u) ? UINT64_MAX : r * q2;
        const uint64_t f = fl >= 256u ? UINT64_MAX : (fl * fl) << 48; /* 2^64 from 256 mm */
        k->gate_accept[s] = a > f ? a : f;
    }
}
