/*
 * Several VL53 sensors sharing one I²C bus, all at 0x29 after power-on: bring-up
 * one at a time through their XSHUT lines, detection of missing, stuck and
 * colliding sensors, and recovery of one sensor or of the bus without touching
 * the others. Health policy (when to recover) belongs to the caller (firmware's
 * fault manager); this layer provides the mechanisms and reports what it found.
 * Every call is bounded: its sensors' driver calls are, and it makes a fixed
 * number of them.
 */
#ifndef VL53_ARRAY_H
#define VL53_ARRAY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vl53/vl53.h"

#define VL53_ARRAY_MAX_SENSORS 4u
/* XSHUT is held low this long before a sensor is released (the datasheet gives no
 * minimum; long enough for the part's supply to settle in reset). */
#define VL53_ARRAY_XSHUT_LOW_US 500u

enum vl53_sensor_state {
    VL53_SENSOR_OFF,         /* held in reset (XSHUT low): never started, or parked after a fault */
    VL53_SENSOR_CONFIGURING, /* at its own address, its VHV range running (bring-up only) */
    VL53_SENSOR_RANGING,     /* at its own address, configured, ranging */
};

/* Why a sensor is not ranging (the last bring-up or recovery of it). */
enum vl53_array_fault {
    VL53_ARRAY_OK = 0,
    VL53_ARRAY_MISSING,          /* nothing answered at 0x29 after its XSHUT was released */
    VL53_ARRAY_BOOT_TIMEOUT,     /* answered, but never reported booted */
    VL53_ARRAY_WRONG_ID,         /* model ID is not 0xEACC */
    VL53_ARRAY_STUCK_AT_DEFAULT, /* still answers at 0x29 after being moved (address change ignored)
                                  */
    VL53_ARRAY_ADDRESS_CONFLICT, /* something answers at 0x29 or at its own address while it
                                    is held in reset: two devices would answer at one address */
    VL53_ARRAY_BUS_ERROR,        /* a bus error (stuck, timeout, NACK burst) got in the way */
    VL53_ARRAY_CONFIG_FAILED,    /* configuration or start failed (error in report.err) */
    VL53_ARRAY_IDENTITY_FAILED,  /* its NVM identity could not be read (vl53_read_part_id) */
};

struct vl53_sensor_report {
    enum vl53_sensor_state state;
    enum vl53_array_fault fault;
    int err;                  /* the hal_err behind the fault, unchanged (HAL_OK if none) */
    uint8_t conflict_address; /* for VL53_ARRAY_ADDRESS_CONFLICT / STUCK_AT_DEFAULT */
    uint16_t model_id;        /* what the sensor reported, for VL53_ARRAY_WRONG_ID */
};

struct vl53_array_config {
    const struct vl53_config *sensors; /* `count` configs: distinct addresses (not 0x29) and
                                          XSHUT pins, all on one bus */
    size_t count;                      /* 1..VL53_ARRAY_MAX_SENSORS */
};

struct vl53_array {
    const struct vl53_array_config *cfg;
    struct vl53_dev dev[VL53_ARRAY_MAX_SENSORS];
    struct vl53_sensor_report report[VL53_ARRAY_MAX_SENSORS];
};

/* Bind and validate (distinct addresses other than 0x29, XSHUT wired and distinct, each
 * sensor config valid). No bus access. HAL_ERR_INVALID on a bad configuration. */
int vl53_array_attach(struct vl53_array *array, const struct vl53_array_config *cfg);

/*
 * Hold every XSHUT low, check that nothing answers at 0x29 or at any sensor's address,
 * then for each sensor in turn: release it, wait for boot, verify the model ID, move it to
 * its address (checking 0x29 is free again), read its NVM identity
 * (vl53_read_part_id, vl53_part_id() then gives it), write ST's configuration and start its VHV
 * range (vl53_configure_begin), and check the sensors already up still answer at theirs
 * (see vl53_array_recover_sensor); then for each: finish its VHV step, write its timing
 * and start it. The four ~100 ms VHV ranges so overlap. A sensor that fails is parked in
 * reset with its report filled, and the others still come up. HAL_OK when all are
 * ranging, else the first failure's error (reports say which sensor and why).
 */
int vl53_array_bring_up(struct vl53_array *array);

/*
 * Bring sensor `index` back (after a reset, a lost sensor, a stuck data-ready): XSHUT low,
 * check 0x29 and its address are free, release, boot, identify, re-address, read the NVM
 * identity, configure,
 * start, then check every other ranging sensor still answers at its own address (one that
 * reset meanwhile may have followed this one to its address: VL53_ARRAY_ADDRESS_CONFLICT).
 * Only this sensor's XSHUT moves, and the others see nothing but model-ID reads, so they
 * keep ranging undisturbed. HAL_OK or the failure's error (report updated).
 */
int vl53_array_recover_sensor(struct vl53_array *array, size_t index);

/*
 * The same in two halves, so a caller need not block for the ~100 ms VHV range: _begin
 * does everything up to the VHV range's start (sensor CONFIGURING; ~5 ms); _step then takes
 * one look (no waiting): HAL_ERR_NOT_READY while the range runs, HAL_OK once it finished
 * the bring-up (RANGING), or the failure's error (sensor parked, report updated: TIMEOUT
 * once configure_budget_us has passed). HAL_ERR_STATE from _step if not CONFIGURING.
 * Each call within call_budget_us (plus vl53_configure_finish's for the last step).
 */
int vl53_array_recover_sensor_begin(struct vl53_array *array, size_t index);
int vl53_array_recover_sensor_step(struct vl53_array *array, size_t index);

/* Bus recovery (nine clocks and a STOP on a stuck SDA) through the bus's hal_i2c recover.
 * HAL_OK if SDA is released; HAL_ERR_INVALID if the bus has no recover hook. */
int vl53_array_recover_bus(struct vl53_array *array);

/*
 * Worst-case duration of vl53_array_recover_sensor(array, index) and of
 * vl53_array_bring_up(array) from the configured budgets, excluding the wire time of the
 * last transfer of each step (at most VL53_ARRAY_STEPS_PER_SENSOR per sensor, plus one bus
 * recovery and 1 + count probes for bring-up). Lets a scheduler know how long it blocks.
 */
#define VL53_ARRAY_STEPS_PER_SENSOR (11u + VL53_ARRAY_MAX_SENSORS - 1u)
uint32_t vl53_array_recover_budget_us(const struct vl53_array *array, size_t index);
uint32_t vl53_array_bring_up_budget_us(const struct vl53_array *array);

/* vl53_poll() of sensor `index` (HAL_ERR_STATE if it is not ranging). */
int vl53_array_poll(struct vl53_array *array, size_t index, struct vl53_result *result);

/* Sensor `index`'s driver state (NULL if out of range), for direct driver calls. */
struct vl53_dev *vl53_array_sensor(struct vl53_array *array, size_t index);

/* Sensor `index`'s report (NULL if out of range). */
const struct vl53_sensor_report *vl53_array_report(const struct vl53_array *array, size_t index);

/* Number of sensors ranging. */
size_t vl53_array_ranging_count(const struct vl53_array *array);

/* Short name of a fault ("missing", "stuck_at_default", ...), never NULL. */
const char *vl53_array_fault_name(enum vl53_array_fault fault);

#endif /* VL53_ARRAY_H */
