/* The firmware's configuration: defaults and the checks made at init (firmware/config.h). */
#include "firmware/config.h"

#include <stddef.h>

#include "hal/hal_err.h"

/* The board's bus clock (the build option TOF_I2C_KHZ, cmake/TofOptions.cmake). */
#ifndef TOF_I2C_KHZ
#define TOF_I2C_KHZ 400
#endif
#if TOF_I2C_KHZ != 100 && TOF_I2C_KHZ != 400
#error "TOF_I2C_KHZ: 100 or 400"
#endif

/* Defaults, checked at compile time below. */
#if TOF_I2C_KHZ == 400
#define TOF_PERIOD_MS 20u /* 50 Hz per sensor, the paper's experiment rate */
#define TOF_BUDGET_MS 15u /* VL53L1X short mode: the longest budget that fits the period */
#else
/* 25 Hz: a 100 kHz bus carries four readings in 14.1 ms, more than half of 20 ms
 * (tof_app_bus_fits()); 40 ms leaves 65 % of the period free. */
#define TOF_PERIOD_MS 40u
#define TOF_BUDGET_MS 33u /* the longest budget that fits 40 ms with the 4 ms margin */
#endif
#if TOF_I2C_KHZ == 400
#define TOF_MAX_SKEW_US 5000u
#else
#define TOF_MAX_SKEW_US 16000u /* four readings one after the other: 14.1 ms at 100 kHz */
#endif
#define TOF_IDLE_US        1000u  /* data-ready latency bound when idle */
#define TOF_LOOP_BUDGET_US 40000u /* >= one sensor re-init (boot 1.2 ms + config) + 4 polls */

_Static_assert(TOF_PERIOD_MS >= TOF_BUDGET_MS + VL53_IMP_MARGIN_MS,
               "inter-measurement period must exceed the timing budget by the margin");
_Static_assert(TOF_MAX_SKEW_US < TOF_PERIOD_MS * 1000u / 2u,
               "skew must stay below half a period so slots cannot be confused");
_Static_assert(TOF_IDLE_US < TOF_MAX_SKEW_US, "idle sleep must be shorter than the skew window");
_Static_assert(TOF_MAX_SKEW_US >= (TOF_SAMPLE_BUS_BITS * 1000u + TOF_I2C_KHZ - 1u) / TOF_I2C_KHZ +
                                      TOF_SKEW_SLACK_US,
               "the skew window covers a sample's readings one after the other on the bus");

/* The estimator's defaults with its clock at this image's period (the walk since calibration
 * counts rows x period): ATTITUDE_CONFIG_DEFAULT reads the period's macro where it expands. */
#undef ATTITUDE_PERIOD_US_DEFAULT
#define ATTITUDE_PERIOD_US_DEFAULT (TOF_PERIOD_MS * 1000u)

const struct tof_app_config tof_app_default_config = {
    /* 0x29 is the power-on default (VL53L1X datasheet DS12385 §2.5.2); 0x30.. are free
     * 7-bit addresses chosen for the four sensors. */
    .address = {0x30, 0x31, 0x32, 0x33},
    .timing = {.mode = VL53_DISTANCE_SHORT,
               .budget_ms = TOF_BUDGET_MS,
               .inter_measurement_ms = TOF_PERIOD_MS},
    .max_skew_us = TOF_MAX_SKEW_US,
    .loop_budget_us = TOF_LOOP_BUDGET_US,
    .idle_us = TOF_IDLE_US,
    .health = {.errors_to_lost = 3,
               .good_to_healthy = 2,
               .silence_to_lost_ms = 3u * TOF_PERIOD_MS,
               .reinit_backoff_ms = 50,
               .recovery_timeout_ms = 5u * TOF_PERIOD_MS,
               .suspect_timeout_ms = 10u * TOF_PERIOD_MS,
               .trouble_errors = 5},
    .estimator = ATTITUDE_CONFIG_DEFAULT, /* the estimator's own defaults (attitude.h) */
    .raw_output = false,
    .cal_off_allowance_s = TOF_CAL_OFF_ALLOWANCE_S_DEFAULT,
    .i2c_khz = TOF_I2C_KHZ,
};

