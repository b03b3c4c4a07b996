/*
 * The re-zero command (docs/how-to/calibrate-a-head.md "Re-zero"): at the latched position the
 * attitude is zero by construction, so all four sensors see the same true distance x̄; N
 * samples refit the four offsets from it, keeping the gains. x̄ itself is unknown, so the sum
 * of the offsets is kept as the calibration has it (the one direction the latch cannot
 * tell): with m_i the mean reading of sensor i and g_i = 1 + gain_ppm_i / 10^6,
 *
 *     x̂ = Σ (m_i − o_i) / Σ g_i,      o_i' = m_i − g_i · x̂      (Σ o_i' = Σ o_i)
 *
 * and the corrected readings (m_i − o_i') / g_i are all x̂: attitude zero. Each new offset's
 * variance, from δo_i' = δm_i − g_i δx̂ with g ≈ 1 and the old offsets' errors independent:
 *
 *     var o_i' = var m_i · (1 − 2/4) + Σ_j var m_j / 16 + Σ_j var o_j / 16
 *
 * with var m_i = s_i² / n_i (s_i the readings' sd about their mean, n_i the valid
 * readings) floored at (1 mm)²/12 / n_i for whole-millimetre readings. Integers only.
 *
 * A thermal calibration (estimator/calibration.h) is refitted at the samples' mean
 * temperature T: the offsets in force there, o_i + k_i · (T − cal_temp), are the o_i above
 * (their variance with the coefficient's, (sd k_i · (T − cal_temp))²), and T becomes the
 * calibration temperature, the coefficients kept. Without a temperature in any sample it
 * is not refitted: offsets at an unknown temperature would be corrected from the wrong one.
 */
#ifndef FIRMWARE_REZERO_H
#define FIRMWARE_REZERO_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/calibration.h"
#include "firmware/assembler.h"

#define TOF_REZERO_MIN 10u   /* samples: fewer cannot give an sd */
#define TOF_REZERO_MAX 5000u /* 100 s at 20 ms; the sums stay within 64 bits */

struct tof_rezero {
    uint16_t wanted, seen;             /* samples asked for, taken so far (0 wanted: idle) */
    uint32_t n[CALIBRATION_SENSORS];   /* valid readings (present, status 0) */
    uint64_t sum[CALIBRATION_SENSORS]; /* mm */
    uint64_t sum2[CALIBRATION_SENSORS];
    int32_t temp_sum; /* 0.01 °C, over the samples with a temperature */
    uint16_t temp_n;
};

/* Start collecting `samples` samples (TOF_REZERO_MIN..MAX). false: out of range. */
bool tof_rezero_start(struct tof_rezero *z, uint16_t samples);

/* Take one assembled sample. true once the last asked for is in. */
bool tof_rezero_add(struct tof_rezero *z, const struct tof_sample *sample);

/* The calibration `cal` (calibrated) with its offsets and their sd refitted from what was
 * collected, gains kept (a thermal one at the samples' mean temperature, which becomes its
 * calibration temperature), into `out`. false (out untouched): `cal` not calibrated, a
 * sensor with fewer than half the samples valid, or `cal` thermal and no sample with a
 * temperature. */
bool tof_rezero_fit(const struct tof_rezero *z, const struct calibration_head *cal,
                    struct calibration_head *out);

#endif /* FIRMWARE_REZERO_H */
