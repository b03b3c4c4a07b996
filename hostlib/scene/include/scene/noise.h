/*
 * Per-sensor noise models: what turns an ideal distance into the reading a
 * VL53-class part reports (integer mm plus a range status).
 */
#ifndef SCENE_NOISE_H
#define SCENE_NOISE_H

#include <stddef.h>
#include <stdint.h>

#include "scene/rng.h"
#include "scene/row.h"

/* Status code written for a flagged sample: 4 is the VL53L1X ULD's
 * "out of bounds" / phase-consistency failure (UM2510 range status table). */
#define SCENE_STATUS_FLAGGED 4u

struct scene_sensor_noise {
    double sigma_mm;       /* white Gaussian jitter before quantisation */
    double outlier_rate;   /* P(gross outlier) per sample, reported with status 0 */
    double outlier_min_mm; /* outlier magnitude uniform in [min, max), sign random */
    double outlier_max_mm;
    double flag_rate;     /* P(flagged) per sample: status SCENE_STATUS_FLAGGED */
    double flag_error_mm; /* a flagged reading is off by uniform(−e, +e) extra */
};

/* Where a sample's noise came from, returned with each sample. */
struct scene_noise_draw {
    double value_mm; /* ideal + noise (+ outlier/flag error), before quantisation */
    uint8_t status;  /* 0 or SCENE_STATUS_FLAGGED */
    bool outlier;    /* a gross outlier was added (status still 0) */
};

/*
 * Draws one noisy sample around ideal_mm. Always consumes exactly the same
 * number of random values, so changing a rate does not shift other draws.
 */
struct scene_noise_draw scene_noise_sample(const struct scene_sensor_noise *model,
                                           struct scene_rng *rng, double ideal_mm,
                                           double base_noise_mm);

/*
 * Rounds value_mm to the nearest integer millimetre as a VL53 part reports it.
 * Returns 0 and sets *out_mm, or -1 if the value is outside 0..65535 mm (it is
 * never clamped: a scenario that produces such a value is wrong).
 */
int scene_quantise_mm(double value_mm, uint16_t *out_mm);

/* Standard deviation of round(x + N(0, sigma²)) − x, by Sheppard's correction
 * sqrt(sigma² + 1/12): the true per-reading noise for sigma ≳ 0.5 mm. */
double scene_quantised_sigma(double sigma_mm);

#endif /* SCENE_NOISE_H */