uint32_t tof_app_sample_bus_us(uint16_t i2c_khz) {
    return i2c_khz == 0u ? UINT32_MAX : (TOF_SAMPLE_BUS_BITS * 1000u + i2c_khz - 1u) / i2c_khz;
}

bool tof_app_bus_fits(uint32_t period_ms, uint16_t i2c_khz) {
    const uint64_t skew_us = (uint64_t)tof_app_sample_bus_us(i2c_khz) + TOF_SKEW_SLACK_US;
    return 2u * skew_us < (uint64_t)period_ms * 1000u;
}

const char *tof_app_config_check(const struct tof_app_config *cfg) {
    if (vl53_timing_check(&cfg->timing) != HAL_OK) {
        return "timing";
    }
    for (unsigned i = 0; i < 4u; ++i) {
        if (cfg->address[i] < 0x08u || cfg->address[i] > 0x77u || cfg->address[i] == 0x29u) {
            return "address";
        }
        for (unsigned j = 0; j < i; ++j) {
            if (cfg->address[i] == cfg->address[j]) {
                return "address";
            }
        }
    }
    const uint32_t period_us = vl53_period_us(&cfg->timing);
    if (cfg->max_skew_us == 0u || cfg->max_skew_us >= period_us / 2u) {
        return "max_skew_us";
    }
    if (cfg->idle_us == 0u || cfg->idle_us >= cfg->max_skew_us) {
        return "idle_us";
    }
    if (cfg->loop_budget_us == 0u) {
        return "loop_budget_us";
    }
    if (!tof_health_config_valid(&cfg->health)) {
        return "health";
    }
    if (cfg->i2c_khz != 100u && cfg->i2c_khz != 400u) {
        return "i2c_khz";
    }
    if (!tof_app_bus_fits(cfg->timing.inter_measurement_ms, cfg->i2c_khz)) {
        return "timing (the bus at i2c_khz cannot carry the period)";
    }
    /* The estimator's own fields are checked by attitude_init() at tof_app_init(). */
    return NULL;
}

/* The longest VL53L1X budget of `mode` that leaves the inter-measurement margin at
 * `period_ms`; false when none does. */
static bool replay_timing(uint32_t period_ms, enum vl53_distance_mode mode,
                          struct vl53_timing *out) {
    static const uint16_t budgets[] = {500, 200, 100, 50, 33, 20, 15};
    for (size_t i = 0; i < sizeof budgets / sizeof budgets[0]; ++i) {
        const struct vl53_timing t = {
            .mode = mode, .budget_ms = budgets[i], .inter_measurement_ms = period_ms};
        if (vl53_timing_check(&t) == HAL_OK) {
            *out = t;
            return true;
        }
    }
    return false;
}

bool tof_app_replay_mode_fits(uint32_t period_ms, enum vl53_distance_mode mode) {
    struct vl53_timing t;
    return replay_timing(period_ms, mode, &t);
}

int tof_app_config_period(struct tof_app_config *cfg, uint32_t period_ms) {
    struct vl53_timing timing;
    if (period_ms == 0u || !replay_timing(period_ms, cfg->timing.mode, &timing) ||
        !tof_app_bus_fits(period_ms, cfg->i2c_khz)) {
        return HAL_ERR_INVALID;
    }
    const uint32_t period_us = period_ms * 1000u;
    cfg->timing = timing;
    const uint32_t bus_skew_us = tof_app_sample_bus_us(cfg->i2c_khz) + TOF_SKEW_SLACK_US;
    cfg->max_skew_us = period_us / 4u > bus_skew_us ? period_us / 4u : bus_skew_us;
    cfg->idle_us = period_us / 20u < TOF_IDLE_US ? period_us / 20u : TOF_IDLE_US;
    cfg->health.silence_to_lost_ms = 3u * period_ms;
    cfg->health.recovery_timeout_ms = 5u * period_ms;
    cfg->health.suspect_timeout_ms = 10u * period_ms;
    cfg->estimator.period_us = period_us; /* the drift allowance's clock */
    return HAL_OK;
}

