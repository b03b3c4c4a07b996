/* Window integrity (estimator/integrity.h): the ring pass and integrity_assess(). */
/* integrity_assess() orchestrates the noise budget, parity, motion and each axis' extra
 * variance (estimator/src/integrity_*.c, integrity_internal.h). */
#include "estimator/integrity.h"

#include <string.h>

#include "fixmath_internal.h"
#include "integrity_internal.h"

fix_q32_t integrity_drift_var(const struct integrity_state *st) {
    return integrity_drift_var_of(st);
}

bool integrity_config_valid(const struct integrity_config *cfg) {
    return cfg->range_max_mm != 0u && cfg->range_max_mm < INTEGRITY_NO_TARGET_8190 &&
           cfg->parity_sigmas_q8 >= 256u && cfg->parity_sigmas_q8 <= 16u * 256u &&
           cfg->motion_sigmas_q8 >= 256u && cfg->motion_sigmas_q8 <= 16u * 256u &&
           cfg->drift_shift != 0u && cfg->drift_shift <= 8u &&
           cfg->period_us >= INTEGRITY_PERIOD_US_MIN && cfg->period_us <= INTEGRITY_PERIOD_US_MAX &&
           cfg->max_rate_mdeg_s <= INTEGRITY_MAX_RATE_MDEG_S_MAX;
}

void integrity_init(struct integrity_state *st) {
    (void)memset(st, 0, sizeof *st);
}

static bool implausible(uint16_t mm, uint16_t range_max_mm) {
    /* 0 or above the max (8190, 8191, 65535 lie above any valid max) in one unsigned
     * comparison: 0 − 1 wraps to 65535 */
    return (uint16_t)(mm - 1u) >= range_max_mm;
}

/* The ring pass: per-sensor reasons of the readings the window holds, the ramp sums of the
 * readings the window statistics used (valid and inside the gate), and the oscillation
 * test's sums of the rows with all four valid (the gate's outliers too: one sensor's moves
 * u_α or u_β and p alike, so the test's excess keeps its mean). Not inlined: the
 * per-row loop keeps the registers to itself (Cortex-M4 bench: about 3,000 fewer
 * instructions per window end than inlined into integrity_assess). */
FIX_NOINLINE attitude_why_t scan_rows(const struct integrity_config *cfg,
                                      const struct window_state *w, const struct window_stats *s,
                                      struct integrity_ramp_sums r[ANGLES_SENSORS],
                                      struct integrity_osc_sums *osc) {
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
            struct integrity_ramp_sums *rk = &r[k];
            if ((valid & (1u << k)) == 0u || dev > half[k]) {
                /* not used by the window statistics (gate: window_stats.c); a late move the
                 * gate dropped still counts for the late step (integrity_motion.c) */
                if ((valid & (1u << k)) != 0u && i >= tail8) {
                    rk->tail_out_n++;
                    rk->tail_out_sx += x;
                }
                continue;
            }
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
        if (valid == ANGLES_ALL_SENSORS) {
            integrity_oscillation_row(osc, row->range_mm);
        }
    }
    return why;
}

/* Slopes for the delta method, from the pair means (0: the conservative 1/(1 + t²) = 1). */
static void slopes(const struct integrity_config *cfg, const struct window_stats *s,
                   struct integrity_window *out) {
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
}

/* Per axis the window observes: what a window estimator's white variance misses, the
 * sensors' drift, prior and rounding, a failed parity's cover, and the motion lag². */
static void axes_extra(struct integrity_window *out, const struct integrity_axes_coeffs *ac,
                       const fix_q32_t lag2_mm2[INTEGRITY_AXES]) {
    const fix_q32_t parity2 = integrity_square_q32(out->parity_mm);
    for (unsigned ax = 0; ax < INTEGRITY_AXES; ++ax) {
        const int unit = ac->unit[ax];
        if (unit < 0) {
            continue;
        }
        fix_q32_t extra = 0;
        (void)integrity_axis_var((enum integrity_axis)ax, out->used, out->extra_mm2, &extra);
        if (out->parity_failed) {
            extra = fix_sat_add_s64(extra, integrity_parity_cover(parity2, ac->c[ax], unit));
        }
        out->extra_var_mm2[ax] = fix_sat_add_s64(extra, lag2_mm2[ax]);
    }
}

void integrity_assess(struct integrity_state *st, const struct integrity_config *cfg,
                      struct window_state *w, const struct window_stats *s, uint32_t rows,
                      bool learn, struct integrity_window *out) {
    (void)memset(out, 0, sizeof *out);
    st->rows = rows; /* the drift allowance's time: rows × period since the start */
    /* the ramp sums: zeroed above; in out, not on the window-end stack */
    out->why = scan_rows(cfg, w, s, out->ramp, &out->osc);
    if (st->walk_mm2 == 0 && cfg->calibration_age_s != 0u) {
        /* a calibration older than the start: its walk counts from the first window, not
         * from the first block's end (integrity_parity) */
        st->walk_mm2 = integrity_prior_walk(cfg, rows);
    }
    struct integrity_noise_sums sums;
    integrity_noise_budget(st, cfg, w, s, out, &sums);
    integrity_motion_sensors(w, s, out);
    slopes(cfg, s, out);
    integrity_parity(st, cfg, s, &sums, learn, out); /* learns the drift from this window */
    struct integrity_axes_coeffs ac;
    integrity_axes_coeffs(out->used, &ac);
    fix_q32_t lag2[INTEGRITY_AXES];
    integrity_motion_axes(st, cfg, w, s, learn, &ac, out, lag2);
    /* The walk since the start may move all four offsets together (temperature, the
     * cover's reflectance): the parity cannot see it and α, β do not feel it, but x̄ takes
     * all of it, where the per-sensor allowances gave it a quarter. The distance carries
     * the whole prior walk as well (a quarter too much when the walks are independent). */
    lag2[INTEGRITY_DISTANCE] = fix_sat_add_s64(lag2[INTEGRITY_DISTANCE], st->walk_mm2);
    axes_extra(out, &ac, lag2);
    if (learn) {
        integrity_motion_remember(st, s, out);
    }
}
