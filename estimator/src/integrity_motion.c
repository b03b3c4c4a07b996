/* Motion in a window and across blocks: ramps, late steps, the steady-motion lag. */
/* Each sensor's least-squares ramp and late steps, each axis' lag behind its last row
 * (`motion`), and the lag a steady motion too slow for one window leaves, learnt from the
 * last four blocks' means. */
#include <string.h>

#include "integrity_internal.h"

/* A late step of one sensor: the mean of its newest readings (tail t) minus the window
 * mean (Q32 mm), and its variance s²(1/m − 1/n) = s²(n − m)/(n m); 0 and 0 without tail
 * readings. n m <= 256 · 64 fits the 16-bit divider; s² (n − m) saturates. */
static void tail_step(const struct integrity_ramp_sums *r, unsigned t, fix_q32_t mean, fix_q32_t s2,
                      fix_q32_t *step, fix_q32_t *var) {
    *step = 0;
    *var = 0;
    const int32_t m = r->tail_n[t];
    /* A plate that moved late in the window puts its newest readings outside the window's
     * gate, which then hides the move from the estimate and from this statistic alike (a
     * 10°/s ramp after a hold: 2.6° off with a 0.2° sd). When the gate dropped at
     * least as many of the newest N/8 rows' readings as it kept, they are a move, not
     * outliers (2 % gross outliers put half of a tail outside it once in 10^7 windows): the
     * step is their mean with the kept ones against the window mean, variance s²(1/m + 1/n)
     * (the dropped ones are not in the window mean). */
    if (t == 0u && r->tail_out_n > 0 && r->tail_out_n >= m) {
        const int32_t mo = m + r->tail_out_n;
        *step =
            integrity_div_small((fix_q32_t)(r->tail_sx[0] + r->tail_out_sx) << FIX_Q32_SHIFT, mo) -
            mean;
        *var = integrity_div_small(fix_sat_mul_s64(s2, r->n + mo), r->n * mo);
        return;
    }
    if (m == 0 || m >= r->n) {
        return;
    }
    *step = integrity_div_small((fix_q32_t)r->tail_sx[t] << FIX_Q32_SHIFT, m) - mean;
    *var = integrity_div_small(fix_sat_mul_s64(s2, r->n - m), r->n * m);
}

/* Least-squares ramp of one sensor: the fitted value at the last row minus the mean
 * (Q32 mm), and its variance for per-reading variance s2 (Q32 mm²). Fewer than three
 * readings or one index only: no ramp can be told from noise, 0 and 0. The divisions by
 * n·Σ(i − ī)² use its normalised reciprocal (relative error < 2^-28, plenty for a test
 * statistic), not a 128-bit division: the window end runs this for every sensor. */
static void ramp(const struct integrity_ramp_sums *r, int64_t last, fix_q32_t s2, fix_q32_t *lag,
                 fix_q32_t *var, fix_q32_t *s2_ramp) {
    *lag = 0;
    *var = 0;
    *s2_ramp = s2;
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
    /* The noise is the scatter about the ramp, not about the mean: a sensor's variance
     * holds all of its motion, the distance's too, which cancels in the angles (a 5 mm/s
     * approach put 52 mm² into each sensor's variance of a 255-row window and hid a 1°/s
     * tilt's 2.5° lag from every test). The ramp explains sxy²/(n sxx) of the sum
     * of squares (Q32: (sxy/(n sxx)) sxy); the rest over n − 2 degrees of freedom, never
     * below the rounding's 1/12 mm². */
    const fix_q32_t b = fix_mul_shr_s64(sxy, rm, shift, NULL); /* sxy/(n sxx), Q32 */
    const fix_q32_t explained = fix_mul_shr_s64(b, sxy, 0u, NULL);
    const fix_q32_t total = fix_sat_mul_s64(s2, n - 1);
    fix_q32_t rest = total > explained ? integrity_div_small(total - explained, (int32_t)n - 2) : 0;
    rest = rest > Q32_TWELFTH ? rest : Q32_TWELFTH;
    *s2_ramp = rest < s2 ? rest : s2;
    *var = fix_mul_shr_s64(*s2_ramp, q, FIX_Q32_SHIFT, NULL);
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
    if (integrity_beyond((y[0] - y[1]) - (y[1] - y[2]), var6, INTEGRITY_MOTION_ALLOW_Q8) ||
        integrity_beyond((y[1] - y[2]) - (y[2] - y[3]), var6, INTEGRITY_MOTION_ALLOW_Q8)) {
        return 0;
    }
    const fix_q32_t lag = fix_mul_q31(y[0] - y[3], gain_q31);
    const fix_q32_t noise = 2 * fix_mul_q31(fix_mul_q31(var, gain_q31), gain_q31);
    if (integrity_beyond(lag - ramp_lag, fix_sat_add_s64(noise, ramp_var),
                         INTEGRITY_MOTION_ALLOW_Q8)) {
        return 0;
    }
    const fix_q32_t lag2 = integrity_square_q32(lag) - noise;
    return lag2 > 0 ? lag2 : 0;
}

