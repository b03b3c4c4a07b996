/* The application's estimator controls and read-outs: window, process noise, calibration,
 * arm, primary estimator, running, raw stream, status and health (firmware/app.h). The
 * acquisition-side control, the sample period, is app.c's (tof_app_set_period). */
#include <string.h>

#include "firmware/app.h"
#include "hal/hal_err.h"

int tof_app_set_window(struct tof_app *app, uint16_t window, bool sliding) {
    struct attitude_config next = app->estimator.cfg;
    next.window = window;
    next.mode = sliding ? ATTITUDE_SLIDING : ATTITUDE_TUMBLING;
    tof_estimator_mode_process_noise(&next); /* Q = 0: auto when sliding */
    /* attitude_init() checks window and mode before it touches the state, and the rest
     * of the configuration was accepted at init: a refusal changes nothing. */
    next.calibration_age_s = tof_app_calibration_age_s(app);
    return attitude_init(&app->estimator, &next);
}

int tof_app_set_process_noise(struct tof_app *app, uint32_t qd_um2_per_s, uint32_t qt_um2_per_s,
                              bool automatic) {
    struct attitude_config next = app->estimator.cfg;
    const int rc = tof_estimator_process_noise(&next, app->assembler_cfg.period_us, qd_um2_per_s,
                                               qt_um2_per_s, automatic);
    if (rc != ATTITUDE_ERR_NONE) {
        return rc;
    }
    /* attitude_init() checks the whole configuration before it touches the state (the
     * Kalman filter's Q included): a refusal changes nothing. */
    next.calibration_age_s = tof_app_calibration_age_s(app);
    return attitude_init(&app->estimator, &next);
}

int tof_app_set_calibration(struct tof_app *app, const struct calibration_head *cal) {
    struct attitude_config next = app->estimator.cfg;
    next.calibration = *cal;
    /* as tof_app_set_window(): checked before the state is touched, a refusal changes nothing */
    return attitude_init(&app->estimator, &next);
}

void tof_app_get_calibration(const struct tof_app *app, struct calibration_head *out) {
    *out = app->estimator.cfg.calibration;
}

uint32_t tof_app_calibration_age_s(const struct tof_app *app) {
    const struct attitude_state *st = &app->estimator;
    const uint64_t s =
        (uint64_t)st->cfg.calibration_age_s + (uint64_t)st->rows * st->cfg.period_us / 1000000u;
    return s > UINT32_MAX ? UINT32_MAX : (uint32_t)s;
}

int tof_app_set_calibration_age(struct tof_app *app, uint32_t age_s, bool restart) {
    if (!restart) {
        app->estimator.cfg.calibration_age_s = age_s; /* read by the next attitude_init() */
        return ATTITUDE_ERR_NONE;
    }
    struct attitude_config next = app->estimator.cfg;
    next.calibration_age_s = age_s;
    return attitude_init(&app->estimator, &next);
}

int tof_app_set_arm(struct tof_app *app, int32_t arm_um) {
    struct attitude_config next = app->estimator.cfg;
    next.arm_um = arm_um;
    /* as tof_app_set_window(): checked before the state is touched, a refusal changes nothing */
    next.calibration_age_s = tof_app_calibration_age_s(app);
    return attitude_init(&app->estimator, &next);
}

int tof_app_set_primary(struct tof_app *app, enum attitude_estimator primary) {
    /* only an estimator that runs (selected in the configuration, built into the image) */
    if ((unsigned)primary >= (unsigned)ATTITUDE_EST_COUNT ||
        (app->estimator.cfg.estimators & ATTITUDE_EST_BIT(primary)) == 0u) {
        return ATTITUDE_ERR_ESTIMATORS;
    }
    app->primary = primary;
    return ATTITUDE_ERR_NONE;
}

void tof_app_set_running(struct tof_app *app, bool running) {
    app->running = running;
}

void tof_app_set_raw_output(struct tof_app *app, bool on) {
    app->raw_output = on;
}

void tof_app_get_status(const struct tof_app *app, struct tof_app_status *out) {
    *out = (struct tof_app_status){
        .uptime_us = app->uptime_us,
        .window = app->estimator.cfg.window,
        .sliding = app->estimator.cfg.mode == ATTITUDE_SLIDING,
        .primary = app->primary,
        .running = app->running,
        .raw_output = app->raw_output,
        .period_us = app->assembler_cfg.period_us,
        .arm_um = app->estimator.cfg.arm_um,
    };
}

void tof_app_get_health(const struct tof_app *app, struct tof_app_health *out) {
    memset(out, 0, sizeof *out);
    out->uptime_us = app->uptime_us;
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        out->state[i] = app->health[i].state;
        out->losses[i] = app->health[i].losses;
        out->read_errors[i] = app->counters.read_errors[i];
    }
    memcpy(out->errors_by_code, app->counters.errors_by_code, sizeof out->errors_by_code);
    out->bus_recoveries = app->counters.bus_recoveries;
    out->overruns = app->counters.overruns;
    out->max_iteration_us = app->counters.max_iteration_us;
}

const char *tof_app_error_message(const struct tof_app *app, int err) {
    (void)app;
    return err < HAL_ERR_BLOCK_END ? attitude_error_message(err) : hal_err_name(err);
}
