/*
 * The product's sensor head in simulation: one clock, one I²C bus, one GPIO
 * controller and four VL53 models (A..D) wired XSHUT to pins 0..3 and GPIO1 to
 * pins 4..7, plus the hal handles a struct tof_platform needs. A convenience over
 * the parts; tests and host_sim may also assemble their own. No heap: the caller
 * owns the struct sim_rig. Re-running sim_rig_init() resets everything.
 */
#ifndef SIM_RIG_H
#define SIM_RIG_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_gpio.h"
#include "hal/hal_i2c.h"
#include "hal/hal_time.h"
#include "sim/range_source.h"
#include "sim/sim_clock.h"
#include "sim/sim_fault.h"
#include "sim/sim_gpio.h"
#include "sim/sim_i2c.h"
#include "sim/sim_vl53.h"

#define SIM_RIG_SENSORS           4u
#define SIM_RIG_XSHUT_PIN(sensor) ((uint16_t)(sensor))
#define SIM_RIG_GPIO1_PIN(sensor) ((uint16_t)(4u + (sensor)))

struct sim_rig_config {
    uint32_t bus_hz;                                /* 0: 400 kHz */
    uint64_t start_us;                              /* initial simulated time */
    struct sim_vl53_config sensor[SIM_RIG_SENSORS]; /* .sensor is set to the index */
    bool absent[SIM_RIG_SENSORS];                   /* not fitted: nothing on the bus */
    struct sim_range_source source;                 /* ops NULL: constant 100 mm */
    struct sim_fault_config faults;                 /* all-zero: no faults */
};

struct sim_rig {
    struct sim_clock clock;
    struct sim_i2c_bus bus;
    struct sim_gpio gpio;
    struct sim_vl53 sensor[SIM_RIG_SENSORS];
    struct hal_i2c i2c;
    struct hal_gpio hal_gpio;
    struct hal_time time;
};

/* Defaults: 400 kHz, every sensor fitted with XSHUT wired and pulled up at start (so all
 * four boot at 0x29 before the MCU drives the pins, as on a real board), no faults. */
void sim_rig_default_config(struct sim_rig_config *cfg);

/* Build (or rebuild) the rig from `cfg`. */
void sim_rig_init(struct sim_rig *rig, const struct sim_rig_config *cfg);

#endif /* SIM_RIG_H */
