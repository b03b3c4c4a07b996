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

/* Simulated time now, µs. */
uint64_t drv_now(const struct drv_fixture *f);

/* Advance simulated time by `us` (as a delay would). */
void drv_sleep(struct drv_fixture *f, uint32_t us);

/* Worst wire time (µs, rounded up, plus the bus-free gap) of the longest transfer the driver
 * makes in normal operation: the 30-byte configuration read-back. */
uint32_t drv_transfer_slack_us(const struct drv_fixture *f);

#endif /* DRV_FIXTURE_H */
