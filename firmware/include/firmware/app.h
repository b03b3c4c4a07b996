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
#include "firmware/vhv_schedule.h"
#include "hal/hal_err.h"
#include "vl53_array/vl53_array.h"

/* Firmware identity, printed at boot and in status telemetry. */
#define TOF_FW_NAME    "tof-attitude"
#define TOF_FW_VERSION "0.1.0"

enum tof_event_kind {
    TOF_EVENT_HEALTH = 0,       /* a sensor changed health state */
    TOF_EVENT_REINIT = 1,       /* a sensor was re-initialised (err says how it went) */
    TOF_EVENT_BUS_RECOVERY = 2, /* the bus was recovered (err says how it went) */
    TOF_EVENT_OVERRUN = 3,      /* a main-loop iteration exceeded its budget */
    /* ST's temperature update (VHV) began on `sensor`: the temperature moved 8 °C since its
     * last VHV calibration; its readings are missing until TOF_EVENT_TEMP_UPDATE_DONE. */
    TOF_EVENT_TEMP_UPDATE = 4,
    TOF_EVENT_TEMP_UPDATE_DONE = 5, /* ... ended (err says how); the sensor restarts */
};

/* One window's estimates, all estimators side by side (docs/reference/tools.md). */
struct tof_estimate_record {
    uint64_t t_us;                 /* firmware time of the window's last slot end */
    struct attitude_output output; /* output.last_row is the sample (slot) index */
    bool temp_known;               /* the unit measured a temperature for the window's last row */
    int16_t temp_cdeg;             /* ... that temperature, 0.01 °C */
};

/* Slots of errors_by_code: slot -err for each hal code -1..HAL_ERR_LAST, slot 0
 * (TOF_ERROR_SLOT_OTHER) for a code of another module's block (docs/reference/errors.md). */
#define TOF_ERROR_SLOT_OTHER 0u
#define TOF_ERROR_SLOTS      ((unsigned)HAL_ERR_COUNT + 1u)

/* The errors_by_code slot that counts `err` (TOF_ERROR_SLOTS above). */
unsigned tof_app_error_slot(int err);

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
    uint32_t errors_by_code[TOF_ERROR_SLOTS]; /* tof_app_error_slot(err) */
    uint32_t reinits_ok;
    uint32_t reinits_failed;
    uint32_t bus_recoveries;
    uint32_t samples;   /* samples assembled */
    uint32_t estimates; /* estimate records emitted */
    /* Temperature reads that failed (each such sample has no temperature) and the last
     * failure's hal code (0: none yet); a board without a sensor reads nothing. */
    uint32_t temp_errors;
    int temp_last_error;
    uint32_t temp_updates;        /* ST's temperature updates completed */
    uint32_t temp_updates_failed; /* ... that ended in an error (counted as the part's error) */
};

/* Assembled samples one iteration can hold back for the next (struct tof_app, deferred). */
#define TOF_APP_DEFERRED 4u

struct tof_app {
    const struct tof_platform *platform;
    /* The configuration in force: tof_app_init()'s copy of its `cfg`, its timing changed by
     * tof_app_set_period() (the estimator's own in force is estimator.cfg). */
    struct tof_app_config cfg;
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
    /* Samples assembled during the sensor reads, estimated in the iterations after them
     * (tof_app_step): the reads and a window's end (~200k instructions at N = 255) are
     * never one iteration. A ring; when full, a sample is estimated at once. */
    struct tof_sample deferred[TOF_APP_DEFERRED];
    uint8_t deferred_head, deferred_count;
    int estimator_error; /* attitude_error of the estimator's last refusal at init, or 0 */
    /* The last temperature read (with the last sample) and the parts' VHV calibrations
     * against it: which part reruns ST's temperature update (vhv_schedule.h). */
    bool temp_known;
    int16_t temp_cdeg;
    struct tof_vhv_schedule vhv;
    struct tof_app_counters counters;
};

/*
 * Bind the application to `platform` (kept by pointer) and `cfg` (copied), bring the
 * sensors up and schedule their phase-aligned start. Sensors that fail are
 * reported and left to the fault manager. Returns HAL_OK; HAL_ERR_INVALID for a bad
 * application configuration or platform; a hal_err from attaching the sensors; or,
 * when the estimator refuses cfg->estimator, attitude_init()'s attitude_error
 * unchanged, also kept in app->estimator_error; the two kinds have disjoint numbers
 * (docs/reference/errors.md), and tof_app_error_message() names either. Nothing else stops the
 * application from running.
 */
