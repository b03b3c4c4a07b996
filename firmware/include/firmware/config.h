/*
 * The firmware's configuration: one const struct, checked at compile time where
 * its values are constants (tof_app_default_config) and at init otherwise.
 */
#ifndef FIRMWARE_CONFIG_H
#define FIRMWARE_CONFIG_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/attitude.h"
#include "firmware/health.h"
#include "vl53/vl53.h"

struct tof_app_config {
    uint8_t address[4];        /* 7-bit addresses the sensors are moved to (A..D) */
    struct vl53_timing timing; /* every sensor: distance mode, budget, period */
    uint32_t max_skew_us;      /* readings of one sample may lag its slot end this much */
    uint32_t loop_budget_us;   /* a main-loop iteration longer than this is an overrun */
    uint32_t idle_us;          /* longest sleep of an idle iteration (data-ready latency) */
    struct tof_health_config health;
    struct attitude_config estimator; /* window, mode, estimators, tolerances, Kalman */
    bool raw_output;                  /* send every assembled sample to the output too */
    /* The head this image runs on, as the user numbered it (HEAD.cal `head_id`): a saved
     * calibration applies only when made on the same head (firmware/calibration_record.h);
     * 0, the default, is a head without a number. */
    uint32_t head_id;
    /* The time the unit may have been off before a boot, added to its calibration's stored age
     * at every boot until the next calibration (firmware/cal_age.h): the unit has no clock
     * that runs while it is off. A mission sets the longest it expects. */
    uint32_t cal_off_allowance_s;
    /* The sensors' bus clock, kHz: 400 (Fast-mode) or 100 (Standard-mode, a long harness): the
     * board's build option TOF_I2C_KHZ. A period whose four readings need more than half of
     * it on the wire is refused (tof_app_bus_fits()). */
    uint16_t i2c_khz;
};

/* Wire bits of one four-sensor sample, the most any data-ready method takes: data ready read
 * from the status register, the result block and the distance re-read, 17.4 transactions on
 * average (tests/drivers/bench_bus.c, drv_bench_bus: 1,406 bits at 4 x 50 Hz). */
#define TOF_SAMPLE_BUS_BITS 1406u

/* The wire time of one sample's readings at `i2c_khz`, µs, rounded up (0 kHz: UINT32_MAX). */
uint32_t tof_app_sample_bus_us(uint16_t i2c_khz);

/* The readings of one sample are read one after the other: the last lands this long after the
 * first, so a sample's skew window (max_skew_us) covers it with TOF_SKEW_SLACK_US to spare. */
#define TOF_SKEW_SLACK_US 1000u

/* True when a sample's readings fit `period_ms` at `i2c_khz`: their wire time plus
 * TOF_SKEW_SLACK_US (the skew window they need, which must stay under half the period) is
 * under half of it, the other half left to the estimator's window end and the link. At
 * 400 kHz 3.5 ms (every VL53L1X period fits), at 100 kHz 14.1 ms (31 ms and longer). */
bool tof_app_bus_fits(uint32_t period_ms, uint16_t i2c_khz);

/* One day: a unit off longer than that before its use is re-zeroed first, or its mission sets
 * a longer allowance (firmware/cal_age.h). */
#define TOF_CAL_OFF_ALLOWANCE_S_DEFAULT 86400u

/* The product's default configuration (firmware/src/config.c). */
extern const struct tof_app_config tof_app_default_config;

/* NULL if `cfg` is usable, else the name of the first bad field (the estimator's
 * fields are checked by attitude_init(), which names them itself). */
const char *tof_app_config_check(const struct tof_app_config *cfg);

/*
 * The configuration for replaying a recording made at `period_ms` with arm `arm_um` by
 * parts in distance mode `mode`: the default with the timing (the longest budget of that
 * mode that leaves the inter-measurement margin), skew, idle time and health timeouts
 * scaled to the period, the window and mode given, and raw samples on. host_sim and the
 * QEMU replay image both use it, so they run the same firmware configuration.
 * HAL_OK, or HAL_ERR_INVALID when no VL53L1X timing of that mode fits the period or a
 * value is out of range (tof_app_config_check() names it).
 */
