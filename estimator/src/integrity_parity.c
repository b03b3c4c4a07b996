/* The parity test of a window and the per-sensor drift its residual teaches. */
/* A flat plate gives x_A + x_C − x_B − x_D = 0 whatever its attitude. */
#include "integrity_internal.h"

/* One block's drift sample: the parity residual's mean square beyond what is not learnt
 * (base), shared by four sensors, clipped (see below); st->drift_mm2 takes it in. */
static void learn_drift(struct integrity_state *st, const struct integrity_config *cfg,
                        fix_q32_t parity_mm, fix_q32_t base_sum) {
    /* mean square beyond what is not learnt, shared by four sensors, clipped at a
     * residual on the test's threshold without learnt drift: a faulty window cannot
     * teach the test to accept it, nor can a run of them (the limit does not grow
     * with what was learnt); a larger wander stays a parity failure */
    fix_q32_t sample = fix_asr_s64(integrity_square_q32(parity_mm) - base_sum, 2u);
    const fix_q32_t limit = fix_asr_s64(
        fix_mul_shr_s64(base_sum, (int64_t)cfg->parity_sigmas_q8 * (int64_t)cfg->parity_sigmas_q8,
                        16u, NULL),
        2u);
    /* negative samples are kept: clipping them at 0 would learn drift from white
     * noise alone (E[max(0, W(χ² − 1))] = 0.48 W); only the upper clip remains, and
     * a floor of −base/4 bounds one window's pull downwards */
    const fix_q32_t floor = -fix_asr_s64(base_sum, 2u);
    sample = sample < floor ? floor : sample;
    const fix_q32_t shown = sample; /* what the parity shows, for `recalibrate` */
    sample = sample > limit ? limit : sample;
    const uint16_t cap = (uint16_t)(1u << cfg->drift_shift);
    if (st->blocks < cap) {
        st->blocks++;
    }
    const int64_t b = st->blocks;
    st->drift_mm2 += fix_div_round_s64(sample - st->drift_mm2, b);
    st->shown_mm2 += fix_div_round_s64(shown - st->shown_mm2, b);
    /* the learnt drift's own scatter: white noise alone gives r² = base·χ²₁, so a sample
     * (r² − base)/4 has variance 2·base²/16 = base²/8; the mean with gain 1/b takes it in
     * as V ← ((b − 1)²·V + base²/8)/b² (once per block: the 128-bit division is cheap) */
    const fix_q32_t v = fix_asr_s64(integrity_square_q32(base_sum), 3u);
    st->drift_var_mm4 = fix_s128_div_s64(
        fix_s128_add(fix_s128_mul(st->drift_var_mm4, (b - 1) * (b - 1)), fix_s128_from_s64(v)),
        b * b, NULL);
    /* the same samples' mean over the whole run: the parity's one direction of the drift,
     * which by the isotropy assumption stands for the three it cannot see, kept when
     * the recent blocks' residual happens to pass near 0 */
    if (st->long_blocks < UINT32_MAX) {
        st->long_blocks++;
    }
    st->drift_long_mm2 += fix_div_round_s64(sample - st->drift_long_mm2, st->long_blocks);
}

/* The prior walk's variance at rows since the start: offset_walk (µm²/h) · (the calibration's
 * age at the start + rows · period) (µs) / 3.6e9 µs/h, in µm², then as Q32 mm² (saturating: it
 * grows, it is never capped). Never scaled down by what the parity shows:
 * docs/explanation/estimators.md, "Drift since the start" (a smooth drift's short spans hide its
 * long ones). */
fix_q32_t integrity_prior_walk(const struct integrity_config *cfg, uint32_t rows) {
    bool sat = false;
    const int64_t us =
        (int64_t)rows * (int64_t)cfg->period_us + (int64_t)cfg->calibration_age_s * 1000000;
    const int64_t um2 = fix_muldiv_s64(us, (int64_t)cfg->offset_walk_um2_h, 3600000000, &sat);
    const int64_t q32 = fix_muldiv_s64(um2, FIX_Q32_ONE, 1000000, &sat);
    return sat ? INT64_MAX : q32;
}

/* `recalibrate`: the drift the parity shows (significant) beyond k² times the allowance
 * since the start, offset stability² plus the prior walk. */
static bool beyond_allowance(const struct integrity_state *st, const struct integrity_config *cfg) {
    const fix_q32_t allowance =
        fix_sat_add_s64(integrity_um2_to_q32(cfg->offset_stability_um), st->walk_mm2);
    const uint32_t k_q8 = INTEGRITY_RECALIBRATE_SIGMAS_Q8;
    const int64_t k = (int64_t)k_q8;
    const fix_q32_t limit = fix_mul_shr_s64(allowance, k * k, 16u, NULL);
    return st->shown_mm2 > limit &&
           integrity_beyond(st->shown_mm2, st->drift_var_mm4, INTEGRITY_DRIFT_SIGNIFICANCE_Q8);
}

void integrity_parity(struct integrity_state *st, const struct integrity_config *cfg,
                      const struct window_stats *s, const struct integrity_noise_sums *sums,
                      bool learn, struct integrity_window *out) {
    if (learn) { /* the walk grows with the time since the start, once per block */
        st->walk_mm2 = integrity_prior_walk(cfg, st->rows);
    }
    if (out->used == ANGLES_ALL_SENSORS) {
        const struct window_sensor_stats *sn = s->sensor;
        out->parity_mm = sn[ANGLES_A].mean_mm + sn[ANGLES_C].mean_mm - sn[ANGLES_B].mean_mm -
                         sn[ANGLES_D].mean_mm;
        out->parity_failed = integrity_beyond(out->parity_mm, sums->total, cfg->parity_sigmas_q8);
        if (learn) {
            learn_drift(st, cfg, out->parity_mm, sums->base);
        }
    }
    if (out->parity_failed) {
        out->why |= ATTITUDE_WHY_PARITY;
    }
    /* `drift` only when the learnt drift is both large and significant: its scatter from
     * white noise alone crossed the flag at short windows and high noise (N = 20,
     * σ 7.3 mm, 35 % of windows); the sd keeps the whole learnt drift (integrity_noise.c) */
    if (st->drift_mm2 > integrity_um2_to_q32(cfg->drift_flag_um) &&
        integrity_beyond(st->drift_mm2, st->drift_var_mm4, INTEGRITY_DRIFT_SIGNIFICANCE_Q8)) {
        out->why |= ATTITUDE_WHY_DRIFT;
    }
    if (beyond_allowance(st, cfg)) {
        out->why |= ATTITUDE_WHY_RECALIBRATE;
    }
}

fix_q32_t integrity_parity_cover(fix_q32_t parity2_mm2, const int8_t c[ANGLES_SENSORS], int unit) {
    int64_t worst = 0;
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        worst = (int64_t)c[k] * c[k] > worst ? (int64_t)c[k] * c[k] : worst;
    }
    return fix_asr_s64(fix_sat_mul_s64(parity2_mm2, worst), 2u * (unsigned)unit);
}
