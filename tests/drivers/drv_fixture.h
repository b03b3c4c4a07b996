/*
 * Shared set-up for the driver tests and the bus benchmark: a simulated sensor head
 * (sim_rig: four VL53 models on one bus) with a deterministic range source, and the
 * driver / array configuration the product uses (short mode, 15 ms budget, 20 ms period
 * = 50 Hz, addresses 0x30..0x33, XSHUT on pins 0..3, GPIO1 on pins 4..7).
 */
#ifndef DRV_FIXTURE_H
#define DRV_FIXTURE_H

#include <stdbool.h>
#include <stdint.h>

#include "sim/sim_rig.h"
#include "vl53/vl53.h"
#include "vl53_array/vl53_array.h"

#define DRV_SENSORS       4u
#define DRV_FIRST_ADDRESS 0x30u

/* Range source: distance 100 + 10*sensor + (index % 97) mm, status `status`; every
 * `dropout_every`-th sample (if non-zero) is absent; ends after `limit` samples (if non-zero). */
struct drv_source {
    uint8_t status;
    uint32_t dropout_every;
    uint32_t limit;
    uint32_t calls;
};

struct drv_fixture {
    struct drv_source source;
    struct sim_rig_config rig_cfg;
    struct sim_rig rig;
    struct vl53_config sensor_cfg[DRV_SENSORS];
    struct vl53_array_config array_cfg;
    struct vl53_array array;
};

/* Expected distance of the source for (sensor, sample index). */
uint16_t drv_expected_distance(unsigned sensor, uint32_t index);

/* Fill defaults (rig config, source, sensor configs); call drv_fixture_build() after any tweak. */
void drv_fixture_defaults(struct drv_fixture *f);

/* (Re)build the rig and bind the sensor configs and the array to it. */
void drv_fixture_build(struct drv_fixture *f);

/* The defaults built (drv_fixture_defaults, then drv_fixture_build): a cmocka setup's
 * whole work; returns 0. */
int drv_fixture_default_rig(struct drv_fixture *f);

/* Simulated time now, µs. */
uint64_t drv_now(const struct drv_fixture *f);

/* Advance simulated time by `us` (as a delay would). */
void drv_sleep(struct drv_fixture *f, uint32_t us);

/* Did model `m` publish exactly this result (distance, status, stream count) as its newest or
 * previous one? (A measurement may complete between the driver's read and this check.) */
bool drv_result_matches(const struct sim_vl53 *m, const struct vl53_result *r);

/* Worst wire time (µs, rounded up, plus the bus-free gap) of the longest transfer the driver
 * makes in normal operation: the 91-byte default-configuration write. */
uint32_t drv_transfer_slack_us(const struct drv_fixture *f);

/* Could a consumer be misled by this OK result? Safe when its status is not "valid" (it is
 * dropped), or when it is valid and its distance is what the model published for that
 * stream count (or, if no published result has that count, for the newest measurement). */
bool drv_result_safe(const struct sim_vl53 *m, const struct vl53_result *r);

/*
 * A reference acquisition loop with a simple fault policy, standing in for the firmware's
 * fault manager in tests and the benchmark: every tick polls each ranging sensor; a stuck
 * bus gets a bus recovery; overdue data, or DRV_MANAGER_ERRORS_TO_RECOVER errors without
 * DRV_MANAGER_CLEAN_TO_FORGIVE clean results in between, or a hardware fault the sensor
 * reports (HAL_ERR_DEVICE), get a sensor recovery (XSHUT re-init, in two halves as the
 * firmware does it: vl53_array_recover_sensor_begin, then one _step per tick until the VHV
 * range is over); a sensor whose recovery failed is retried every DRV_MANAGER_RETRY_US.
 * Every call is timed in simulated time against its bound.
 */
#define DRV_MANAGER_ERRORS_TO_RECOVER 3u
#define DRV_MANAGER_CLEAN_TO_FORGIVE  10u
#define DRV_MANAGER_RETRY_US          10000u

enum drv_call { DRV_CALL_POLL, DRV_CALL_RECOVER_SENSOR, DRV_CALL_RECOVER_BUS, DRV_CALL_COUNT };

struct drv_manager {
    struct drv_fixture *f;
    uint32_t consecutive_errors[DRV_SENSORS]; /* errors since the last forgiving clean run */
    uint64_t retry_at_us[DRV_SENSORS];
    uint64_t last_error_us[DRV_SENSORS];    /* time of the sensor's last error (or recovery) */
    uint32_t ok_since_error[DRV_SENSORS];   /* valid results since then */
    uint64_t healthy_since_us[DRV_SENSORS]; /* time of the 2nd result after the last error */
    uint64_t results[DRV_SENSORS];
    uint64_t unsafe_results; /* OK results with a "valid" status but a distance the model did
                                not publish for that measurement (drv_result_safe) */
    uint64_t glitches;       /* OK results that are safe but not exact: a valid reading turned
                                invalid, or a flipped stream count on the right distance */
    uint64_t errors[13];     /* by -hal_err */
    uint32_t calls[DRV_CALL_COUNT];
    uint32_t max_us[DRV_CALL_COUNT];
    uint32_t over_budget[DRV_CALL_COUNT]; /* calls that took longer than their bound */
    uint32_t recoveries_ok;
    uint32_t recoveries_failed;
    /* Faults injected into the transactions of each call, by kind, split by how the call
     * ended: with an error (surfaced at once), or OK / NOT_READY (absorbed: harmless unless
     * the call delivered a wrong reading, which unsafe_results counts). */
    uint32_t faults_surfaced[SIM_FAULT_COUNT];
    uint32_t faults_absorbed[SIM_FAULT_COUNT];
};

void drv_manager_init(struct drv_manager *m, struct drv_fixture *f);

/* One loop tick (poll all, act on errors), then sleep `tick_us`. */
void drv_manager_tick(struct drv_manager *m, uint32_t tick_us);

/* Bound (µs) the manager checks a call of kind `call` against. */
uint32_t drv_manager_bound_us(const struct drv_manager *m, enum drv_call call);

/* Earliest time after which every sensor delivered 2 results with no error in between
 * (max over sensors of healthy_since_us), or UINT64_MAX if one never did since its last error. */
uint64_t drv_manager_all_healthy_since(const struct drv_manager *m);

#endif /* DRV_FIXTURE_H */