int tof_app_config_for_replay(struct tof_app_config *cfg, int32_t arm_um, uint32_t period_ms,
                              uint16_t window, bool sliding, enum vl53_distance_mode mode);

/*
 * `cfg` at sample period `period_ms` (its distance mode kept): the timing (the longest VL53L1X
 * budget of the mode that leaves the inter-measurement margin), the skew (a quarter of the
 * period, at least a sample's wire time at cfg->i2c_khz plus TOF_SKEW_SLACK_US), idle time and
 * health timeouts scaled to the period, and the estimator's clock (period_us). The one rule
 * of tof_app_config_for_replay() and of the set-period command (tof_app_set_period()).
 * HAL_OK, or HAL_ERR_INVALID with `cfg` unchanged when no timing of the mode fits or the bus
 * at cfg->i2c_khz cannot carry the period (tof_app_bus_fits()).
 */
int tof_app_config_period(struct tof_app_config *cfg, uint32_t period_ms);

/* True when a part in distance mode `mode` has a timing budget that fits `period_ms`
 * (long mode's shortest is 20 ms, short mode's 15 ms, each plus the 4 ms margin). */
bool tof_app_replay_mode_fits(uint32_t period_ms, enum vl53_distance_mode mode);

/*
 * The Kalman filter's process noise as random-walk intensities (docs/reference/tools.md,
 * --process-noise): qd of x̄ and qt of a·tan α and a·tan β, µm²/s, turned into Q per row
 * (q · period, the period of cfg->timing, rounded to whole µm²); `automatic`: the filter
 * learns Q (starting there) and R itself. HAL_ERR_INVALID when a non-zero intensity
 * rounds to 0 per row or a Q per row exceeds 2^32 µm².
 */
int tof_app_config_process_noise(struct tof_app_config *cfg, uint32_t qd_um2_per_s,
                                 uint32_t qt_um2_per_s, bool automatic);

/*
 * The process noise a window mode implies when none is chosen: a sliding estimate
 * is for a plate that may move, so with the Kalman filter's Q all 0 sliding mode takes
 * `auto` and tumbling mode the paper's static windows (auto off); a fixed Q > 0 is kept in
 * both. Applied whenever the mode is set (tof_app_config_for_replay, tof_app_set_window); a
 * process noise set after it (host_sim --process-noise, the process-noise command, a saved
 * record's) wins, so Q = 0 in sliding mode is `--process-noise 0,0`.
 */
void tof_estimator_mode_process_noise(struct attitude_config *est);

/*
 * The same conversion into an estimator configuration `est` at sample period `period_us`
 * (the run-time command's path, tof_app_set_process_noise()): ATTITUDE_ERR_NONE, or
 * ATTITUDE_ERR_KALMAN_PROCESS_NOISE with `est` unchanged when a non-zero intensity rounds
 * to 0 per row or a Q per row exceeds 2^32 µm². Whether the image can run that Q is
 * attitude_init()'s to say.
 */
int tof_estimator_process_noise(struct attitude_config *est, uint32_t period_us,
                                uint32_t qd_um2_per_s, uint32_t qt_um2_per_s, bool automatic);

/*
 * The estimator configuration `est` at a new row period `period_us`: the Kalman filter's Q per
 * row rescaled so its intensity (Q / period) is kept, rounded to whole µm², and period_us set.
 * ATTITUDE_ERR_NONE, or ATTITUDE_ERR_KALMAN_PROCESS_NOISE with `est` unchanged when a
 * non-zero Q would round to 0 or overflow.
 */
int tof_estimator_period(struct attitude_config *est, uint32_t period_us);

#endif /* FIRMWARE_CONFIG_H */
