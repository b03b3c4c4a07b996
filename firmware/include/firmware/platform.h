/*
 * What a board hands the application: its HAL implementations, its wiring of
 * the four sensors, and where the application's outputs go. The firmware is
 * linked unchanged into every target (MCU boards, QEMU, host_sim); only the
 * platform differs. A board leaves an interface's ops NULL when it has none.
 */
#ifndef FIRMWARE_PLATFORM_H
#define FIRMWARE_PLATFORM_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_gpio.h"
#include "hal/hal_i2c.h"
#include "hal/hal_log.h"
#include "hal/hal_temp.h"
#include "hal/hal_time.h"
#include "hal/hal_watchdog.h"

#define TOF_SENSORS 4u /* A, B, C, D */

struct tof_estimate_record; /* firmware/app.h */
struct tof_sample;          /* firmware/assembler.h */
struct tof_event;           /* firmware/app.h */

/* Where results go: telemetry frames on a board, CSV text under QEMU and in host_sim. */
struct tof_output_ops {
    /* One window's estimates, all estimators side by side. */
    void (*estimate)(void *ctx, const struct tof_estimate_record *record);
    /* Each assembled four-sensor sample, when raw output is enabled (may be NULL). */
    void (*sample)(void *ctx, const struct tof_sample *sample);
    /* Health transitions, recoveries and other events (may be NULL). */
    void (*event)(void *ctx, const struct tof_event *event);
};

struct tof_output {
    const struct tof_output_ops *ops;
    void *ctx;
};

struct tof_platform {
    const char *board_name; /* e.g. "nucleo-l476rg", "mps2-an386", "host_sim" */
    struct hal_i2c i2c;
    struct hal_gpio gpio;
    struct hal_time time;
    struct hal_log log;
    struct hal_watchdog watchdog;
    struct hal_temp temp; /* the temperature read with every sample (ops NULL: none) */
    struct tof_output output;
    uint16_t xshut_pin[TOF_SENSORS]; /* GPIO pin driving each sensor's XSHUT */
    uint16_t gpio1_pin[TOF_SENSORS]; /* GPIO pin reading each sensor's GPIO1, or 0xFFFF */
    bool sensor_pads_at_avdd; /* sensors' I²C / GPIO1 pulled up to AVDD (2V8..3V3), not 1V8 */
};

#endif /* FIRMWARE_PLATFORM_H */