void integrity_motion_sensors(const struct window_state *w, const struct window_stats *s,
                              struct integrity_window *out) {
    const struct integrity_ramp_sums *r = out->ramp;
    /* three motion statistics per sensor: the ramp, the newest N/8 and N/4 rows (kept in
     * out, not on the window-end stack) */
    fix_q32_t(*lag)[ANGLES_SENSORS] = out->motion_mm;
    fix_q32_t(*lag_var)[ANGLES_SENSORS] = out->motion_var_mm2;
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        const struct window_sensor_stats *ss = &s->sensor[k];
        if (ss->used == 0u) {
            continue;
        }
        /* a window of identical readings still has the rounding's 1/12 mm² */
        const fix_q32_t s2 = ss->var_mm2 > Q32_TWELFTH ? ss->var_mm2 : Q32_TWELFTH;
        fix_q32_t s2_ramp = s2; /* the scatter about the ramp: the noise of every statistic */
        ramp(&r[k], (int64_t)w->fill - 1, s2, &lag[0][k], &lag_var[0][k], &s2_ramp);
        tail_step(&r[k], 0u, ss->mean_mm, s2_ramp, &lag[1][k], &lag_var[1][k]);
        tail_step(&r[k], 1u, ss->mean_mm, s2_ramp, &lag[2][k], &lag_var[2][k]);
    }
}

/* One axis' motion statistics (coefficients c in units 2^unit): the largest beyond
 * INTEGRITY_MOTION_ALLOW_Q8 is taken as the lag of the window mean behind its last row
 * and goes into the sd (returns true); beyond motion_sigmas the window is also said to
 * have moved. With none beyond, the ramp stands (its noise, not motion, and not added).
 * The ramp's own lag and variance go to *ramp_lag, *ramp_var. */
static bool axis_lag(const struct integrity_config *cfg, enum integrity_axis ax,
                     const int8_t c[ANGLES_SENSORS], int unit, struct integrity_window *out,
                     fix_q32_t *ramp_lag, fix_q32_t *ramp_var) {
    bool allow = false;
    for (unsigned m = 0; m < 3u; ++m) {
        int64_t lag_sum = 0;
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
            lag_sum = fix_sat_add_s64(lag_sum, fix_sat_mul_s64(out->motion_mm[m][k], c[k]));
        }
        const fix_q32_t v = fix_asr_s64(lag_sum, (unsigned)unit);
        fix_q32_t var = 0;
        (void)integrity_axis_var(ax, out->used, out->motion_var_mm2[m], &var);
        const bool big = var > 0 && integrity_beyond(v, var, INTEGRITY_MOTION_ALLOW_Q8);
        if (m == 0u) {
            *ramp_lag = v;
            *ramp_var = var;
        }
        if (m == 0u || (big && (!allow || fix_abs_u64(v) > fix_abs_u64(out->lag_mm[ax])))) {
            out->lag_mm[ax] = v;
            out->lag_var_mm2[ax] = var;
        }
        allow = allow || big;
        out->moved[ax] = out->moved[ax] || (big && integrity_beyond(v, var, cfg->motion_sigmas_q8));
    }
    return allow;
}

/* The axis value of this block (y[0], from the window's means) and the previous three
 * (y[1..3], from the history), and the per-block variance of the axis value (white noise
 * plus drift and prior). */
static fix_q32_t block_values(const struct integrity_state *st, const struct window_stats *s,
                              const struct integrity_window *out,
                              const fix_q32_t block_var[ANGLES_SENSORS], enum integrity_axis ax,
                              const int8_t c[ANGLES_SENSORS], int unit, fix_q32_t y[4]) {
    for (unsigned b = 0; b < 4u; ++b) {
        int64_t sum = 0;
        for (unsigned k = 0; k < ANGLES_SENSORS; ++k) { /* |c| <= 2, mean < 2^46 */
            sum += (b == 0u ? s->sensor[k].mean_mm : st->block_mean_mm[b - 1u][k]) * c[k];
        }
        y[b] = fix_asr_s64(sum, (unsigned)unit);
    }
    fix_q32_t var = 0;
    (void)integrity_axis_var(ax, out->used, block_var, &var);
    return var;
}

/*
 * The rate bound's prior on an angle axis (Q32 mm², in a·tan units): a ramp at up to
 * max_rate that the window's statistics cannot tell from noise still leaves the window's
 * estimate behind the attitude at its last row by up to a·sec²θ·ω·(n − 1)·T/2 (the
 * centroid of n rows a period T apart; any motion whose rate stays within the bound
 * leaves no more). Its variance as a uniform error over ±that lag is lag²/3: a ramp
 * exactly at the bound sits at √3 of it. 0 for a still plate.
 */
