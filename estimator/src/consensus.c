/* Consensus fusion, paper and product rules: see estimator/consensus.h. */
#include "estimator/consensus.h"

#include <string.h>

#include "fixmath_internal.h"

/* 1/12 mm² (uniform 1 mm quantisation, Sheppard) in Q32: the smallest sample
 * variance a sensor reporting integer millimetres can honestly be given. */
#define QUANT_VAR_Q32 357913941

const char *consensus_status_name(enum consensus_status status) {
    switch (status) {
    case CONSENSUS_OK:
        return "ok";
    case CONSENSUS_UNOBSERVABLE:
        return "unobservable";
    case CONSENSUS_TOO_FEW_ROWS:
        return "too-few-rows";
    case CONSENSUS_NONPOSITIVE_VARIANCE:
        return "nonpositive-variance";
    case CONSENSUS_ZERO_COVARIANCE:
        return "zero-covariance";
    case CONSENSUS_ZERO_ROW_SUM:
        return "zero-row-sum";
    case CONSENSUS_NEGATIVE_ROW_SUM:
        return "negative-row-sum";
    case CONSENSUS_OVERFLOW:
        return "overflow";
    case CONSENSUS_DIVERGED:
        return "diverged";
    case CONSENSUS_NO_CONVERGENCE:
        return "no-convergence";
    case CONSENSUS_OUTSIDE_HULL:
        return "outside-hull";
    default:
        return "unknown";
    }
}

/* --- product rule ------------------------------------------------------------------ */

/* Sensors of one axis in the generic frame: low = x̄ − a·t, high = x̄ + a·t,
 * ref1 = x̄ + a·o, ref2 = x̄ − a·o (o: the other axis, sign per frame). */
struct axis_frame {
    unsigned low;
    unsigned ref1;
    unsigned high;
    unsigned ref2;
};
static const struct axis_frame alpha_frame = {ANGLES_A, ANGLES_B, ANGLES_C, ANGLES_D};
static const struct axis_frame beta_frame = {ANGLES_D, ANGLES_A, ANGLES_B, ANGLES_C};

/* What both axes and x̄ share: the arm's reciprocal, the variances of the four window
 * means and the tolerance in slope units. */
struct product_prep {
    struct angles_arm arm;
    fix_q28_t var_mean[ANGLES_SENSORS]; /* Q28 mm², 0 for a sensor not used */
    fix_q32_t tol_q32;
};

/* (hi − lo)/(span·a) as a Q32 slope from Q32 mm means (|hi − lo| < 2^48), rounded half
 * away from zero: |hi − lo| times the Q(31 + shift) reciprocal of a (angles_arm_prepare,
 * relative error < 2^-31), two 32x32 -> 64 products. */
static fix_q32_t slope_q32(fix_q32_t hi_mm, fix_q32_t lo_mm, const struct angles_arm *arm,
                           unsigned span) {
    const int64_t diff = hi_mm - lo_mm;
    const uint64_t m = fix_abs_u64(diff);
    const uint64_t p_lo = (m & 0xFFFFFFFFu) * arm->inv;
    uint64_t p_hi = (m >> 32) * arm->inv + (p_lo >> 32);               /* product / 2^32, < 2^49 */
    const unsigned total = arm->shift + span;                          /* >= 2 */
    const unsigned s2 = (total > 2u && total < 14u) ? total - 2u : 0u; /* 31 + sh + span − 1 − 32 */
    uint64_t q;
    if (s2 == 0u) {
        q = p_hi + ((p_lo >> 31) & 1u);
    } else {
        p_hi += (uint64_t)1 << (s2 - 1u);
        q = p_hi >> s2;
    }
    return diff < 0 ? -(int64_t)q : (int64_t)q;
}

/* Variance of a window mean in Q28 mm²: max(s², 1/12)/n, rounded (n <= 65535: two
 * exact divisions, floor(floor(x / 16) / n) = floor(x / 16n)). */
static fix_q28_t mean_var_q28(const struct consensus_sensor *s) {
    const fix_q32_t v = s->var_mm2 > QUANT_VAR_Q32 ? s->var_mm2 : QUANT_VAR_Q32;
    const uint32_t n = s->count;
    const uint64_t num = ((uint64_t)v + 8u * (uint64_t)n) >> 4;
    return (fix_q28_t)fix_div_u64_u16(num, n);
}

