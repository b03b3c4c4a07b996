/* Each sensor's noise budget in a window: what its mean's variance is, seen and unseen. */
#include "integrity_internal.h"

void integrity_noise_budget(const struct integrity_state *st, const struct integrity_config *cfg,
                            const struct window_stats *s, struct integrity_window *out,
                            struct integrity_noise_sums *sums) {
    const fix_q32_t prior = integrity_um2_to_q32(cfg->offset_stability_um);
    fix_q32_t base_sum = 0;  /* what the window sees, the prior and the rounding */
    fix_q32_t total_sum = 0; /* ... plus the learnt drift: the parity residual's variance */
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
        const fix_q32_t drift = integrity_drift_var(st);
        out->extra_mm2[k] = fix_sat_add_s64(fix_sat_add_s64(drift, prior), quant);
        base_sum = fix_sat_add_s64(
            base_sum, fix_sat_add_s64(out->white_mm2[k], fix_sat_add_s64(prior, quant)));
        total_sum =
            fix_sat_add_s64(total_sum, fix_sat_add_s64(out->white_mm2[k], out->extra_mm2[k]));
    }
    sums->base = base_sum;
    sums->total = total_sum;
}