static fix_q32_t rate_bound_lag2(const struct integrity_config *cfg, uint32_t n,
                                 fix_q32_t tan_q32) {
    if (cfg->max_rate_mdeg_s == 0u || n < 2u) {
        return 0;
    }
    /* a·ω in µm/s: a [µm] · ω [m°/s] · π/180000, π as 355/113 (8.5e-8 relative) */
    const int64_t rate_um_s = fix_muldiv_s64((int64_t)cfg->arm_um * (int64_t)cfg->max_rate_mdeg_s,
                                             355, (int64_t)113 * 180000, NULL);
    const int64_t span_us = ((int64_t)n - 1) * (int64_t)cfg->period_us / 2;
    /* the lag in Q32 mm: µm/s · µs / 10^6 · 2^32 / 1000, 2^32 / 1000 rounded up (the
     * conservative side); then times sec²θ = 1 + tan²θ (the axis is a·tan θ) */
    const fix_q32_t lag = fix_muldiv_s64(rate_um_s * 4294968, span_us, 1000000, NULL);
    const fix_q32_t sec2 =
        fix_sat_add_s64(FIX_Q32_ONE, fix_muldiv_s64(tan_q32, tan_q32, FIX_Q32_ONE, NULL));
    const fix_q32_t lag_sec2 = fix_muldiv_s64(lag, sec2, FIX_Q32_ONE, NULL);
    return integrity_square_q32(lag_sec2) / 3;
}

void integrity_motion_axes(struct integrity_state *st, const struct integrity_config *cfg,
                           const struct window_state *w, const struct window_stats *s, bool learn,
                           const struct integrity_axes_coeffs *ac, struct integrity_window *out,
                           fix_q32_t lag2_mm2[INTEGRITY_AXES]) {
    /* the steady-motion lag is learnt when this block's sensors were used in the last three
     * (an axis the window cannot observe learns 0) */
    if (learn) {
        (void)memset(st->steady_lag2_mm2, 0, sizeof st->steady_lag2_mm2);
    }
    const bool history = learn && (st->block_used[0] & out->used) == out->used &&
                         (st->block_used[1] & out->used) == out->used &&
                         (st->block_used[2] & out->used) == out->used;
    fix_q32_t block_var[ANGLES_SENSORS]; /* per-block variance of each sensor's mean */
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        block_var[k] = fix_sat_add_s64(out->white_mm2[k], out->extra_mm2[k]);
    }
    /* (n − 1)/(6n) in Q31 for a block of n = fill rows (6n <= 1536 fits the 16-bit divider;
     * 0 for n < 2: no lag) */
    const uint32_t n = w->fill;
    const uint32_t n_less_one = n >= 2u ? n - 1u : 0u;
    const int32_t gain_q31 =
        n >= 2u ? (int32_t)fix_div_u64_u16((uint64_t)n_less_one << 31, 6u * n) : 0;
    const fix_q32_t osc_lag2 = integrity_oscillation(cfg, out); /* both angle axes' */
    for (unsigned ax = 0; ax < INTEGRITY_AXES; ++ax) {
        lag2_mm2[ax] = 0;
        const int8_t *c = ac->c[ax];
        const int unit = ac->unit[ax];
        if (unit < 0) {
            continue;
        }
        fix_q32_t ramp_lag = 0;
        fix_q32_t ramp_var = 0;
        const bool allow =
            axis_lag(cfg, (enum integrity_axis)ax, c, unit, out, &ramp_lag, &ramp_var);
        if (history) {
            fix_q32_t y[4];
            const fix_q32_t var =
                block_values(st, s, out, block_var, (enum integrity_axis)ax, c, unit, y);
            st->steady_lag2_mm2[ax] = steady_lag2(y, var, gain_q31, ramp_lag, ramp_var);
        }
        /* the lag this window shows, or the steady motion's learnt one, or the oscillation's,
         * whichever is larger */
        const fix_q32_t seen = allow ? integrity_square_q32(out->lag_mm[ax]) : 0;
        lag2_mm2[ax] = seen > st->steady_lag2_mm2[ax] ? seen : st->steady_lag2_mm2[ax];
        if (ax != (unsigned)INTEGRITY_DISTANCE && osc_lag2 > lag2_mm2[ax]) {
            lag2_mm2[ax] = osc_lag2;
        }
        /* ... or, at least, what a motion within the plate's rate bound may leave unseen */
        const fix_q32_t bound2 = ax < 2u ? rate_bound_lag2(cfg, n, out->tan_q32[ax]) : 0;
        if (bound2 > lag2_mm2[ax]) {
            lag2_mm2[ax] = bound2;
        }
        if (out->moved[ax]) {
            out->why |= ATTITUDE_WHY_MOTION;
        }
    }
}

void integrity_motion_remember(struct integrity_state *st, const struct window_stats *s,
                               const struct integrity_window *out) {
    st->block_used[2] = st->block_used[1];
    st->block_used[1] = st->block_used[0];
    st->block_used[0] = out->used;
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        st->block_mean_mm[2][k] = st->block_mean_mm[1][k];
        st->block_mean_mm[1][k] = st->block_mean_mm[0][k];
        st->block_mean_mm[0][k] = s->sensor[k].mean_mm;
    }
}