/* num / den as a Q31 fraction for 0 <= num <= den, den > 0 (relative error < 2^-27). */
static int32_t fraction_q31(int64_t num, int64_t den) {
    int32_t e;
    const uint32_t dm = fix_norm31((uint64_t)den, &e);
    const int32_t rm = fix_recip31(dm);
    const int64_t nm = e >= 0 ? fix_floor_shr_s64(num, (unsigned)e)
                              : num * ((int64_t)1 << (unsigned)(-e)); /* <= dm < 2^31 */
    const int64_t f = fix_floor_shr_s64(nm * rm, 30u);                /* Q31 */
    return f < INT32_MAX ? (int32_t)f : INT32_MAX;
}

/* v / 2 rounded half away from zero (|v| < 2^62). */
static int64_t half_away(int64_t v) {
    return v >= 0 ? (v + 1) / 2 : -((1 - v) / 2);
}

/* v ← ((1 − ε)I + ε1πᵀ)v with ε = 1/2 until spread <= tol. P v = (v + c1)/2 with
 * c = πᵀv, which P leaves unchanged (πᵀP = πᵀ), so c is computed once, exactly: the
 * weights sum to 2^30, so c = v_ref + round(Σ π_i (v_i − v_ref) / 2^30), in 64 bits when
 * the spread is below 2^30 (each term then below 2^60), else with 128-bit products.
 * Returns c, the consensus value. */
static fix_q32_t iterate_product(struct consensus_axis *ax, fix_q32_t tol_q32) {
    const fix_q32_t *v = ax->initial;
    fix_q32_t lo = INT64_MAX;
    fix_q32_t hi = INT64_MIN;
    fix_q32_t ref = 0;
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        if ((ax->used & (1u << i)) != 0u) {
            ref = v[i];
            lo = v[i] < lo ? v[i] : lo;
            hi = v[i] > hi ? v[i] : hi;
        }
    }
    fix_q32_t c;
    if (hi - lo < ((int64_t)1 << 30)) {
        int64_t acc = 0;
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            if ((ax->used & (1u << i)) != 0u) {
                acc += ax->weight[i] * (v[i] - ref);
            }
        }
        c = ref + fix_shr_round_s64(acc, FIX_Q30_SHIFT);
    } else {
        fix_s128 acc = fix_s128_from_s64(0);
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            if ((ax->used & (1u << i)) != 0u) {
                acc = fix_s128_add(acc, fix_s128_mul(ax->weight[i], v[i]));
            }
        }
        c = fix_s128_to_s64(fix_s128_shr_round(acc, FIX_Q30_SHIFT), NULL);
    }
    /* The iteration on the deviations d = v − c: (P v)_i − c = (v_i − c)/2, rounded half
     * away from zero. That map is monotone, so the largest and the smallest deviation stay
     * the largest and the smallest, and the spread after k steps is that of those two
     * alone: they are all the stopping test needs (the other entries are not output). */
    ax->status = CONSENSUS_NO_CONVERGENCE;
    int64_t d_hi = hi - c;
    int64_t d_lo = lo - c;
    unsigned it = 0;
    /* a spread of 2^30 and more (slopes apart by more than 1/4) is above every tolerance
     * (10^7 udeg is 7.5·10^8 LSB): halve it in 64 bits first (at most 33 steps) */
    for (; it < CONSENSUS_PRODUCT_MAX_ITERATIONS && d_hi - d_lo >= ((int64_t)1 << 30); ++it) {
        d_hi = half_away(d_hi);
        d_lo = half_away(d_lo);
    }
    int32_t h32 = (int32_t)d_hi; /* c lies between them: |d| <= spread < 2^30 */
    int32_t l32 = (int32_t)d_lo;
    const int32_t tol = tol_q32 < INT32_MAX ? (int32_t)tol_q32 : INT32_MAX;
    /* Each pass ends the loop or advances `it`, which ends it at the cap. */
    bool done = false;
    while (!done) {
        if (h32 - l32 <= tol) {
            ax->status = CONSENSUS_OK;
            done = true;
        } else if (it >= CONSENSUS_PRODUCT_MAX_ITERATIONS) {
            done = true; /* cannot happen while tol > 4 LSB (header proof); reported if it does */
        } else {
            h32 = h32 >= 0 ? (h32 + 1) / 2 : -((1 - h32) / 2);
            l32 = l32 >= 0 ? (l32 + 1) / 2 : -((1 - l32) / 2);
            ++it;
        }
    }
    ax->iterations = (uint16_t)it;
    return c;
}

