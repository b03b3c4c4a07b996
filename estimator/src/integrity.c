/* Window integrity: plausibility, parity, motion and drift facts (see estimator/integrity.h). */
#include "estimator/integrity.h"

#include <string.h>

/* 1/12 mm² (the variance of 1 mm rounding) and 1/4 mm² in Q32. */
#define Q32_TWELFTH ((fix_q32_t)357913941)
#define Q32_QUARTER ((fix_q32_t)1073741824)

bool integrity_config_valid(const struct integrity_config *cfg) {
    return cfg->range_max_mm != 0u && cfg->range_max_mm < INTEGRITY_NO_TARGET_8190 &&
           cfg->parity_sigmas_q8 >= 256u && cfg->parity_sigmas_q8 <= 16u * 256u &&
           cfg->motion_sigmas_q8 >= 256u && cfg->motion_sigmas_q8 <= 16u * 256u &&
           cfg->drift_shift != 0u && cfg->drift_shift <= 8u;
}

void integrity_init(struct integrity_state *st) {
    (void)memset(st, 0, sizeof *st);
}

static bool implausible(uint16_t mm, uint16_t range_max_mm) {
    /* 0 or above the max (8190, 8191, 65535 lie above any valid max) in one unsigned
     * comparison: 0 − 1 wraps to 65535 */
    return (uint16_t)(mm - 1u) >= range_max_mm;
}

/* Least-squares coefficients of an axis over a sensor set, in units of 1/2 (α, β: y =
 * Σ c_k m_k / 2) or 1/4 (x̄: Σ c_k m_k / 4); returns the log2 of that unit, or -1 when
 * the set does not observe the axis. DESIGN.md §2: α needs A and C (y = (x_C − x_A)/2),
 * or one of them with B and D (their midpoint stands for x̄); β likewise. */
static int axis_coeffs(enum integrity_axis axis, uint8_t used, int8_t c[ANGLES_SENSORS]) {
    static const int8_t table[9][ANGLES_SENSORS] = {
        {-1, 0, 1, 0}, {0, -1, 2, -1}, {-2, 1, 0, 1}, /* α: A+C, C+B+D, A+B+D */
        {0, 1, 0, -1}, {-1, 2, -1, 0}, {1, 0, 1, -2}, /* β: B+D, A+B+C, A+C+D */
        {1, 1, 1, 1},  {2, 0, 2, 0},   {0, 2, 0, 2},  /* x̄: all, A+C, B+D */
    };
    const bool a = (used & ANGLES_BIT(ANGLES_A)) != 0u;
    const bool b = (used & ANGLES_BIT(ANGLES_B)) != 0u;
    const bool cc = (used & ANGLES_BIT(ANGLES_C)) != 0u;
    const bool d = (used & ANGLES_BIT(ANGLES_D)) != 0u;
    int row = -1;
    int unit = 1;
    if (axis == INTEGRITY_ALPHA) {
        if (a && cc) {
            row = 0;
        } else if (cc && b && d) {
            row = 1;
        } else if (a && b && d) {
            row = 2;
        } else {
            row = -1;
        }
    } else if (axis == INTEGRITY_BETA) {
        if (b && d) {
            row = 3;
        } else if (a && b && cc) {
            row = 4;
        } else if (a && cc && d) {
            row = 5;
        } else {
            row = -1;
        }
    } else {
        unit = 2;
        if (a && b && cc && d) {
            row = 6;
        } else if (a && cc) {
            row = 7;
        } else if (b && d) {
            row = 8;
        } else {
            row = -1;
        }
    }
    if (row < 0) {
        return -1;
    }
    (void)memcpy(c, table[row], sizeof table[row]);
    return unit;
}

bool integrity_axis_var(enum integrity_axis axis, uint8_t used, const fix_q32_t v[ANGLES_SENSORS],
                        fix_q32_t *var_mm2) {
    int8_t c[ANGLES_SENSORS];
    const int unit = axis_coeffs(axis, used, c);
    *var_mm2 = 0;
    if (unit < 0) {
        return false;
    }
    fix_q32_t sum = 0;
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        sum = fix_sat_add_s64(sum, fix_sat_mul_s64(v[k], (int64_t)c[k] * c[k]));
    }
    *var_mm2 = fix_asr_s64(sum, 2u * (unsigned)unit);
    return true;
}

