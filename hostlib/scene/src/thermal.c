/* The simulated head's thermal world: orbital temperature cycle, offsets following it (thermal.h).
 */
#include "scene/thermal.h"

#include <math.h>
#include <stddef.h>

#include "scene/geometry.h"

/* RNG streams of one seed, apart from the scenarios' (scenario.c) and the fixture's. */
enum { STREAM_THERMAL_HEAD = 40, STREAM_THERMAL_WALK = 41, STREAM_THERMAL_TEMP = 42 };

void scene_thermal_defaults(struct scene_thermal *t) {
    t->on = true;
    t->mean_c = SCENE_THERMAL_MEAN_C;
    t->amplitude_c = SCENE_THERMAL_AMPLITUDE_C;
    t->period_s = SCENE_THERMAL_PERIOD_S;
    t->phase_deg = 0.0;
    t->cal_temp_c = SCENE_THERMAL_MEAN_C;
    t->coeff_range_mm_per_c = SCENE_THERMAL_COEFF_RANGE_MM_PER_C;
    t->coeff_sd_mm_per_c = SCENE_THERMAL_COEFF_SD_MM_PER_C;
    /* VL53L1X datasheet: up to ±20 mm before offset calibration (as the fixture draws them) */
    t->offset_range_mm = 20.0;
    t->walk_um2_h = SCENE_THERMAL_WALK_UM2_H;
    t->temp_noise_c = SCENE_THERMAL_TEMP_NOISE_C;
    t->temp_quantum_c = SCENE_THERMAL_TEMP_QUANTUM_C;
}

static bool finite_in(double v, double lo, double hi) {
    return isfinite(v) && v >= lo && v <= hi;
}

const char *scene_thermal_check(const struct scene_thermal *t) {
    if (!finite_in(t->mean_c, -40.0, 85.0) || !finite_in(t->amplitude_c, 0.0, 60.0) ||
        !finite_in(t->mean_c - t->amplitude_c, -100.0, 200.0) ||
        !finite_in(t->mean_c + t->amplitude_c, -100.0, 200.0)) {
        return "temperature mean within -40..85 C, amplitude within 0..60 C, the cycle within "
               "-100..200 C";
    }
    if (!(t->period_s > 0.0) || !isfinite(t->period_s) || !finite_in(t->phase_deg, -360.0, 360.0)) {
        return "cycle period must be positive, phase within -360..360 degrees";
    }
    if (!finite_in(t->cal_temp_c, -100.0, 200.0)) {
        return "calibration temperature within -100..200 C";
    }
    /* stated coefficient and sd must stay within the estimator's bound (4 sd of headroom) */
    if (!finite_in(t->coeff_range_mm_per_c, 0.0, SCENE_THERMAL_COEFF_MAX_MM_PER_C / 2.0) ||
        !finite_in(t->coeff_sd_mm_per_c, 0.0, SCENE_THERMAL_COEFF_MAX_MM_PER_C / 8.0)) {
        return "coefficient range within 0..0.5 mm/C, its stated sd within 0..0.125 mm/C";
    }
    if (!finite_in(t->offset_range_mm, 0.0, 50.0) || !finite_in(t->walk_um2_h, 0.0, 1e9)) {
        return "offset range within 0..50 mm, walk within 0..1e9 um^2/h";
    }
    if (!finite_in(t->temp_noise_c, 0.0, 10.0) || !finite_in(t->temp_quantum_c, 0.01, 5.0)) {
        return "temperature noise within 0..10 C, quantum within 0.01..5 C";
    }
    return NULL;
}

void scene_thermal_draw(struct scene_thermal_head *h, const struct scene_thermal *t,
                        uint64_t seed) {
    struct scene_rng rng;
    scene_rng_seed(&rng, seed, STREAM_THERMAL_HEAD);
    for (unsigned k = 0; k < SCENE_THERMAL_SENSORS; ++k) {
        /* to 1 µm, the offset key's resolution: the trace states it exactly */
        h->offset_mm[k] =
            round(scene_rng_range(&rng, -t->offset_range_mm, t->offset_range_mm) * 1e3) / 1e3;
        h->coeff_mm_per_c[k] =
            scene_rng_range(&rng, -t->coeff_range_mm_per_c, t->coeff_range_mm_per_c);
        /* Stated to 1e-6 mm/°C, the key's resolution, so the trace reads back the same. */
        const double stated = h->coeff_mm_per_c[k] + t->coeff_sd_mm_per_c * scene_rng_normal(&rng);
        h->stated_mm_per_c[k] = round(stated * 1e6) / 1e6;
        h->walk_mm[k] = 0.0;
    }
    scene_rng_seed(&h->walk_rng, seed, STREAM_THERMAL_WALK);
    scene_rng_seed(&h->temp_rng, seed, STREAM_THERMAL_TEMP);
}

double scene_thermal_temp_c(const struct scene_thermal *t, double t_s) {
    return t->mean_c + t->amplitude_c * sin(2.0 * SCENE_PI * t_s / t->period_s +
                                            t->phase_deg * SCENE_PI / 180.0);
}

void scene_thermal_row(struct scene_thermal_head *h, const struct scene_thermal *t, double t_s,
                       double dt_s, double offset_mm[SCENE_THERMAL_SENSORS], double *measured_c,
                       double *true_c) {
    const double temp = scene_thermal_temp_c(t, t_s);
    /* µm²/h → mm² over dt: a Gaussian step of that variance per row */
    const double step_sd = sqrt(t->walk_um2_h * 1e-6 * dt_s / 3600.0);
    for (unsigned k = 0; k < SCENE_THERMAL_SENSORS; ++k) {
        const double z = scene_rng_normal(&h->walk_rng); /* drawn every row: fixed consumption */
        h->walk_mm[k] += step_sd * z;
        offset_mm[k] =
            h->offset_mm[k] + h->coeff_mm_per_c[k] * (temp - t->cal_temp_c) + h->walk_mm[k];
    }
    const double noisy = temp + t->temp_noise_c * scene_rng_normal(&h->temp_rng);
    const double q = t->temp_quantum_c;
    /* to the quantum, then to the 0.01 °C the trace writes */
    *measured_c = round(round(noisy / q) * q * 100.0) / 100.0;
    if (true_c != NULL) {
        *true_c = temp;
    }
}