/* v(0): the five slopes of Eq. 1 in this frame that ax->used selects, compensated by
 * `other` (t̂ of the other axis). Inlined: product_axis's one call. */
FIX_INLINE void initial_slopes(const struct consensus_sensor *s, const struct product_prep *pp,
                               const struct axis_frame *f, fix_q32_t other,
                               struct consensus_axis *ax) {
    const fix_q32_t low = s[f->low].mean_mm;
    const fix_q32_t high = s[f->high].mean_mm;
    const fix_q32_t r1 = s[f->ref1].mean_mm;
    const fix_q32_t r2 = s[f->ref2].mean_mm;
    if ((ax->used & 0x01u) != 0u) {
        ax->initial[0] = slope_q32(r1, low, &pp->arm, 1u) - other; /* s1 = t + o */
    }
    if ((ax->used & 0x02u) != 0u) {
        ax->initial[1] = slope_q32(r2, low, &pp->arm, 1u) + other; /* s2 = t − o */
    }
    if ((ax->used & 0x04u) != 0u) {
        ax->initial[2] = slope_q32(high, r1, &pp->arm, 1u) + other; /* s3 = t − o */
    }
    if ((ax->used & 0x08u) != 0u) {
        ax->initial[3] = slope_q32(high, r2, &pp->arm, 1u) - other; /* s4 = t + o */
    }
    if ((ax->used & 0x10u) != 0u) {
        ax->initial[4] = slope_q32(high, low, &pp->arm, 2u); /* s5 = t */
    }
}

static void product_axis(const struct consensus_product_input *in, const struct product_prep *pp,
                         const struct axis_frame *f, struct consensus_axis *ax) {
    (void)memset(ax, 0, sizeof *ax);
    const struct consensus_sensor *s = in->sensor;
    const bool has_low = s[f->low].used;
    const bool has_high = s[f->high].used;
    const bool has_refs = s[f->ref1].used && s[f->ref2].used;
    const fix_q28_t v_low = pp->var_mean[f->low];
    const fix_q28_t v_high = pp->var_mean[f->high];
    /* m = var of the reference midpoint (m_ref1 + m_ref2)/2 */
    const fix_q28_t m = has_refs ? (pp->var_mean[f->ref1] + pp->var_mean[f->ref2] + 2) / 4 : 0;

    fix_q32_t other = 0; /* t̂ of the other axis in this frame: (ref1 − ref2)/2a */
    if (has_refs) {
        other = slope_q32(s[f->ref1].mean_mm, s[f->ref2].mean_mm, &pp->arm, 2u);
    }
    fix_q28_t var_at = 0; /* variance of a·t̂ in Q28 mm² */
    if (has_low && has_high && has_refs) {
        ax->used = 0x1F;
        /* π_low ∝ 2m + V_high, π_high ∝ 2m + V_low; π5 = 2·min, the rest split. Every
         * V < 2^59 (a variance below 2^31 mm² over n >= 1), so no sum overflows. */
        const int64_t w_low = 2 * m + v_high;
        const int64_t w_high = 2 * m + v_low;
        /* equal halves exactly (equal noise: π = e5, mean(α5) as a slope) */
        const fix_q30_t pi_low =
            w_low == w_high ? FIX_Q30_ONE / 2 : fraction_q31(w_low, w_low + w_high) / 2;
        const fix_q30_t pi_high = FIX_Q30_ONE - pi_low;
        const fix_q30_t common = pi_low < pi_high ? pi_low : pi_high;
        ax->weight[4] = 2 * common;
        ax->weight[0] = (pi_low - common) / 2;
        ax->weight[1] = pi_low - common - ax->weight[0];
        ax->weight[2] = (pi_high - common) / 2;
        ax->weight[3] = pi_high - common - ax->weight[2];
        /* var(a·t̂) = (V_l V_h + m (V_l + V_h)) / (V_l + V_h + 4m)
         *          = V_l · V_h/D + m · (V_l + V_h)/D, both fractions below 1 */
        const int64_t d = v_low + v_high + 4 * m;
        var_at = fix_mul_q31(v_low, fraction_q31(v_high, d)) +
                 fix_mul_q31(m, fraction_q31(v_low + v_high, d));
    } else if (!has_low && has_high && has_refs) {
        ax->used = 0x0C; /* v3, v4: (high − M)/a */
        ax->weight[2] = FIX_Q30_ONE / 2;
        ax->weight[3] = FIX_Q30_ONE / 2;
        var_at = v_high + m;
    } else if (has_low && !has_high && has_refs) {
        ax->used = 0x03; /* v1, v2: (M − low)/a */
        ax->weight[0] = FIX_Q30_ONE / 2;
        ax->weight[1] = FIX_Q30_ONE / 2;
        var_at = v_low + m;
    } else if (has_low && has_high) {
        ax->used = 0x10; /* a reference is missing: v5 alone */
        ax->weight[4] = FIX_Q30_ONE;
        var_at = (v_low + v_high + 2) / 4;
    } else {
        ax->status = CONSENSUS_UNOBSERVABLE;
        return;
    }

    initial_slopes(s, pp, f, other, ax);
    ax->tan_q32 = iterate_product(ax, pp->tol_q32);
    ax->angle_udeg = fix_atan_q32_udeg(ax->tan_q32);
    ax->sigma_udeg = fix_angle_sigma_udeg(fix_sat_mul_s64(var_at, 16), in->arm_um, ax->tan_q32);
}