int tof_app_init(struct tof_app *app, const struct tof_platform *platform,
                 const struct tof_app_config *cfg);

/* What error `err` from this application's calls means: attitude_error_message() for a
 * code below the hal block (the estimator's refusals reach the application as
 * attitude_error codes), else hal_err_name(). `app` is not needed since the blocks
 * became disjoint (docs/reference/errors.md); it stays for the callers. */
const char *tof_app_error_message(const struct tof_app *app, int err);

/* One bounded main-loop iteration; `idle` true lets it sleep until the next due reading. */
void tof_app_step(struct tof_app *app, bool idle);

/* The sleep of an idle iteration on its own (tof_app_step(app, false), other work, then
 * this): until the next due reading, a pending start's window, or idle_us (bounded by one
 * period). */
void tof_app_idle(struct tof_app *app);

/*
 * Change the window length and mode at run time (a command): the estimators restart
 * with the next sample. ATTITUDE_ERR_NONE (0), or attitude_init()'s attitude_error
 * unchanged (ATTITUDE_ERR_WINDOW outside 2..ATTITUDE_WINDOW_MAX), nothing changed.
 */
int tof_app_set_window(struct tof_app *app, uint16_t window, bool sliding);

/*
 * Change the Kalman filter's process noise at run time (the set-process-noise command):
 * random-walk intensities qd (x̄) and qt (a·tan α, a·tan β) in µm²/s, `automatic` to let
 * the filter learn Q (starting there) and R, as tof_app_config_process_noise() takes them
 * at init. The estimators restart with the next sample, as after tof_app_set_window().
 * ATTITUDE_ERR_NONE, or the estimator's attitude_error unchanged with nothing changed:
 * ATTITUDE_ERR_KALMAN_PROCESS_NOISE for an intensity that rounds to 0 or overflows Q per
 * row at this sample period, and for any Q > 0 or `automatic` in an image built without
 * the tracking form (cmake/TofOptions.cmake).
 */
int tof_app_set_process_noise(struct tof_app *app, uint32_t qd_um2_per_s, uint32_t qt_um2_per_s,
                              bool automatic);

/* Put the head's calibration `cal` (estimator/calibration.h) in force: the estimators restart
 * with the next sample, as after tof_app_set_window(). ATTITUDE_ERR_NONE, or the estimator's
 * attitude_error unchanged with nothing changed. */
int tof_app_set_calibration(struct tof_app *app, const struct calibration_head *cal);

/* The head's calibration in force (estimator/calibration.h) into `out`. */
void tof_app_get_calibration(const struct tof_app *app, struct calibration_head *out);

/* The calibration's age `age_s` (firmware/cal_age.h) for the estimator: with `restart`, the
 * estimators restart with it now (attitude_init(): its attitude_error, nothing changed on a
 * refusal); without, it is the age their next restart starts from when that restart sets none
 * of its own (tof_app_set_calibration()'s, a new calibration's). */
int tof_app_set_calibration_age(struct tof_app *app, uint32_t age_s, bool restart);

/* The calibration's age the estimator's walk counts now, seconds: the age it started from plus
 * the rows since then at its period (the estimator's own clock, the same on every target). A
 * restart for another window, process noise, arm or period carries it on; one for another
 * calibration takes the age set for it. */
uint32_t tof_app_calibration_age_s(const struct tof_app *app);

/* The head's arm a (µm) in force from the next sample: the estimators restart, as after
 * tof_app_set_window(). ATTITUDE_ERR_NONE, or attitude_init()'s attitude_error unchanged
 * (ATTITUDE_ERR_ARM outside 1..1000 mm) with nothing changed. */
int tof_app_set_arm(struct tof_app *app, int32_t arm_um);

/*
 * The sample period at run time (the set-period command): the configuration's timing for
 * `period_ms` (tof_app_config_period(): the longest budget of the distance mode that fits),
 * each sensor stopped, given that timing and parked for the next slot of the new period,
 * the assembler restarted on it, the estimators restarted with Q per row rescaled to keep its
 * intensity (tof_estimator_period()). The slot in progress is not assembled. The period in
 * force (the same timing) changes nothing. HAL_OK;
 * HAL_ERR_INVALID (nothing changed) when no timing of the mode fits; the estimator's
 * attitude_error (nothing changed) when it refuses the new period. A sensor whose new timing
 * could not be written counts the error and is re-initialised by the fault manager with it.
 */
int tof_app_set_period(struct tof_app *app, uint32_t period_ms);

/* Choose the primary estimator: ATTITUDE_ERR_NONE, or ATTITUDE_ERR_ESTIMATORS (nothing
 * changed) for an unknown one or one that does not run (not in the configuration's set,
 * or not built into the image), the estimator's own code for that. */
