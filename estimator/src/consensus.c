/* Consensus fusion, paper and product rules: see estimator/consensus.h. */
#include "estimator/consensus.h"

#include <string.h>

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
    unsigned low, ref1, high, ref2;
};
static const struct axis_frame alpha_frame = {ANGLES_A, ANGLES_B, ANGLES_C, ANGLES_D};
static const struct axis_frame beta_frame = {ANGLES_D, ANGLES_A, ANGLES_B, ANGLES_C};

/* (hi − lo)/(span·a) as a Q32 slope from Q32 mm means. |hi − lo| < 2^48, times
 * 1000 < 2^58: no overflow. */
static fix_q32_t slope_q32(fix_q32_t hi_mm, fix_q32_t lo_mm, int32_t arm_um, int span) {
    return fix_div_round_s64((hi_mm - lo_mm) * 1000, (int64_t)arm_um * span);
}

/* Variance of a window mean in Q28 mm²: max(s², 1/12)/n. */
static fix_q28_t mean_var_q28(const struct consensus_sensor *s) {
    const fix_q32_t v = s->var_mm2 > QUANT_VAR_Q32 ? s->var_mm2 : QUANT_VAR_Q32;
    return fix_div_round_s64(v, (int64_t)s->count * 16);
}

/* v ← ((1 − ε)I + ε1πᵀ)v with ε = 1/2 until spread <= tol. Returns πᵀv. */
static fix_q32_t iterate_product(struct consensus_axis *ax, fix_q32_t tol_q32) {
    fix_q32_t v[ANGLES_PER_AXIS];
    memcpy(v, ax->initial, sizeof v);
    fix_q32_t c = 0;
    ax->status = CONSENSUS_NO_CONVERGENCE;
    for (unsigned it = 0; it <= CONSENSUS_PRODUCT_MAX_ITERATIONS; ++it) {
        fix_q32_t lo = INT64_MAX;
        fix_q32_t hi = INT64_MIN;
        fix_s128 acc = fix_s128_from_s64(0);
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            if ((ax->used & (1u << i)) == 0u) {
                continue;
            }
            lo = v[i] < lo ? v[i] : lo;
            hi = v[i] > hi ? v[i] : hi;
            acc = fix_s128_add(acc, fix_s128_mul(ax->weight[i], v[i]));
        }
        c = fix_s128_to_s64(fix_s128_shr_round(acc, FIX_Q30_SHIFT), NULL);
        if (hi - lo <= tol_q32) {
            ax->status = CONSENSUS_OK;
            break;
        }
        if (it == CONSENSUS_PRODUCT_MAX_ITERATIONS) {
            break; /* cannot happen while tol > 4 LSB (header proof); reported if it does */
        }
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            if ((ax->used & (1u << i)) != 0u) {
                v[i] = fix_shr_round_s64(v[i] + c, 1u);
            }
        }
        ax->iterations++;
    }
    return c;
}