void consensus_product(const struct consensus_product_input *in,
                       struct consensus_product_result *out) {
    struct product_prep pp;
    angles_arm_prepare(&pp.arm, in->arm_um);
    const struct consensus_sensor *s = in->sensor;
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        pp.var_mean[k] = s[k].used ? mean_var_q28(&s[k]) : 0;
    }
    /* tolerance in slope units: |Δatan| <= |Δt|, so a slope spread <= tol_rad
     * guarantees an angle spread <= tol */
    pp.tol_q32 =
        fix_div_trunc_s64((fix_q32_t)in->tolerance_udeg * FIX_Q32_RAD_PER_UDEG_X1000, 1000);
    product_axis(in, &pp, &alpha_frame, &out->alpha);
    product_axis(in, &pp, &beta_frame, &out->beta);

    /* x̄: each complete opposite pair gives its midpoint, exactly free of the
     * tilt; both pairs are combined by inverse variance:
     * mid_ac + (mid_bd − mid_ac) · v_ac / (v_ac + v_bd). */
    const bool ac = s[ANGLES_A].used && s[ANGLES_C].used;
    const bool bd = s[ANGLES_B].used && s[ANGLES_D].used;
    out->distance_valid = ac || bd;
    out->distance_mm = 0;
    const fix_q32_t mid_ac = (s[ANGLES_A].mean_mm + s[ANGLES_C].mean_mm) / 2;
    const fix_q32_t mid_bd = (s[ANGLES_B].mean_mm + s[ANGLES_D].mean_mm) / 2;
    if (ac && bd) {
        const fix_q28_t v_ac = pp.var_mean[ANGLES_A] + pp.var_mean[ANGLES_C];
        const fix_q28_t v_bd = pp.var_mean[ANGLES_B] + pp.var_mean[ANGLES_D];
        out->distance_mm = mid_ac + fix_mul_q31(mid_bd - mid_ac, fraction_q31(v_ac, v_ac + v_bd));
    } else if (ac) {
        out->distance_mm = mid_ac;
    } else if (bd) {
        out->distance_mm = mid_bd;
    } else {
        /* no complete pair: distance_valid is false and distance_mm stays 0 */
    }
}

/* --- paper rule ---------------------------------------------------------------------- */

/* Builds P of Eq. 3-4 in Q30. Returns CONSENSUS_OK or why P does not exist. */
static enum consensus_status paper_matrix(const int64_t cov[ANGLES_PER_AXIS][ANGLES_PER_AXIS],
                                          fix_q30_t p[ANGLES_PER_AXIS][ANGLES_PER_AXIS]) {
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        if (cov[i][i] <= 0) {
            return CONSENSUS_NONPOSITIVE_VARIANCE;
        }
    }
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        for (unsigned j = 0; j < ANGLES_PER_AXIS; ++j) {
            if (cov[i][j] == 0) {
                return CONSENSUS_ZERO_COVARIANCE;
            }
        }
    }
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        /* w_ik = 1/c_ik, scaled by the row's smallest |c| so |w̃| <= 2^40 exactly
         * where it matters: P is invariant to the row scale. */
        uint64_t smallest = UINT64_MAX;
        for (unsigned k = 0; k < ANGLES_PER_AXIS; ++k) {
            const uint64_t mag = fix_abs_u64(cov[i][k]);
            smallest = mag < smallest ? mag : smallest;
        }
        int64_t w[ANGLES_PER_AXIS];
        int64_t sum = 0;
        bool ovf = false;
        for (unsigned k = 0; k < ANGLES_PER_AXIS; ++k) {
            const fix_s128 num = fix_s128_shl(fix_s128_from_s64((int64_t)smallest), 40u);
            w[k] = fix_s128_div_s64(num, cov[i][k], &ovf);
            sum += w[k]; /* |w| <= 2^40: no overflow */
        }
        if (ovf) {
            return CONSENSUS_OVERFLOW;
        }
        if (sum == 0) {
            return CONSENSUS_ZERO_ROW_SUM;
        }
        if (sum < 0) {
            return CONSENSUS_NEGATIVE_ROW_SUM;
        }
        for (unsigned k = 0; k < ANGLES_PER_AXIS; ++k) {
            p[i][k] = fix_muldiv_s64(w[k], FIX_Q30_ONE, sum, &ovf);
            if (ovf || fix_abs_u64(p[i][k]) >
                           ((uint64_t)1 << (FIX_Q30_SHIFT + CONSENSUS_PAPER_MAX_ENTRY_LOG2))) {
                return CONSENSUS_OVERFLOW;
            }
        }
    }
    return CONSENSUS_OK;
}