/* v² > k²·var for v in Q32 mm, var in Q32 mm², k in Q8: exact in 128 bits. */
static bool beyond(fix_q32_t v, fix_q32_t var, uint16_t k_q8) {
    const fix_s128 v2 = fix_s128_mul(v, v); /* Q64 */
    const fix_s128 lim =
        fix_s128_shl(fix_s128_mul((int64_t)k_q8 * (int64_t)k_q8, var), 16u); /* Q64 */
    return fix_s128_cmp(v2, lim) > 0;
}

/* v² in Q32 mm² from Q32 mm, saturating. */
static fix_q32_t square_q32(fix_q32_t v) {
    return fix_s128_to_s64(fix_s128_shr_round(fix_s128_mul(v, v), FIX_Q32_SHIFT), NULL);
}

/* The ring pass: per-sensor reasons of the readings the window holds, and the ramp sums
 * of the readings the window statistics used (valid and inside the gate). */
static attitude_why_t scan_rows(const struct integrity_config *cfg, const struct window_state *w,
                                const struct window_stats *s,
                                struct integrity_ramp_sums r[ANGLES_SENSORS]) {
    attitude_why_t why = 0;
    uint16_t idx = w->oldest;
    const uint32_t eighth = ((uint32_t)w->fill + 7u) / 8u;
    const uint32_t quarter = ((uint32_t)w->fill + 3u) / 4u;
    const int32_t tail8 = (int32_t)w->fill - (int32_t)eighth;
    const int32_t tail4 = (int32_t)w->fill - (int32_t)quarter;
    int32_t centre[ANGLES_SENSORS];
    int32_t half[ANGLES_SENSORS];
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        centre[k] = s->sensor[k].median_x2_mm;
        half[k] = s->sensor[k].gate_x2_mm != 0 ? s->sensor[k].gate_x2_mm : INT32_MAX;
    }
    for (int32_t i = 0; i < (int32_t)w->fill; ++i) {
        const struct window_row *row = &w->ring[idx];
        idx = (uint16_t)(idx + 1u == w->cfg.length ? 0u : idx + 1u);
        const uint8_t valid = window_row_valid(row);
        if (valid != ANGLES_ALL_SENSORS) { /* the rare row: say why each reading is unused */
            const uint8_t present = window_row_present(row);
            for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
                const uint16_t x = row->range_mm[k];
                if ((valid & (1u << k)) != 0u) {
                    continue;
                }
                if ((present & (1u << k)) == 0u) {
                    why |= ATTITUDE_WHY_MISSING(k);
                } else if (x == INTEGRITY_NO_TARGET_8190 || x == INTEGRITY_NO_TARGET_8191 ||
                           x == INTEGRITY_NO_TARGET_65535) {
                    why |= ATTITUDE_WHY_NO_TARGET(k);
                } else if (implausible(x, cfg->range_max_mm)) {
                    why |= ATTITUDE_WHY_RANGE(k);
                } else {
                    why |= ATTITUDE_WHY_FLAGGED(k);
                }
            }
        }
        const int32_t ii = i * i;
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            const int32_t x = row->range_mm[k];
            int32_t dev = 2 * x - centre[k];
            dev = dev < 0 ? -dev : dev;
            if ((valid & (1u << k)) == 0u || dev > half[k]) {
                continue; /* not used by the window statistics (gate: window_stats.c) */
            }
            struct integrity_ramp_sums *rk = &r[k];
            rk->n++;
            rk->si += i;
            rk->sii += ii;
            rk->sx += x;
            rk->six += i * x;
            if (i >= tail4) {
                rk->tail_n[1]++;
                rk->tail_sx[1] += x;
                if (i >= tail8) {
                    rk->tail_n[0]++;
                    rk->tail_sx[0] += x;
                }
            }
        }
    }
    return why;
}