int tof_app_set_primary(struct tof_app *app, enum attitude_estimator primary);

/* Start (true) or stop (false) estimating; acquisition and the fault manager go on. */
void tof_app_set_running(struct tof_app *app, bool running);

/* Send (true) or stop sending (false) every assembled sample to the output. */
void tof_app_set_raw_output(struct tof_app *app, bool on);

/* The application's configuration and state, as a status report gives them. */
struct tof_app_status {
    uint64_t uptime_us;
    uint16_t window; /* samples per window */
    bool sliding;    /* false: tumbling windows */
    enum attitude_estimator primary;
    bool running;
    bool raw_output;
    uint32_t period_us; /* sample period */
    int32_t arm_um;     /* the head's arm a in force */
};

/* Fill `out` with the application's status (read only). */
void tof_app_get_status(const struct tof_app *app, struct tof_app_status *out);

/* Sensor health and error counters, as a health report gives them (cumulative). */
struct tof_app_health {
    uint64_t uptime_us;
    enum tof_health_state state[TOF_SENSORS];
    uint32_t losses[TOF_SENSORS];             /* times each sensor was declared lost */
    uint32_t read_errors[TOF_SENSORS];        /* failed polls of each sensor */
    uint32_t errors_by_code[TOF_ERROR_SLOTS]; /* tof_app_error_slot(err) */
    uint32_t bus_recoveries;
    uint32_t overruns; /* iterations longer than loop_budget_us */
    uint32_t max_iteration_us;
};

/* Fill `out` with the application's health and counters (read only). */
void tof_app_get_health(const struct tof_app *app, struct tof_app_health *out);

/* Current firmware time in microseconds (64-bit, monotonic). */
uint64_t tof_app_now_us(struct tof_app *app);

/* Write a NUL-terminated line (plus '\n') to the platform log, if it has one. */
void tof_log_line(const struct tof_platform *platform, const char *text);

/*
 * Something the main program runs beside the application, such as the telemetry link
 * (firmware/link.h: tof_link_service_ops). The application knows it only by these ops.
 */
struct tof_app_service_ops {
    /* The application is initialised: the one the service acts on from now on. */
    void (*start)(void *ctx, struct tof_app *app);
    /* After each main-loop iteration: bounded work. */
    void (*poll)(void *ctx);
};

struct tof_app_service {
    const struct tof_app_service_ops *ops;
    void *ctx;
};

/*
 * The firmware's main program on a board: banner, init, then `max_iterations`
 * iterations (0: forever), polling `service` (may be NULL) after each.
 * Returns 0, or the init error (logged with tof_app_error_message()).
 */
int tof_app_main(const struct tof_platform *platform, const struct tof_app_config *cfg,
                 struct tof_app *app, const struct tof_app_service *service,
                 uint32_t max_iterations);

/* ---- the head's temperature (firmware/src/app_temperature.c): the read that goes with each
 * sample, and the steps of ST's temperature update on one part at a time (when:
 * vhv_schedule.h); app.c calls these and does what their results ask (the part's restart, its
 * error for the fault manager, the events). */

/* Read the platform's temperature into `sample` (temp_known false without a sensor or on a
 * failed read, which is counted in app->counters; never an earlier value) and keep it as
 * app->temp_known / temp_cdeg for the update's schedule. */
void tof_app_read_temperature(struct tof_app *app, struct tof_sample *sample);

enum tof_temp_step {
    TOF_TEMP_STEP_IDLE,  /* nothing due, or the running update's range is not over */
    TOF_TEMP_STEP_BEGUN, /* `sensor` stopped and its update started (err: how) */
    TOF_TEMP_STEP_ENDED, /* `sensor`'s update ended (err: how); it is stopped */
};

struct tof_temp_step_result {
    enum tof_temp_step step;
    uint8_t sensor;
    int err;
};

/*
 * One step, bounded (one look, or one half of the driver's sequence): with an update
 * running, look at it once and end it when its range is over; else start one on the part
 * vhv_schedule names among the healthy, ranging ones. The schedule and the counters
 * (temp_updates, temp_updates_failed) are kept here; on BEGUN with an error and on ENDED the
 * caller restarts the part at the next slot, and counts an error as the part's.
 */
struct tof_temp_step_result tof_app_temperature_step(struct tof_app *app);

/* End a running update now (bounded by the driver's finish), for a re-timing of the parts. */
void tof_app_temperature_abandon(struct tof_app *app);

#endif /* FIRMWARE_APP_H */
