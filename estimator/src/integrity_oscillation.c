/* Motion whatever its shape: the angle combinations' scatter against the parity's. */
/* A plate librating with a near-whole period in the window leaves no ramp and no late
 * step, and its window mean is its mean attitude, up to the amplitude from the row's own.
 * Over the window's rows with all four readings valid, u_α = x_C − x_A and
 * u_β = x_B − x_D carry the sensors' noise plus the plate's motion (2·a·tan α, 2·a·tan β),
 * while p = x_A + x_C − x_B − x_D carries the noise alone (no rigid motion moves it), and
 * var p = σ_A² + σ_B² + σ_C² + σ_D² = var u_α + var u_β for noise alone, whatever each
 * sensor's σ. For block lengths L = 1, 2, 4, … 32 rows, the scatter of the block sums of
 * u_α and u_β (K blocks, K − 1 degrees of freedom each) is (K − 1)·var p for noise alone;
 * motion slower than the blocks keeps its variance in them while the noise's shrinks by
 * L, so some L sees any period from 2 rows up (the ramp and late-step statistics,
 * integrity_motion.c, see the slower ones). The excess E = X − (K − 1)·var p (X the two
 * axes' between-block scatter, per row) has under noise alone a variance of at most
 * var p²·(2(K − 1) + 2(K − 1)²/(n − 1)) (unequal σ, and var p itself estimated from n
 * rows). Cost: a few additions a row in the window end's ring pass (integrity.c). */
#include "integrity_internal.h"

/* A level needs at least MIN_BLOCKS blocks. */
#define OSC_MIN_BLOCKS 4u
/* The threshold k grows to k·√(1 + 6/(K − 1)) at few blocks: the χ² of 2(K − 1) degrees
 * of freedom has a long right tail (its 10^-4 point is 6.3 of its sd from the mean at
 * K = 4, 4.9 at K = 8, against 3.7 for a Gaussian). */
#define OSC_SMALL_K 6u

/* (e/p)² · den in Q16, for a test e > k sd when sd² = p²·num/den: (e/p)²·den > k²·num.
 * e/p is taken in Q16 and clamped at 256 (beyond every threshold here); 0 for e <= 0. */
static uint64_t ratio2_den(int64_t e, int64_t p, uint32_t den) {
    if (e <= 0) {
        return 0;
    }
    const uint32_t r =
        p <= 0 || e >= p * 256 ? (uint32_t)1 << 24 : (uint32_t)fix_muldiv_s64(e, 65536, p, NULL);
    return ((uint64_t)r * r >> 16) * den; /* r² < 2^48, den < 2^10 */
}

void integrity_oscillation_row(struct integrity_osc_sums *o,
                               const uint16_t range_mm[ANGLES_SENSORS]) {
    const int32_t xa = range_mm[ANGLES_A];
    const int32_t xb = range_mm[ANGLES_B];
    const int32_t xc = range_mm[ANGLES_C];
    const int32_t xd = range_mm[ANGLES_D];
    const int32_t p = xa + xc - xb - xd;
    o->n++;
    o->sp += p;
    o->spp += (int64_t)p * p;
    int32_t b[2] = {xc - xa, xb - xd};
    /* a block of level j closes every 2^j rows and carries its sums up to level j + 1 */
    for (unsigned j = 0; j < INTEGRITY_OSC_LEVELS; ++j) {
        struct integrity_osc_level *l = &o->level[j];
        for (unsigned a = 0; a < 2u; ++a) {
            l->run[a] += b[a];
        }
        if ((o->n & ((1u << j) - 1u)) != 0u) {
            break;
        }
        for (unsigned a = 0; a < 2u; ++a) {
            b[a] = l->run[a];
            l->sum[a] += b[a];
            l->sum2[a] += (int64_t)b[a] * b[a];
            l->run[a] = 0;
        }
        l->blocks++;
    }
}

fix_q32_t integrity_oscillation(const struct integrity_config *cfg, struct integrity_window *out) {
    const struct integrity_osc_sums *o = &out->osc;
    const uint32_t n = o->n; /* <= 1024 */
    fix_q32_t lag2 = 0;
    /* var p per row, Q32 mm² (n Σp² − (Σp)² is exact: |p| < 2^18, n <= 1024: below 2^56);
     * 0 (no test) below 2·MIN_BLOCKS rows or when p never changed */
    const int64_t var_p = n < 2u * OSC_MIN_BLOCKS
                              ? 0
                              : fix_muldiv_s64((int64_t)n * o->spp - o->sp * o->sp, FIX_Q32_ONE,
                                               (int64_t)n * ((int64_t)n - 1), NULL);
    for (unsigned j = 0; j < INTEGRITY_OSC_LEVELS && var_p > 0; ++j) {
        const struct integrity_osc_level *l = &o->level[j];
        const uint32_t k = l->blocks; /* <= 1024 */
        if (k < OSC_MIN_BLOCKS) {
            break;
        }
        /* the two axes' between-block scatter, per row: (K Σb² − (Σb)²)/(K L), Q32 mm² */
        const int64_t ss = (int64_t)k * (l->sum2[0] + l->sum2[1]) - (int64_t)l->sum[0] * l->sum[0] -
                           (int64_t)l->sum[1] * l->sum[1];
        const uint32_t dof = k - 1u;
        const uint64_t rows_j = (uint64_t)k << j;
        const int64_t e =
            fix_muldiv_s64(ss, FIX_Q32_ONE, (int64_t)rows_j, NULL) - var_p * (int64_t)dof;
        const uint32_t num = 2u * (dof + OSC_SMALL_K) * (n - 1u + dof); /* < 2^22 */
        const uint64_t z2 = ratio2_den(e, var_p, n - 1u);
        const uint32_t allow_q8 = INTEGRITY_MOTION_ALLOW_Q8;
        const uint64_t allow = allow_q8;
        if (z2 <= allow * allow * num) {
            continue;
        }
        /* The excess is n times the block means' motion variance (u units: 4·a²tan²);
         * twice that, the largest squared distance of a sinusoid from its mean, is the lag²
         * of either axis (the motion may be all in one): 2·e/(4n) in (a·tan)² */
        const fix_q32_t v = (fix_q32_t)fix_div_u64_u16((uint64_t)e, 2u * n);
        lag2 = v > lag2 ? v : lag2;
        if (z2 > (uint64_t)((uint32_t)cfg->motion_sigmas_q8 * cfg->motion_sigmas_q8) * num) {
            out->moved[INTEGRITY_ALPHA] = true;
            out->moved[INTEGRITY_BETA] = true;
        }
    }
    return lag2;
}
