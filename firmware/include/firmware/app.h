/*
 * The application: sensor-array bring-up, non-blocking acquisition, the fault
 * manager and the estimation pipeline, one main-loop iteration at a time.
 *
 *   board init -> tof_app_init() (bring-up, configuration) -> loop { tof_app_step() }
 *
 * Every iteration is bounded: each sensor is polled once (a driver call with
 * its own time budget), at most one sensor is re-initialised, and the
 * assembler and estimator do bounded work. The watchdog is kicked only when
 * an iteration finished within cfg->loop_budget_us.
 */
#ifndef FIRMWARE_APP_H
#define FIRMWARE_APP_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/assembler.h"
#include "firmware/config.h"
#include "firmware/health.h"
#include "firmware/platform.h"
#include "vl53_array/vl53_array.h"

/* Firmware identity, printed at boot and in status telemetry. */
#define TOF_FW_NAME    "tof-attitude"
#define TOF_FW_VERSION "0.1.0"

enum tof_event_kind {
    TOF_EVENT_HEALTH = 0,       /* a sensor changed health state */
    TOF_EVENT_REINIT = 1,       /* a sensor was re-initialised (err says how it went) */
    TOF_EVENT_BUS_RECOVERY = 2, /* the bus was recovered (err says how it went) */
    TOF_EVENT_OVERRUN = 3,      /* a main-loop iteration exceeded its budget */
};

/* One window's estimates, all estimators side by side (DESIGN.md §6). */
struct tof_estimate_record {
    uint64_t t_us;                 /* firmware time of the window's last slot end */
    struct attitude_output output; /* output.last_row is the sample (slot) index */
};

struct tof_event {
    enum tof_event_kind kind;
    uint64_t t_us;
    uint8_t sensor; /* 0..3, or 0xFF when not about one sensor */
    enum tof_health_state from, to;
    int err; /* hal_err of the action or of the error that caused the transition */
};

struct tof_app_counters {
    uint32_t iterations;
    uint32_t overruns; /* iterations longer than loop_budget_us */
    uint32_t max_iteration_us;
    uint32_t readings; /* good readings fed to the assembler */
    uint32_t read_errors[TOF_SENSORS];
    uint32_t errors_by_code[12]; /* index -err for hal_err codes -1..-11 */
    uint32_t reinits_ok;
    uint32_t reinits_failed;
    uint32_t bus_recoveries;
    uint32_t samples;   /* samples assembled */
    uint32_t estimates; /* estimate records emitted */
};

struct tof_app {
    const struct tof_platform *platform;
    const struct tof_app_config *cfg;
    struct vl53_config sensor_cfg[TOF_SENSORS]; /* built once at init from cfg + platform */
    struct vl53_array_config array_cfg;
    struct vl53_array array;
    struct tof_health health[TOF_SENSORS];
    bool start_pending[TOF_SENSORS]; /* configured, waiting for the next slot boundary */
    struct tof_assembler_config assembler_cfg;
    struct tof_assembler assembler;
    struct attitude_state estimator; /* its cfg is the live estimator configuration */
    enum attitude_estimator primary; /* the estimator telemetry and status lead with */
    bool running;                    /* false: samples are assembled, not estimated */
    uint32_t phase_us;      /* offset into its slot of the earliest reading of the last sample */
    uint32_t slot_first_us; /* ... being measured for the current slot (period: none yet) */
    uint64_t uptime_us;     /* 64-bit extension of the platform's 32-bit microsecond clock */
    uint32_t last_raw_us;
    bool raw_output;
    struct tof_app_counters counters;
};

/*
 * Bind the application to `platform` and `cfg` (both kept by pointer), bring the
 * sensors up and schedule their phase-aligned start. Sensors that fail are
 * reported and left to the fault manager. HAL_OK, or HAL_ERR_INVALID for a bad
 * configuration (nothing else stops the application from running).
 */
int tof_app_init(struct tof_app *app, const struct tof_platform *platform,
                 const struct tof_app_config *cfg);

/* One bounded main-loop iteration; `idle` true lets it sleep until the next due reading. */
void tof_app_step(struct tof_app *app, bool idle);

/*
 * Change the window length and mode at run time (a command): the estimators restart
 * with the next sample. HAL_OK, or HAL_ERR_INVALID (nothing changed) when `window` is
 * outside 2..ATTITUDE_WINDOW_MAX.
 */
int tof_app_set_window(struct tof_app *app, uint16_t window, bool sliding);

/* Choose the primary estimator; HAL_ERR_INVALID (nothing changed) for an unknown one or
 * one that does not run (not in the configuration's set, or not built into the image). */
int tof_app_set_primary(struct tof_app *app, enum attitude_estimator primary);

/* Start (true) or stop (false) estimating; acquisition and the fault manager go on. */
void tof_app_set_running(struct tof_app *app, bool running);

/* Current firmware time in microseconds (64-bit, monotonic). */
uint64_t tof_app_now_us(struct tof_app *app);

/* Write a NUL-terminated line (plus '\n') to the platform log, if it has one. */
void tof_log_line(const struct tof_platform *platform, const char *text);

struct tof_link; /* firmware/link.h */

/*
 * The firmware's main program on a board: banner, init, then `max_iterations`
 * iterations (0: forever), polling the telemetry `link` (may be NULL) after each.
 * Returns 0, or the init error.
 */
int tof_app_main(const struct tof_platform *platform, const struct tof_app_config *cfg,
                 struct tof_app *app, struct tof_link *link, uint32_t max_iterations);

#endif /* FIRMWARE_APP_H */
