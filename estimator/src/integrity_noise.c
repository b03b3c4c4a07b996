/* Each sensor's noise budget in a window: what its mean's variance is, seen and unseen. */
#include "integrity_internal.h"

/* What sensor k's calibration leaves in its corrected reading at distance x (Q32 mm), as a
 * variance (Q32 mm²): the error of (raw − offset)/gain is about −(δo + x·δg), so
 * var = σo² + (x·σg)² + 2·x·ρ·σo·σg (docs/how-to/calibrate-a-head.md, `offset_gain_corr`). At gain
 * 1 (the 1/gain² it omits is within ±0.2 of 1 for gains within ±10 %). 0 for a calibration stated
 * exact. */
static fix_q32_t calibration_var(const struct integrity_state *st,
                                 const struct integrity_config *cfg, unsigned k, fix_q32_t x_mm) {
    const int64_t so = cfg->cal_offset_sd_um[k];
    const int64_t x_um = fix_asr_s64(x_mm * 1000, FIX_Q32_SHIFT); /* |x| < 2^48 */
    /* x·σg in µm: · 4295 / 2^32 for / 10^6 (8e-6 relative), no 64-bit division */
    const int64_t sg = fix_asr_s64(x_um * (int64_t)cfg->cal_gain_sd_ppm[k] * 4295, 32u);
    int64_t var = so * so + sg * sg + fix_asr_s64(2 * so * sg * cfg->cal_corr_q15[k], 15u);
    var = var > 0 ? var : 0;
    /* the temperature correction's share (< 2^40 µm²: |coefficient sd| <= 1 mm/°C over
     * <= 300 °C), independent of the rest */
    var += st->thermal_var_um2[k];
    /* µm² as Q32 mm²: · 4295 for 2^32 / 10^6 (8e-6 relative, within int64: var < 2^46) */
    return var * 4295;
}

/* The ring pass sums the readings as they came (integrity.c), the window statistics are
 * corrected (window_stats.c): a late step compares the newest rows' sum with the window
 * mean, so the tails' sums are corrected here, before the motion statistics read them
 * (to whole mm: at most 0.5 mm / m off for a tail of m readings, under 0.2 of the
 * step's own sd floor). The ramp's slope is offset-free and off by the gain only. */
static void correct_tails(const struct integrity_config *cfg, const struct window_state *w,
                          struct integrity_window *out) {
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        /* the offset in force, fine units (its temperature's: window_shift_offsets) */
        const int64_t o = w->cal_offset_fine[k];
        const int64_t g = 1000000 + (int64_t)cfg->cal_gain_ppm[k];
        if (o == 0 && g == 1000000) {
            continue;
        }
        struct integrity_ramp_sums *r = &out->ramp[k];
        for (unsigned t = 0; t < 2u; ++t) {
            /* µm: (mm · 1024 − fine) · 1000 / 1024 */
            const int64_t fine =
                (int64_t)r->tail_sx[t] * ANGLES_FINE_ONE - (int64_t)r->tail_n[t] * o;
            const int64_t um = fix_asr_s64(fine * 125, 7u);
            /* never below 0: the motion statistics take the sums as distances (>= 0); a
             * reading corrected below 0 (read under its offset) counts as 0 there */
            const int64_t v = fix_div_round_s64(um * 1000, g);
            r->tail_sx[t] = (int32_t)(v > 0 ? v : 0);
        }
    }
}

void integrity_noise_budget(const struct integrity_state *st, const struct integrity_config *cfg,
                            const struct window_state *w, const struct window_stats *s,
                            struct integrity_window *out, struct integrity_noise_sums *sums) {
    const fix_q32_t prior = integrity_um2_to_q32(cfg->offset_stability_um);
    fix_q32_t base_sum = 0;  /* what the window sees, the prior and the rounding */
    fix_q32_t total_sum = 0; /* ... plus the learnt drift: the parity residual's variance */
    correct_tails(cfg, w, out);
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        const struct window_sensor_stats *ss = &s->sensor[k];
        if (ss->used == 0u) {
            continue;
        }
        out->used = (uint8_t)(out->used | (1u << k));
        /* a window of identical readings still has the rounding's 1/12 mm² */
        const fix_q32_t s2 = ss->var_mm2 > Q32_TWELFTH ? ss->var_mm2 : Q32_TWELFTH;
        out->white_mm2[k] = integrity_div_small(s2, ss->used);
        /* noise under half a step does not dither the rounding: the mean keeps its error */
        const fix_q32_t quant = ss->var_mm2 < Q32_QUARTER ? Q32_TWELFTH : 0;
        /* the learnt drift and the walk since the start (integrity_parity.c), never below 0 */
        const fix_q32_t drift = integrity_drift_var_of(st);
        /* the calibration's share is not learnt: it is in the parity threshold (an
         * uncalibrated head's x_A + x_C − x_B − x_D reads tens of mm) and in the base the
         * drift is learnt beyond */
        const fix_q32_t cal = calibration_var(st, cfg, k, ss->mean_mm);
        const fix_q32_t fixed = fix_sat_add_s64(fix_sat_add_s64(prior, quant), cal);
        out->extra_mm2[k] = fix_sat_add_s64(drift, fixed);
        base_sum = fix_sat_add_s64(base_sum, fix_sat_add_s64(out->white_mm2[k], fixed));
        total_sum =
            fix_sat_add_s64(total_sum, fix_sat_add_s64(out->white_mm2[k], out->extra_mm2[k]));
    }
    sums->base = base_sum;
    sums->total = total_sum;
}
