/* Per-sensor noise models (docs/reference/trace-format.md, "Noise models"). */
#include "scene/noise.h"

#include <math.h>

struct scene_noise_draw scene_noise_sample(const struct scene_sensor_noise *model,
                                           struct scene_rng *rng, double ideal_mm,
                                           double base_noise_mm) {
    /* Fixed consumption: one normal and five uniforms whatever the rates. */
    const double jitter = scene_rng_normal(rng);
    const double u_outlier = scene_rng_uniform(rng);
    const double u_magnitude = scene_rng_uniform(rng);
    const double u_sign = scene_rng_uniform(rng);
    const double u_flag = scene_rng_uniform(rng);
    const double u_flag_error = scene_rng_uniform(rng);

    struct scene_noise_draw d = {0};
    d.value_mm = ideal_mm + base_noise_mm + model->sigma_mm * jitter;
    if (u_outlier < model->outlier_rate) {
        const double mag =
            model->outlier_min_mm + (model->outlier_max_mm - model->outlier_min_mm) * u_magnitude;
        d.value_mm += (u_sign < 0.5) ? -mag : mag;
        d.outlier = true;
    }
    if (u_flag < model->flag_rate) {
        d.value_mm += model->flag_error_mm * (2.0 * u_flag_error - 1.0);
        d.status = SCENE_STATUS_FLAGGED;
    }
    return d;
}

int scene_quantise_mm(double value_mm, uint16_t *out_mm) {
    /* Round half up; VL53 parts report whole millimetres. */
    const double r = floor(value_mm + 0.5);
    if (!(r >= 0.0 && r <= 65535.0)) { /* also rejects NaN */
        return -1;
    }
    *out_mm = (uint16_t)r;
    return 0;
}

double scene_quantised_sigma(double sigma_mm) {
    return sqrt(sigma_mm * sigma_mm + 1.0 / 12.0);
}