/* (v µm)² in Q32 mm²: v² · 2^32 / 10^6 as v² · round(2^52 / 10^6) / 2^20 (relative error
 * below 10^-10, and no division at the window end). */
static fix_q32_t um2_to_q32(uint16_t v) {
    return fix_mul_shr_s64((int64_t)v * (int64_t)v, (int64_t)4503599627, 20u, NULL);
}

/* v / d for v >= 0 and d in [1, 65535]: the cheap divider (no 64-bit division). */
static fix_q32_t div_small(fix_q32_t v, int32_t d) {
    return (fix_q32_t)fix_div_u64_u16((uint64_t)v, (uint32_t)d);
}

/* A late step of one sensor: the mean of its newest readings (tail t) minus the window
 * mean (Q32 mm), and its variance s²(1/m − 1/n) = s²(n − m)/(n m); 0 and 0 without tail
 * readings. n m <= 256 · 64 fits the 16-bit divider; s² (n − m) saturates. */
static void tail_step(const struct integrity_ramp_sums *r, unsigned t, fix_q32_t mean, fix_q32_t s2,
                      fix_q32_t *step, fix_q32_t *var) {
    *step = 0;
    *var = 0;
    const int32_t m = r->tail_n[t];
    if (m == 0 || m >= r->n) {
        return;
    }
    *step = div_small((fix_q32_t)r->tail_sx[t] << FIX_Q32_SHIFT, m) - mean;
    *var = div_small(fix_sat_mul_s64(s2, r->n - m), r->n * m);
}

/* Least-squares ramp of one sensor: the fitted value at the last row minus the mean
 * (Q32 mm), and its variance for per-reading variance s2 (Q32 mm²). Fewer than three
 * readings or one index only: no ramp can be told from noise, 0 and 0. The divisions by
 * n·Σ(i − ī)² use its normalised reciprocal (relative error < 2^-28, plenty for a test
 * statistic), not a 128-bit division: the window end runs this for every sensor. */
static void ramp(const struct integrity_ramp_sums *r, int64_t last, fix_q32_t s2, fix_q32_t *lag,
                 fix_q32_t *var) {
    *lag = 0;
    *var = 0;
    if (r->n < 3) {
        return;
    }
    const int64_t n = r->n;
    const int64_t sxx = n * r->sii - (int64_t)r->si * r->si; /* n Σ(i − ī)², < 2^40 */
    if (sxx <= 0) {
        return;
    }
    const int64_t sxy = n * r->six - (int64_t)r->si * r->sx; /* |.| < 2^38 */
    const int64_t m = n * last - r->si;                      /* n (i_L − ī), < 2^17 */
    /* den = n·sxx = dm·2^e, rm ≈ 2^61/dm: x / den · 2^32 = x · rm / 2^(29 + e), e >= -26 */
    int32_t e = 0;
    const int64_t den = n * sxx;
    const uint32_t dm = fix_norm31((uint64_t)den, &e);
    const int64_t rm = fix_recip31(dm);
    const int32_t shift_s = 29 + e;
    const unsigned shift = (unsigned)shift_s;
    /* lag = slope (i_L − ī) = sxy m / (n sxx); var = s² (i_L − ī)² / Σ(i − ī)² = s² m²/(n sxx) */
    *lag = fix_mul_shr_s64(sxy * m, rm, shift, NULL);          /* sxy m < 2^55 */
    const int64_t q = fix_mul_shr_s64(m * m, rm, shift, NULL); /* m²/(n sxx) in Q32, <= 2^34 */
    *var = fix_mul_shr_s64(s2, q, FIX_Q32_SHIFT, NULL);
}

/* The lag² of the window mean behind its last row under a steady motion, learnt from this
 * block's axis value y[0] and the previous three, y[1..3] (disjoint blocks of n rows; var:
 * the per-block variance of the axis value, white noise plus drift and prior). A steady
 * rate moves y by the same step per block, so it is taken as steady when consecutive steps
 * differ by no more than 3σ of their difference (var(y0 − 2 y1 + y2) = 6 var; a step
 * between blocks or a change of rate fails it) and the lag agrees, within 3σ, with the
 * window's own ramp statistic (ramp_lag, ramp_var): a plate that jumps between static windows
 * shows no ramp inside them. Then the rate per block is (y0 − y3)/3 and the lag
 * (n − 1)/(2n) of it: lag = g·(y0 − y3) with g = (n − 1)/(6n) in Q31 (gain_q31); returned
 * is lag² less its noise variance (2 var g²), never below 0: on a level plate it adds
 * about half that noise variance on average (the clamp), under 5 % of the white variance. */