/* x = hi · 2^23 + lo with 0 <= lo < 2^23, for |x| <= 2^46 (|hi| <= 2^23). */
static void split23(int64_t x, int32_t *hi, int32_t *lo) {
    const int64_t h = fix_floor_shr_s64(x, 23u);
    *hi = (int32_t)h;
    *lo = (int32_t)(x - h * ((int64_t)1 << 23));
}

/* P split once per window: P = hi · 2^23 + lo entry by entry (split23), so that each
 * iteration's products are 32 × 32 bits. */
struct paper_split {
    int32_t hi[ANGLES_PER_AXIS][ANGLES_PER_AXIS];
    int32_t lo[ANGLES_PER_AXIS][ANGLES_PER_AXIS];
};

static void paper_split_matrix(const fix_q30_t p[ANGLES_PER_AXIS][ANGLES_PER_AXIS],
                               struct paper_split *ps) {
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        for (unsigned k = 0; k < ANGLES_PER_AXIS; ++k) {
            split23(p[i][k], &ps->hi[i][k], &ps->lo[i][k]);
        }
    }
}

/* One entry of P·v / 2^30 rounded half away from zero, exact, from the 2^23 splits of a
 * row of P (|P| <= 2^46: |hi| <= 2^23) and of v (|v| < 2^45: |hi| < 2^22): with
 * A = Σ Ph vh, B = Σ (Ph vl + Pl vh), C = Σ Pl vl (each below 2^50),
 * P·v = A 2^46 + B 2^23 + C and floor((P·v + 2^29) / 2^30)
 *     = A 2^16 + floor((B + floor((C + 2^29) / 2^23)) / 2^7).
 * |A| >= 2^29 means |P·v / 2^30| > 2^44.8, beyond the divergence bound: *diverged.
 * Unrolled: it runs 5 times per iteration, up to the iteration cap. */
static int64_t paper_row(const int32_t ph[ANGLES_PER_AXIS], const int32_t pl[ANGLES_PER_AXIS],
                         const int32_t vh[ANGLES_PER_AXIS], const int32_t vl[ANGLES_PER_AXIS],
                         bool *diverged) {
    _Static_assert(ANGLES_PER_AXIS == 5u, "paper_row is unrolled for five estimates");
    const int64_t a = (int64_t)ph[0] * vh[0] + (int64_t)ph[1] * vh[1] + (int64_t)ph[2] * vh[2] +
                      (int64_t)ph[3] * vh[3] + (int64_t)ph[4] * vh[4];
    if (a >= ((int64_t)1 << 29) || a <= -((int64_t)1 << 29)) {
        *diverged = true;
        return 0;
    }
    const int64_t c = (int64_t)pl[0] * vl[0] + (int64_t)pl[1] * vl[1] + (int64_t)pl[2] * vl[2] +
                      (int64_t)pl[3] * vl[3] + (int64_t)pl[4] * vl[4];
    const int64_t b = (int64_t)ph[0] * vl[0] + (int64_t)ph[1] * vl[1] + (int64_t)ph[2] * vl[2] +
                      (int64_t)ph[3] * vl[3] + (int64_t)ph[4] * vl[4] + (int64_t)pl[0] * vh[0] +
                      (int64_t)pl[1] * vh[1] + (int64_t)pl[2] * vh[2] + (int64_t)pl[3] * vh[3] +
                      (int64_t)pl[4] * vh[4];
    const int64_t c1 = c + ((int64_t)1 << 29);
    const int64_t q1 = fix_floor_shr_s64(c1, 23u);
    const int64_t r1 = c1 - q1 * ((int64_t)1 << 23);
    const int64_t b1 = b + q1;
    int64_t next = a * ((int64_t)1 << 16) + fix_floor_shr_s64(b1, 7u);
    /* that rounded halves up; a negative half goes away from zero instead */
    if (r1 == 0 && fix_floor_shr_s64(b1, 7u) * 128 == b1 && next <= 0) {
        next -= 1;
    }
    return next;
}

