/* The window family's private parts (window_stats.c and window_gate.c only): the head's
 * calibration applied to the window's readings and statistics (estimator/window_stats.h,
 * "Calibration"), and the gate. */
#ifndef ESTIMATOR_WINDOW_INTERNAL_H
#define ESTIMATOR_WINDOW_INTERNAL_H

#include <stdint.h>

#include "estimator/window_stats.h"
#include "fixmath_internal.h"

/* One reading corrected (docs/explanation/architecture.md: true = (raw − offset)/gain), in fine
 * units: d = raw − offset, true = d + round(d·r/2^32) with r = 1/gain − 1 in Q32, computed as the
 * high word of d·2^32 + 2^31 + d·r (one multiply-accumulate on a Cortex-M). The product stays below
 * 2^59 and the sum below 2^63 (|d| < 2^27, |r| < 2^31). Deterministic, so a row dropped later
 * subtracts exactly what it added; identity (offset 0, r 0) gives raw · 1024 exactly. */
FIX_INLINE int32_t window_correct_one(const struct window_state *w, unsigned k, uint16_t raw) {
    const int32_t d = (int32_t)raw * ANGLES_FINE_ONE - w->cal_offset_fine[k];
    const int64_t prod = (int64_t)d * w->cal_inv_gain_q32[k];
    const uint64_t acc = (((uint64_t)(uint32_t)d << 32) | 0x80000000u) + (uint64_t)prod;
    return (int32_t)(uint32_t)(acc >> 32);
}

/* The four readings of a row corrected (window_correct_one). */
FIX_INLINE void window_correct(const struct window_state *w,
                               const uint16_t range_mm[ANGLES_SENSORS], int32_t x[ANGLES_SENSORS]) {
    for (unsigned k = 0; k < ANGLES_SENSORS; ++k) {
        x[k] = window_correct_one(w, k, range_mm[k]);
    }
}

/* The newest row's reading k corrected, also in whole mm for the Kalman filter, with the
 * rounding error carried to the next row (error feedback): whole mm rounded alone would
 * leave the fraction of a calibration's offset in every reading (raw readings are whole
 * mm), a bias of up to 0.5 mm per sensor in the filter, 0.48° of α at a = 30 mm (an
 * independent review: without it the filter's RMS error 1.69× the true calibration's);
 * carried, the whole-mm readings of any run of rows sum to the exact ones within 0.5 mm,
 * so the filter's averages hold no bias. An identity calibration (or whole-mm offsets
 * with gain 1) leaves the carry at 1/2 mm and the readings as they came. The carry stays
 * within 0 .. 1023 fine units whatever the reading (an implausible one is never used and
 * its whole-mm value may wrap; below 0 the value is 0). */
FIX_INLINE void window_correct_newest_one(struct window_state *w, unsigned k, uint16_t raw) {
    const int32_t x = window_correct_one(w, k, raw);
    w->newest_fine[k] = x;
    const int32_t f = x + (int32_t)w->newest_carry[k];
    w->newest_carry[k] = (uint32_t)f & ((uint32_t)ANGLES_FINE_ONE - 1u);
    w->newest_mm[k] = (uint16_t)((uint32_t)(f < 0 ? 0 : f) >> ANGLES_FINE_SHIFT);
}

/* window_correct() of the newest row into newest_fine and newest_mm, unrolled: it runs on
 * every row (a budget of 60 instructions a row on the Cortex-M4). */
FIX_INLINE void window_correct_newest(struct window_state *w,
                                      const uint16_t range_mm[ANGLES_SENSORS]) {
    window_correct_newest_one(w, 0u, range_mm[0]);
    window_correct_newest_one(w, 1u, range_mm[1]);
    window_correct_newest_one(w, 2u, range_mm[2]);
    window_correct_newest_one(w, 3u, range_mm[3]);
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
    ss->var_mm2 += fix_mul_shr_s64(ss->var_mm2, w->cal_inv_gain2_q32[k], FIX_Q32_SHIFT, NULL);
}

/* The gate of every sensor with valid readings (window_gate.c): median and half-width (both
 * x2 mm) and whether the gate applies (off, or nothing to gate: false). */
void window_gate_sensors(const struct window_state *w, const uint16_t count[ANGLES_SENSORS],
                         int32_t median_x2[ANGLES_SENSORS], int32_t half_width_x2[ANGLES_SENSORS],
                         bool gate_on[ANGLES_SENSORS]);

#endif /* ESTIMATOR_WINDOW_INTERNAL_H */