static fix_q32_t steady_lag2(const fix_q32_t y[4], fix_q32_t var, int32_t gain_q31,
                             fix_q32_t ramp_lag, fix_q32_t ramp_var) {
    const fix_q32_t var6 = fix_sat_mul_s64(var, 6);
    if (beyond((y[0] - y[1]) - (y[1] - y[2]), var6, INTEGRITY_MOTION_ALLOW_Q8) ||
        beyond((y[1] - y[2]) - (y[2] - y[3]), var6, INTEGRITY_MOTION_ALLOW_Q8)) {
        return 0;
    }
    const fix_q32_t lag = fix_mul_q31(y[0] - y[3], gain_q31);
    const fix_q32_t noise = 2 * fix_mul_q31(fix_mul_q31(var, gain_q31), gain_q31);
    if (beyond(lag - ramp_lag, fix_sat_add_s64(noise, ramp_var), INTEGRITY_MOTION_ALLOW_Q8)) {
        return 0;
    }
    const fix_q32_t lag2 = square_q32(lag) - noise;
    return lag2 > 0 ? lag2 : 0;
}

void integrity_assess(struct integrity_state *st, const struct integrity_config *cfg,
                      struct window_state *w, const struct window_stats *s, bool learn,
                      struct integrity_window *out) {
    (void)memset(out, 0, sizeof *out);
    struct integrity_ramp_sums *r =
        out->ramp; /* zeroed above; in out, not on the window-end stack */
    out->why = scan_rows(cfg, w, s, r);

    const fix_q32_t prior = um2_to_q32(cfg->offset_stability_um);
    /* three motion statistics per sensor: the ramp, the newest N/8 and N/4 rows (kept in
     * out, not on the window-end stack) */
    fix_q32_t(*lag)[ANGLES_SENSORS] = out->motion_mm;
    fix_q32_t(*lag_var)[ANGLES_SENSORS] = out->motion_var_mm2;
    fix_q32_t white_sum = 0; /* Σ of what the window sees */
    fix_q32_t base_sum = 0;  /* ... plus what is not learnt: the prior and the rounding */
    fix_q32_t total_sum = 0; /* ... plus the learnt drift: the parity residual's variance */
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        const struct window_sensor_stats *ss = &s->sensor[k];
        if (ss->used == 0u) {
            continue;
        }
        out->used = (uint8_t)(out->used | (1u << k));
        /* a window of identical readings still has the rounding's 1/12 mm² */
        const fix_q32_t s2 = ss->var_mm2 > Q32_TWELFTH ? ss->var_mm2 : Q32_TWELFTH;
        out->white_mm2[k] = div_small(s2, ss->used);
        /* noise under half a step does not dither the rounding: the mean keeps its error */
        const fix_q32_t quant = ss->var_mm2 < Q32_QUARTER ? Q32_TWELFTH : 0;
        /* the learnt drift is a mean of unbiased samples that may be negative: never below 0 */
        const fix_q32_t drift = st->drift_mm2 > 0 ? st->drift_mm2 : 0;
        out->extra_mm2[k] = fix_sat_add_s64(fix_sat_add_s64(drift, prior), quant);
        white_sum = fix_sat_add_s64(white_sum, out->white_mm2[k]);
        base_sum = fix_sat_add_s64(
            base_sum, fix_sat_add_s64(out->white_mm2[k], fix_sat_add_s64(prior, quant)));
        total_sum =
            fix_sat_add_s64(total_sum, fix_sat_add_s64(out->white_mm2[k], out->extra_mm2[k]));
        ramp(&r[k], (int64_t)w->fill - 1, s2, &lag[0][k], &lag_var[0][k]);
        tail_step(&r[k], 0u, ss->mean_mm, s2, &lag[1][k], &lag_var[1][k]);
        tail_step(&r[k], 1u, ss->mean_mm, s2, &lag[2][k], &lag_var[2][k]);
    }

    /* slopes for the delta method, from the pair means (0: the conservative 1/(1 + t²) = 1) */
    const struct window_sensor_stats *sa = &s->sensor[ANGLES_A];
    const struct window_sensor_stats *sb = &s->sensor[ANGLES_B];
    const struct window_sensor_stats *sc = &s->sensor[ANGLES_C];
    const struct window_sensor_stats *sd = &s->sensor[ANGLES_D];
    if (sa->used != 0u && sc->used != 0u) {
        out->tan_q32[0] = fix_div_round_s64((sc->mean_mm - sa->mean_mm) * 500, cfg->arm_um);
    }
    if (sb->used != 0u && sd->used != 0u) {
        out->tan_q32[1] = fix_div_round_s64((sb->mean_mm - sd->mean_mm) * 500, cfg->arm_um);
    }

    /* parity: a flat plate gives x_A + x_C − x_B − x_D = 0 whatever its attitude */
    if (out->used == ANGLES_ALL_SENSORS) {
        out->parity_mm = sa->mean_mm + sc->mean_mm - sb->mean_mm - sd->mean_mm;
        out->parity_failed = beyond(out->parity_mm, total_sum, cfg->parity_sigmas_q8);
        if (learn) {
            /* mean square beyond what is not learnt, shared by four sensors, clipped at a
             * residual on the test's threshold without learnt drift: a faulty window cannot
             * teach the test to accept it, nor can a run of them (the limit does not grow
             * with what was learnt); a larger wander stays a parity failure */
            fix_q32_t sample = fix_asr_s64(square_q32(out->parity_mm) - base_sum, 2u);
            const fix_q32_t limit = fix_asr_s64(
                fix_mul_shr_s64(base_sum,
                                (int64_t)cfg->parity_sigmas_q8 * (int64_t)cfg->parity_sigmas_q8,
                                16u, NULL),
                2u);
            /* negative samples are kept: clipping them at 0 would learn drift from white
             * noise alone (E[max(0, W(χ² − 1))] = 0.48 W); only the upper clip remains, and
             * a floor of −base/4 bounds one window's pull downwards */
            const fix_q32_t floor = -fix_asr_s64(base_sum, 2u);
            sample = sample < floor ? floor : (sample > limit ? limit : sample);
            const uint16_t cap = (uint16_t)(1u << cfg->drift_shift);
            if (st->blocks < cap) {
                st->blocks++;
            }
            st->drift_mm2 += fix_div_round_s64(sample - st->drift_mm2, st->blocks);
        }
    }
    if (out->parity_failed) {
        out->why |= ATTITUDE_WHY_PARITY;
    }
    if (st->drift_mm2 > um2_to_q32(cfg->drift_flag_um)) {
        out->why |= ATTITUDE_WHY_DRIFT;
    }

    /* per axis: what a window estimator's white variance misses */
    const fix_q32_t parity2 = square_q32(out->parity_mm);
    /* the steady-motion lag is learnt when this block's sensors were used in the last three
     * (an axis the window cannot observe learns 0) */
    if (learn) {
        (void)memset(st->steady_lag2_mm2, 0, sizeof st->steady_lag2_mm2);
    }
    const bool history = learn && (st->block_used[0] & out->used) == out->used &&
                         (st->block_used[1] & out->used) == out->used &&
                         (st->block_used[2] & out->used) == out->used;
    fix_q32_t block_var[ANGLES_SENSORS];
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        block_var[k] = fix_sat_add_s64(out->white_mm2[k], out->extra_mm2[k]);
    }
    /* (n − 1)/(6n) in Q31 for a block of n = fill rows (6n <= 1536 fits the 16-bit divider;
     * 0 for n < 2: no lag) */
    const uint32_t n = w->fill;
    const uint32_t n_less_one = n >= 2u ? n - 1u : 0u;
    const int32_t gain_q31 =
        n >= 2u ? (int32_t)fix_div_u64_u16((uint64_t)n_less_one << 31, 6u * n) : 0;
    for (unsigned ax = 0; ax < INTEGRITY_AXES; ++ax) {
        int8_t c[ANGLES_SENSORS];
        const int unit = axis_coeffs((enum integrity_axis)ax, out->used, c);
        if (unit < 0) {
            continue;
        }
        fix_q32_t extra = 0;
        (void)integrity_axis_var((enum integrity_axis)ax, out->used, out->extra_mm2, &extra);
        int64_t worst = 0;
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            worst = (int64_t)c[k] * c[k] > worst ? (int64_t)c[k] * c[k] : worst;
        }
        /* the largest motion statistic beyond INTEGRITY_MOTION_ALLOW_Q8 is taken as the lag
         * of the window mean behind its last row and goes into the sd; beyond
         * motion_sigmas the window is also said to have moved. With none beyond, the ramp
         * stands (its noise, not motion, and not added) */
        bool allow = false;
        fix_q32_t ramp_lag = 0;
        fix_q32_t ramp_var = 0;
        for (unsigned m = 0; m < 3u; ++m) {
            int64_t lag_sum = 0;
            for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
                lag_sum = fix_sat_add_s64(lag_sum, fix_sat_mul_s64(lag[m][k], c[k]));
            }
            const fix_q32_t v = fix_asr_s64(lag_sum, (unsigned)unit);
            fix_q32_t var = 0;
            (void)integrity_axis_var((enum integrity_axis)ax, out->used, lag_var[m], &var);
            const bool big = var > 0 && beyond(v, var, INTEGRITY_MOTION_ALLOW_Q8);
            if (m == 0u) {
                ramp_lag = v;
                ramp_var = var;
            }
            if (m == 0u || (big && (!allow || fix_abs_u64(v) > fix_abs_u64(out->lag_mm[ax])))) {
                out->lag_mm[ax] = v;
                out->lag_var_mm2[ax] = var;
            }
            allow = allow || big;
            out->moved[ax] = out->moved[ax] || (big && beyond(v, var, cfg->motion_sigmas_q8));
        }
        if (out->parity_failed) {
            /* the disagreement may sit in any one sensor: cover the worst */
            extra = fix_sat_add_s64(
                extra, fix_asr_s64(fix_sat_mul_s64(parity2, worst), 2u * (unsigned)unit));
        }
        if (history) {
            fix_q32_t y[4];
            for (unsigned b = 0; b < 4u; ++b) {
                int64_t sum = 0;
                for (unsigned k = 0; k < ANGLES_SENSORS; ++k) { /* |c| <= 2, mean < 2^46 */
                    sum += (b == 0u ? s->sensor[k].mean_mm : st->block_mean_mm[b - 1u][k]) * c[k];
                }
                y[b] = fix_asr_s64(sum, (unsigned)unit);
            }
            fix_q32_t var = 0;
            (void)integrity_axis_var((enum integrity_axis)ax, out->used, block_var, &var);
            st->steady_lag2_mm2[ax] = steady_lag2(y, var, gain_q31, ramp_lag, ramp_var);
        }
        /* the lag this window shows, or the steady motion's learnt one, whichever is larger */
        const fix_q32_t seen = allow ? square_q32(out->lag_mm[ax]) : 0;
        extra =
            fix_sat_add_s64(extra, seen > st->steady_lag2_mm2[ax] ? seen : st->steady_lag2_mm2[ax]);
        if (out->moved[ax]) {
            out->why |= ATTITUDE_WHY_MOTION;
        }
        out->extra_var_mm2[ax] = extra;
    }
    if (learn) {
        st->block_used[2] = st->block_used[1];
        st->block_used[1] = st->block_used[0];
        st->block_used[0] = out->used;
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            st->block_mean_mm[2][k] = st->block_mean_mm[1][k];
            st->block_mean_mm[1][k] = st->block_mean_mm[0][k];
            st->block_mean_mm[0][k] = s->sensor[k].mean_mm;
        }
    }
}