void consensus_paper(const fix_udeg_q16_t mean[ANGLES_PER_AXIS],
                     const int64_t cov[ANGLES_PER_AXIS][ANGLES_PER_AXIS], uint16_t complete,
                     const struct consensus_paper_config *cfg, struct consensus_paper_result *out) {
    (void)memset(out, 0, sizeof *out);
    if (complete < 2u) {
        out->status = CONSENSUS_TOO_FEW_ROWS;
        return;
    }
    out->status = paper_matrix(cov, out->matrix);
    if (out->status != CONSENSUS_OK) {
        return;
    }
    const int64_t tol_q16 = (int64_t)cfg->tolerance_udeg << FIX_UDEG_Q_SHIFT;
    const int64_t diverged_q16 = (int64_t)CONSENSUS_PAPER_DIVERGED_UDEG << FIX_UDEG_Q_SHIFT;
    fix_udeg_q16_t v[ANGLES_PER_AXIS];
    fix_udeg_q16_t lo0 = INT64_MAX;
    fix_udeg_q16_t hi0 = INT64_MIN;
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        v[i] = mean[i];
        lo0 = v[i] < lo0 ? v[i] : lo0;
        hi0 = v[i] > hi0 ? v[i] : hi0;
    }
    struct paper_split ps;
    paper_split_matrix(out->matrix, &ps);
    out->status = CONSENSUS_NO_CONVERGENCE;
    bool done = false;
    for (uint32_t it = 0; it <= cfg->max_iterations && !done; ++it) {
        fix_udeg_q16_t lo = INT64_MAX;
        fix_udeg_q16_t hi = INT64_MIN;
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            lo = v[i] < lo ? v[i] : lo;
            hi = v[i] > hi ? v[i] : hi;
        }
        if (hi - lo <= tol_q16) {
            out->status = CONSENSUS_OK;
            done = true;
            continue;
        }
        if (it == cfg->max_iterations) {
            done = true;
            continue;
        }
        /* Alg. 1: α(k) = P·α(k − 1), exactly: |P| <= 2^46 and |v| < 2^45 */
        fix_udeg_q16_t next[ANGLES_PER_AXIS];
        int32_t vh[ANGLES_PER_AXIS];
        int32_t vl[ANGLES_PER_AXIS];
        for (unsigned k = 0; k < ANGLES_PER_AXIS; ++k) {
            split23(v[k], &vh[k], &vl[k]);
        }
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            bool diverged = false;
            next[i] = paper_row(ps.hi[i], ps.lo[i], vh, vl, &diverged);
            if (diverged || next[i] > diverged_q16 || next[i] < -diverged_q16) {
                out->status = CONSENSUS_DIVERGED;
                out->iterations = (uint16_t)(it + 1u);
                return;
            }
        }
        (void)memcpy(v, next, sizeof v);
        out->iterations = (uint16_t)(it + 1u);
    }
    if (out->status != CONSENSUS_OK) {
        return;
    }
    int64_t sum = 0;
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        sum += v[i];
    }
    const fix_udeg_q16_t result = fix_div_round_s64(sum, (int64_t)ANGLES_PER_AXIS);
    const fix_udeg_t angle = fix_sat_s32(fix_shr_round_s64(result, FIX_UDEG_Q_SHIFT));
    /* The tolerance margin can carry a converged mean of estimates near ±90° past it, where
     * no angle lies (found by the fuzzers: a = 1 mm, tolerance 4.9°): reported likewise. */
    if (result < lo0 - tol_q16 || result > hi0 + tol_q16 || angle > FIX_UDEG_90 ||
        angle < -FIX_UDEG_90) {
        out->status = CONSENSUS_OUTSIDE_HULL;
        return;
    }
    out->angle_udeg = angle;
}
