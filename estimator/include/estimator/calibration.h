/*
 * The head's calibration as the estimator takes it (docs/explanation/architecture.md,
 * docs/reference/calibration-file.md): each sensor reads raw = gain · true + offset, and the
 * estimator corrects every reading to true = (raw − offset) / gain, in fixed point, before any
 * estimator sees it; every sd then carries what the calibration leaves (its own offset and gain
 * uncertainty at the window's distance). An uncalibrated head (calibrated false) is never `ok`: its
 * rows say `uncalibrated` and their sd carries the parts' offset and gain spread below.
 *
 * Units: offsets and their sd in micrometres, gains as parts per million of deviation
 * from 1 (gain 1.00410 is gain_ppm 4100), the correlation of one sensor's offset and gain
 * errors in Q15 (HEAD.cal key `offset_gain_corr`, docs/how-to/calibrate-a-head.md).
 */
#ifndef ESTIMATOR_CALIBRATION_H
#define ESTIMATOR_CALIBRATION_H

#include <stdbool.h>
#include <stdint.h>

#define CALIBRATION_SENSORS 4u /* A, B, C, D */

/* Offsets beyond ±100 mm and gains beyond ±10 % are no VL53 part's (ST: ranging error
 * before offset calibration up to ±20 mm, VL53L1X datasheet DS12385; gains about 1 %):
 * a calibration outside these is refused as a configuration error. */
#define CALIBRATION_OFFSET_MAX_UM 100000
#define CALIBRATION_GAIN_MAX_PPM  100000

/* A coefficient beyond 1 mm/°C would move an offset by 40 mm over an orbit's cycle: no
 * VL53 part's (ST publishes no figure, DS12385 §3.2.1 names "a temperature drift" only), a
 * configuration error. The calibration temperature within −100..200 °C, as a trace's temp_c. */
#define CALIBRATION_TEMP_COEFF_MAX_NM_PER_C 1000000
#define CALIBRATION_TEMP_MIN_CDEG           (-10000)
#define CALIBRATION_TEMP_MAX_CDEG           20000

/* The parts' spread an uncalibrated head's sd carries, as 1σ of a uniform spread over the
 * stated bound (bound / √3): offsets ±20 mm (DS12385, "ranging error" before offset
 * calibration; ../shared/calibration-notes.md item 3) → 11.547 mm; gains ±3 % (the calibration's
 * range of real heads; ST publishes no gain spread) → 1.732 %. A HEAD.cal without gains
 * (one fixture distance) takes gain 1 with this gain sd (docs/reference/calibration-file.md). */
#define CALIBRATION_UNCAL_OFFSET_SD_UM 11547u
#define CALIBRATION_UNCAL_GAIN_SD_PPM  17321u

struct calibration_head {
    bool calibrated;                            /* false: the parts' spread, never ok */
    int32_t offset_um[CALIBRATION_SENSORS];     /* |.| <= CALIBRATION_OFFSET_MAX_UM */
    int32_t gain_ppm[CALIBRATION_SENSORS];      /* gain − 1, |.| <= CALIBRATION_GAIN_MAX_PPM */
    uint32_t offset_sd_um[CALIBRATION_SENSORS]; /* 1σ of the calibration's offset error */
    uint32_t gain_sd_ppm[CALIBRATION_SENSORS];  /* 1σ of its gain error */
    int16_t offset_gain_corr_q15[CALIBRATION_SENSORS]; /* their correlation, Q15 */
    /* Offsets against temperature: at temperature T a part's offset is
     * offset_um + temp_coeff · (T − cal_temp) (docs/how-to/calibrate-a-head.md, "Temperature").
     * Only when thermal is true; otherwise the offsets hold at whatever temperature the head
     * is, and the sd's drift prior covers the change with time alone. */
    bool thermal;                                         /* the coefficients below were measured */
    int16_t cal_temp_cdeg;                                /* where offset_um holds, 0.01 °C */
    int32_t temp_coeff_nm_per_c[CALIBRATION_SENSORS];     /* d offset / dT, nm per °C */
    uint32_t temp_coeff_sd_nm_per_c[CALIBRATION_SENSORS]; /* its 1σ */
};

#endif /* ESTIMATOR_CALIBRATION_H */
