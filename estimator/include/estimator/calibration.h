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
};

#endif /* ESTIMATOR_CALIBRATION_H */