static void product_axis(const struct consensus_product_input *in, const struct axis_frame *f,
                         struct consensus_axis *ax) {
    memset(ax, 0, sizeof *ax);
    const struct consensus_sensor *s = in->sensor;
    const bool has_low = s[f->low].used;
    const bool has_high = s[f->high].used;
    const bool has_refs = s[f->ref1].used && s[f->ref2].used;
    const int32_t a = in->arm_um;
    fix_q28_t v_low = has_low ? mean_var_q28(&s[f->low]) : 0;
    fix_q28_t v_high = has_high ? mean_var_q28(&s[f->high]) : 0;
    /* m = var of the reference midpoint (m_ref1 + m_ref2)/2 */
    const fix_q28_t m =
        has_refs ? (mean_var_q28(&s[f->ref1]) + mean_var_q28(&s[f->ref2]) + 2) / 4 : 0;

    fix_q32_t other = 0; /* t̂ of the other axis in this frame: (ref1 − ref2)/2a */
    if (has_refs) {
        other = slope_q32(s[f->ref1].mean_mm, s[f->ref2].mean_mm, a, 2);
    }
    fix_q28_t var_at = 0; /* variance of a·t̂ in Q28 mm² */
    bool ovf = false;
    if (has_low && has_high && has_refs) {
        ax->used = 0x1F;
        /* π_low ∝ 2m + V_high, π_high ∝ 2m + V_low; π5 = 2·min, the rest split */
        const int64_t w_low = 2 * m + v_high;
        const int64_t w_high = 2 * m + v_low;
        const fix_q30_t pi_low = fix_muldiv_s64(w_low, FIX_Q30_ONE, w_low + w_high, &ovf);
        const fix_q30_t pi_high = FIX_Q30_ONE - pi_low;
        const fix_q30_t common = pi_low < pi_high ? pi_low : pi_high;
        ax->weight[4] = 2 * common;
        ax->weight[0] = (pi_low - common) / 2;
        ax->weight[1] = pi_low - common - ax->weight[0];
        ax->weight[2] = (pi_high - common) / 2;
        ax->weight[3] = pi_high - common - ax->weight[2];
        /* var(a·t̂) = (V_l V_h + m (V_l + V_h)) / (V_l + V_h + 4m) */
        const fix_s128 num =
            fix_s128_add(fix_s128_mul(v_low, v_high), fix_s128_mul(m, v_low + v_high));
        var_at = fix_s128_div_s64(num, v_low + v_high + 4 * m, &ovf); /* Q56 / Q28 = Q28 */
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

    /* v(0): the five slopes of Eq. 1 in this frame, compensated by `other` */
    const fix_q32_t low = s[f->low].mean_mm;
    const fix_q32_t high = s[f->high].mean_mm;
    const fix_q32_t r1 = s[f->ref1].mean_mm;
    const fix_q32_t r2 = s[f->ref2].mean_mm;
    if ((ax->used & 0x01u) != 0u) {
        ax->initial[0] = slope_q32(r1, low, a, 1) - other; /* s1 = t + o */
    }
    if ((ax->used & 0x02u) != 0u) {
        ax->initial[1] = slope_q32(r2, low, a, 1) + other; /* s2 = t − o */
    }
    if ((ax->used & 0x04u) != 0u) {
        ax->initial[2] = slope_q32(high, r1, a, 1) + other; /* s3 = t − o */
    }
    if ((ax->used & 0x08u) != 0u) {
        ax->initial[3] = slope_q32(high, r2, a, 1) - other; /* s4 = t + o */
    }
    if ((ax->used & 0x10u) != 0u) {
        ax->initial[4] = slope_q32(high, low, a, 2); /* s5 = t */
    }
    /* tolerance in slope units: |Δatan| <= |Δt|, so a slope spread <= tol_rad
     * guarantees an angle spread <= tol */
    const fix_q32_t tol_q32 = (fix_q32_t)in->tolerance_udeg * FIX_Q32_RAD_PER_UDEG_X1000 / 1000;
    ax->tan_q32 = iterate_product(ax, tol_q32);
    ax->angle_udeg = fix_atan_q32_udeg(ax->tan_q32);
    ax->sigma_udeg =
        ovf ? INT32_MAX : fix_angle_sigma_udeg(fix_sat_mul_s64(var_at, 16), a, ax->tan_q32);
}

void consensus_product(const struct consensus_product_input *in,
                       struct consensus_product_result *out) {
    product_axis(in, &alpha_frame, &out->alpha);
    product_axis(in, &beta_frame, &out->beta);

    /* x̄: each complete opposite pair gives its midpoint, exactly free of the
     * tilt; both pairs are combined by inverse variance. */
    const struct consensus_sensor *s = in->sensor;
    const bool ac = s[ANGLES_A].used && s[ANGLES_C].used;
    const bool bd = s[ANGLES_B].used && s[ANGLES_D].used;
    out->distance_valid = ac || bd;
    out->distance_mm = 0;
    if (ac && bd) {
        const fix_q28_t v_ac = mean_var_q28(&s[ANGLES_A]) + mean_var_q28(&s[ANGLES_C]);
        const fix_q28_t v_bd = mean_var_q28(&s[ANGLES_B]) + mean_var_q28(&s[ANGLES_D]);
        const fix_q32_t mid_ac = (s[ANGLES_A].mean_mm + s[ANGLES_C].mean_mm) / 2;
        const fix_q32_t mid_bd = (s[ANGLES_B].mean_mm + s[ANGLES_D].mean_mm) / 2;
        const fix_s128 num = fix_s128_add(fix_s128_mul(mid_ac, v_bd), fix_s128_mul(mid_bd, v_ac));
        out->distance_mm = fix_s128_div_s64(num, v_ac + v_bd, NULL);
    } else if (ac) {
        out->distance_mm = (s[ANGLES_A].mean_mm + s[ANGLES_C].mean_mm) / 2;
    } else if (bd) {
        out->distance_mm = (s[ANGLES_B].mean_mm + s[ANGLES_D].mean_mm) / 2;
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

void consensus_paper(const fix_udeg_q16_t mean[ANGLES_PER_AXIS],
                     const int64_t cov[ANGLES_PER_AXIS][ANGLES_PER_AXIS], uint16_t complete,
                     const struct consensus_paper_config *cfg, struct consensus_paper_result *out) {
    memset(out, 0, sizeof *out);
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
    out->status = CONSENSUS_NO_CONVERGENCE;
    for (uint32_t it = 0; it <= cfg->max_iterations; ++it) {
        fix_udeg_q16_t lo = INT64_MAX;
        fix_udeg_q16_t hi = INT64_MIN;
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            lo = v[i] < lo ? v[i] : lo;
            hi = v[i] > hi ? v[i] : hi;
        }
        if (hi - lo <= tol_q16) {
            out->status = CONSENSUS_OK;
            break;
        }
        if (it == cfg->max_iterations) {
            break;
        }
        /* Alg. 1: α(k) = P·α(k − 1); |P| <= 2^46, |v| <= 2^45: exact in 128 bits */
        fix_udeg_q16_t next[ANGLES_PER_AXIS];
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            fix_s128 acc = fix_s128_from_s64(0);
            for (unsigned k = 0; k < ANGLES_PER_AXIS; ++k) {
                acc = fix_s128_add(acc, fix_s128_mul(out->matrix[i][k], v[k]));
            }
            bool ovf = false;
            next[i] = fix_s128_to_s64(fix_s128_shr_round(acc, FIX_Q30_SHIFT), &ovf);
            if (ovf || next[i] > diverged_q16 || next[i] < -diverged_q16) {
                out->status = CONSENSUS_DIVERGED;
                out->iterations = (uint16_t)(it + 1u);
                return;
            }
        }
        memcpy(v, next, sizeof v);
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
    if (result < lo0 - tol_q16 || result > hi0 + tol_q16) {
        out->status = CONSENSUS_OUTSIDE_HULL;
        return;
    }
    out->angle_udeg = fix_sat_s32(fix_shr_round_s64(result, FIX_UDEG_Q_SHIFT));
}
