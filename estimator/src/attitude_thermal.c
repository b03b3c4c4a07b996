/* A thermal calibration's correction: each offset at the rows' temperature, and its sd. */
#include "attitude_internal.h"
#include "fixmath_internal.h"

/* The window's offsets follow the temperature in steps of 1 °C: a smaller change waits for the
 * next empty window (tumbling), since a step sums the window's rows again (window_shift_offsets,
 * about 500 instructions a row held). A measured temperature's noise (0.3 °C) crosses a whole
 * degree seldom, and a 40 °C orbital cycle takes about 80 steps in 90 minutes: a few
 * instructions a row on average. The degree a step may lag is in the sd (attitude_thermal_var):
 * the coefficient times 1 °C. */
#define THERMAL_STEP_CDEG 100

/* Without a temperature the offsets stay those of the last one measured, and the parts may have
 * moved since by up to this rate: 2 °C/min, above the 1.4 °C/min at most of a 40 °C orbital cycle
 * of 90 minutes (20 °C · 2π / 90 min), never beyond the parts' operating range (VL53L1X: −20 to
 * 85 °C, DS12385 §1), which is also the bound when no temperature was ever measured. */
#define THERMAL_SLEW_CDEG_PER_MIN 200
#define THERMAL_PART_MIN_CDEG     (-2000)
#define THERMAL_PART_MAX_CDEG     8500

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
    if (!st->temp_known) {
        /* the offsets in force stay; the sd widens with the time since (attitude_thermal_var) */
        st->thermal_unknown_rows += st->thermal_unknown_rows < UINT32_MAX ? 1u : 0u;
        return;
    }
    st->thermal_unknown_rows = 0u;
    st->thermal_in_force = true;
    const int32_t dt = (int32_t)st->temp_cdeg - st->cfg.calibration.cal_temp_cdeg;
    const int32_t change = dt - st->thermal_dt_cdeg;
    if (change == 0 || (change < THERMAL_STEP_CDEG && change > -THERMAL_STEP_CDEG &&
                        window_fill(&st->window) != 0u)) {
        return; /* most rows: the offsets in force are this temperature's within a step */
    }
    int32_t shift[ATTITUDE_SENSORS];
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        /* |Q32 · dt| < 2^36 · 2^15: rounded to the nearest fine unit */
        shift[k] = (int32_t)fix_asr_s64(st->thermal_fine_q32[k] * dt + ((int64_t)1 << 31), 32u);
    }
    window_shift_offsets(&st->window, shift);
    st->thermal_dt_cdeg = dt;
}

/* |a · b| / 10^5 in µm for a in nm/°C and b in 0.01 °C. */
static int64_t nm_per_c_times_cdeg_um(int64_t a, int64_t b) {
    const int64_t p = a * b; /* < 2^20 · 2^15 */
    return fix_div_round_s64(p < 0 ? -p : p, 100000);
}

/* How far (0.01 °C) the parts' temperature may be from the one the offsets in force belong to:
 * a step's lag and the measurement's sd always, plus, without a temperature, the slew since
 * the last one (or the whole operating range when there was none). */
static int64_t thermal_unknown_cdeg(const struct attitude_state *st) {
    const int32_t cal = st->cfg.calibration.cal_temp_cdeg;
    const int32_t below = cal + st->thermal_dt_cdeg - THERMAL_PART_MIN_CDEG;
    const int32_t above = THERMAL_PART_MAX_CDEG - cal - st->thermal_dt_cdeg;
    const int32_t wider = below > above ? below : above;
    const int64_t range = wider;
    if (!st->thermal_in_force) {
        return range > 0 ? range : 0;
    }
    const int64_t us = (int64_t)st->thermal_unknown_rows * (int64_t)st->cfg.period_us;
    const int64_t slew = fix_muldiv_s64(us, THERMAL_SLEW_CDEG_PER_MIN, 60000000, NULL);
    return slew < range ? slew : (range > 0 ? range : 0);
}

void attitude_thermal_var(struct attitude_state *st) {
    const struct calibration_head *c = &st->cfg.calibration;
    const bool on = thermal_on(&st->cfg);
    const int64_t unknown_cdeg = on ? thermal_unknown_cdeg(st) : 0;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        int64_t var = 0;
        if (on) {
            /* the coefficient's own error over the distance from the calibration temperature,
             * and the coefficient times what the temperature may be off by: its sd, a step's
             * lag, and the time without one (independent: added as variances) */
            const int64_t coeff_um =
                nm_per_c_times_cdeg_um((int64_t)c->temp_coeff_sd_nm_per_c[k], st->thermal_dt_cdeg);
            const int64_t c_nm = (int64_t)c->temp_coeff_nm_per_c[k];
            const int64_t sd_um = nm_per_c_times_cdeg_um(c_nm, st->cfg.temp_sd_cdeg);
            const int64_t step_um = nm_per_c_times_cdeg_um(c_nm, THERMAL_STEP_CDEG);
            const int64_t gone_um = nm_per_c_times_cdeg_um(c_nm, unknown_cdeg);
            var = coeff_um * coeff_um + sd_um * sd_um + step_um * step_um + gone_um * gone_um;
        }
        st->integrity.thermal_var_um2[k] = var;
    }
}
