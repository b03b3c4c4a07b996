/* The head's calibration applied to the window's readings and statistics (issue 23). */
/* Private to window_stats.c: see estimator/window_stats.h, "Calibration". */
#ifndef ESTIMATOR_WINDOW_CAL_H
#define ESTIMATOR_WINDOW_CAL_H

#include <stdint.h>

#include "estimator/window_stats.h"
#include "fix_inline.h"

/* The calibration applied to the four readings of a row (DESIGN.md §2: true =
 * (raw − offset)/gain), in fine units: d = raw − offset, true = d + round(d·r/2^32) with
 * r = 1/gain − 1 in Q32. Deterministic, so a row dropped later subtracts exactly what it
 * added; identity (offset 0, r 0) gives raw · 1024 exactly. */
FIX_INLINE void window_correct(const struct window_state *w,
                               const uint16_t range_mm[ANGLES_SENSORS], int32_t x[ANGLES_SENSORS]) {
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        const int32_t d = (int32_t)range_mm[k] * ANGLES_FINE_ONE - w->cal_offset_fine[k];
        x[k] = d + fix_hi32((int64_t)d * w->cal_inv_gain_q32[k] + ((int64_t)1 << 31));
    }
}

/* window_correct() of the newest row, also rounded to whole mm (newest_mm), in one pass. */
FIX_INLINE void window_correct_newest(struct window_state *w,
                                      const uint16_t range_mm[ANGLES_SENSORS]) {
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        const int32_t d = (int32_t)range_mm[k] * ANGLES_FINE_ONE - w->cal_offset_fine[k];
        const int32_t x = d + fix_hi32((int64_t)d * w->cal_inv_gain_q32[k] + ((int64_t)1 << 31));
        w->newest_fine[k] = x;
        const int32_t f = x + (ANGLES_FINE_ONE / 2);
        const uint32_t mm = f < 0 ? 0u : (uint32_t)f >> ANGLES_FINE_SHIFT;
        w->newest_mm[k] = (uint16_t)(mm > 65535u ? 65535u : mm);
    }
}

/* The calibration applied to a sensor's mean and variance (the correction is affine:
 * mean' = (mean − offset)/gain, var' = var/gain², exact from the raw sums; identity
 * leaves both as they are). */
static inline void correct_stats(const struct window_state *w, unsigned k,
                                 struct window_sensor_stats *ss) {
    const int64_t r = w->cal_inv_gain_q32[k];
    const fix_q32_t d =
        ss->mean_mm - (int64_t)w->cal_offset_fine[k] * ((int64_t)1 << (32u - ANGLES_FINE_SHIFT));
    ss->mean_mm = d + fix_mul_shr_s64(d, r, FIX_Q32_SHIFT, NULL);
    const fix_q32_t v = ss->var_mm2 + fix_mul_shr_s64(ss->var_mm2, r, FIX_Q32_SHIFT, NULL);
    ss->var_mm2 = v + fix_mul_shr_s64(v, r, FIX_Q32_SHIFT, NULL);
}

#endif /* ESTIMATOR_WINDOW_CAL_H */
