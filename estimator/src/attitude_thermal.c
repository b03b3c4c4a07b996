/* A thermal calibration's correction: each offset at the rows' temperature, and its sd. */
#include "attitude_internal.h"
#include "fixmath_internal.h"

/* The window's offsets follow the temperature in steps of at most this (fine units, 31 µm):
 * a smaller change waits for the next empty window (tumbling) or until it reaches a step,
 * since each step sums the window's rows again (window_shift_offsets, about 500 instructions
 * a row held). A part moving 40 µm/°C on a 40 °C orbital cycle (1.4 °C/min at most) steps
 * every 33 s at the fastest: under 30 instructions a row at N = 100, 50 Hz. The step's error,
 * (31 µm)² at most, is in the sd (attitude_thermal_var), under the offset stability's
 * (120 µm)². */
#define THERMAL_STEP_FINE 32
#define THERMAL_STEP_UM2  977 /* (32 · 1000/1024 µm)² */

static bool thermal_on(const struct attitude_config *cfg) {
    return cfg->calibration.calibrated && cfg->calibration.thermal;
}

void attitude_thermal_prepare(struct attitude_state *st) {
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        /* nm/°C as fine units (1/1024 mm) per 0.01 °C, Q32: k · 1024 · 2^32 / (10^6 · 100);
         * |k| <= 10^6 gives < 2^36 */
        st->thermal_fine_q32[k] =
            thermal_on(&st->cfg)
                ? fix_muldiv_s64((int64_t)st->cfg.calibration.temp_coeff_nm_per_c[k],
                                 (int64_t)1 << 42, 100000000, NULL)
                : 0;
    }
}

void attitude_thermal_row(struct attitude_state *st) {
    if (!thermal_on(&st->cfg)) {
        return;
    }
    /* without a temperature: the calibration temperature's offsets, as a calibration
     * without coefficients (the sd's time-based drift prior covers the rest) */
    const int32_t dt =
        st->temp_known ? (int32_t)st->temp_cdeg - st->cfg.calibration.cal_temp_cdeg : 0;
    st->thermal_in_force = st->temp_known;
    if (dt == st->thermal_dt_cdeg) {
        return; /* the offsets in force are this temperature's: most rows */
    }
    struct window_state *w = &st->window;
    int32_t shift[ATTITUDE_SENSORS];
    bool step = false;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        /* |Q32 · dt| < 2^36 · 2^15: rounded to the nearest fine unit */
        shift[k] = (int32_t)fix_asr_s64(st->thermal_fine_q32[k] * dt + 0x80000000, 32u);
        const int32_t change = shift[k] - (w->cal_offset_fine[k] - w->cal_base_offset_fine[k]);
        step = step || change >= THERMAL_STEP_FINE || change <= -THERMAL_STEP_FINE;
    }
    /* a smaller change is taken for free when the window is empty */
    if (step || window_fill(w) == 0u) {
        window_shift_offsets(w, shift);
        st->thermal_dt_cdeg = dt;
    }
}

/* |a · b| / 10^5 in µm for a in nm/°C and b in 0.01 °C. */
static int64_t nm_per_c_times_cdeg_um(int64_t a, int64_t b) {
    const int64_t p = a * b; /* < 2^20 · 2^15 */
    return fix_div_round_s64(p < 0 ? -p : p, 100000);
}

void attitude_thermal_var(struct attitude_state *st) {
    const struct calibration_head *c = &st->cfg.calibration;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        int64_t var = 0;
        if (thermal_on(&st->cfg) && (st->thermal_in_force || st->thermal_dt_cdeg != 0)) {
            /* the coefficient's own error over the distance from the calibration
             * temperature, and the coefficient times the temperature's error */
            const int64_t coeff_um =
                nm_per_c_times_cdeg_um((int64_t)c->temp_coeff_sd_nm_per_c[k], st->thermal_dt_cdeg);
            const int64_t temp_um =
                nm_per_c_times_cdeg_um((int64_t)c->temp_coeff_nm_per_c[k], st->cfg.temp_sd_cdeg);
            var = coeff_um * coeff_um + temp_um * temp_um + THERMAL_STEP_UM2;
        }
        st->integrity.thermal_var_um2[k] = var;
    }
}