int tof_app_config_for_replay(struct tof_app_config *cfg, int32_t arm_um, uint32_t period_ms,
                              uint16_t window, bool sliding, enum vl53_distance_mode mode) {
    *cfg = tof_app_default_config;
    cfg->timing.mode = mode;
    if (tof_app_config_period(cfg, period_ms) != HAL_OK) {
        return HAL_ERR_INVALID;
    }
    cfg->estimator.arm_um = arm_um;
    cfg->estimator.window = window;
    cfg->estimator.mode = sliding ? ATTITUDE_SLIDING : ATTITUDE_TUMBLING;
    tof_estimator_mode_process_noise(&cfg->estimator);
    cfg->raw_output = true;
    return tof_app_config_check(cfg) == NULL ? HAL_OK : HAL_ERR_INVALID;
}

void tof_estimator_mode_process_noise(struct attitude_config *est) {
    const uint32_t *q = est->kalman_process_noise_um2;
    if (q[0] == 0u && q[1] == 0u && q[2] == 0u) {
        est->kalman_process_noise_auto = est->mode == ATTITUDE_SLIDING;
    }
}

/* Q per row `q[i] * num / den`, rounded, into est (all three or none): ATTITUDE_ERR_NONE, or
 * ATTITUDE_ERR_KALMAN_PROCESS_NOISE when a non-zero Q would round to 0 or overflow. */
static int scale_process_noise(struct attitude_config *est, const uint32_t q[3], uint32_t num,
                               uint32_t den) {
    uint32_t per_row[3];
    for (unsigned i = 0; i < 3u; ++i) {
        const uint64_t row = ((uint64_t)q[i] * num + den / 2u) / den;
        if (row > UINT32_MAX || (q[i] != 0u && row == 0u)) {
            return ATTITUDE_ERR_KALMAN_PROCESS_NOISE; /* never a silent Q = 0 */
        }
        per_row[i] = (uint32_t)row;
    }
    for (unsigned i = 0; i < 3u; ++i) {
        est->kalman_process_noise_um2[i] = per_row[i];
    }
    return ATTITUDE_ERR_NONE;
}

int tof_estimator_process_noise(struct attitude_config *est, uint32_t period_us,
                                uint32_t qd_um2_per_s, uint32_t qt_um2_per_s, bool automatic) {
    const uint32_t q[3] = {qd_um2_per_s, qt_um2_per_s, qt_um2_per_s};
    const int rc = scale_process_noise(est, q, period_us, 1000000u); /* µm²/s × s */
    if (rc == ATTITUDE_ERR_NONE) {
        est->kalman_process_noise_auto = automatic;
    }
    return rc;
}

int tof_app_config_process_noise(struct tof_app_config *cfg, uint32_t qd_um2_per_s,
                                 uint32_t qt_um2_per_s, bool automatic) {
    const int rc = tof_estimator_process_noise(&cfg->estimator, vl53_period_us(&cfg->timing),
                                               qd_um2_per_s, qt_um2_per_s, automatic);
    return rc == ATTITUDE_ERR_NONE ? HAL_OK : HAL_ERR_INVALID;
}

int tof_estimator_period(struct attitude_config *est, uint32_t period_us) {
    /* the same intensity (Q per row / old period) at the new period */
    const uint32_t q[3] = {est->kalman_process_noise_um2[0], est->kalman_process_noise_um2[1],
                           est->kalman_process_noise_um2[2]};
    const uint32_t old_us = est->period_us != 0u ? est->period_us : 1u; /* init checks it */
    const int rc = scale_process_noise(est, q, period_us, old_us);
    if (rc == ATTITUDE_ERR_NONE) {
        est->period_us = period_us;
    }
    return rc;
}
