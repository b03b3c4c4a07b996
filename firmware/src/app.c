/* The application: bring-up, acquisition, fault manager, estimation, one iteration at a time. */
#include "firmware/app.h"

#include <string.h>

#include "firmware/text.h"
#include "hal/hal_err.h"

unsigned tof_app_error_slot(int err) {
    return (err < 0 && err >= HAL_ERR_LAST) ? (unsigned)(-err) : TOF_ERROR_SLOT_OTHER;
}

void tof_log_line(const struct tof_platform *platform, const char *text) {
    if (platform->log.ops == NULL || platform->log.ops->write == NULL) {
        return;
    }
    platform->log.ops->write(platform->log.ctx, text, strlen(text));
    platform->log.ops->write(platform->log.ctx, "\n", 1);
}

uint64_t tof_app_now_us(struct tof_app *app) {
    const struct hal_time *t = &app->platform->time;
    const uint32_t raw = t->ops->now_us(t->ctx);
    app->uptime_us += hal_time_elapsed_us(raw, app->last_raw_us); /* wrap-safe extension */
    app->last_raw_us = raw;
    return app->uptime_us;
}

static void emit_event(struct tof_app *app, enum tof_event_kind kind, unsigned sensor,
                       enum tof_health_state from, enum tof_health_state to, int err) {
    const struct tof_output *out = &app->platform->output;
    if (out->ops == NULL || out->ops->event == NULL) {
        return;
    }
    const struct tof_event ev = {.kind = kind,
                                 .t_us = app->uptime_us,
                                 .sensor = (uint8_t)sensor,
                                 .from = from,
                                 .to = to,
                                 .err = err};
    out->ops->event(out->ctx, &ev);
}

/* A sample's raw output, then the estimators. */
static void process_sample(struct tof_app *app, const struct tof_sample *sample) {
    const struct tof_output *out = &app->platform->output;
    if (app->raw_output && out->ops != NULL && out->ops->sample != NULL) {
        out->ops->sample(out->ctx, sample);
    }
    if (!app->running) {
        return;
    }
    bool present[TOF_SENSORS];
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        present[i] = (sample->present_mask & (1u << i)) != 0u;
    }
    struct tof_estimate_record record;
    attitude_set_temperature(&app->estimator, sample->temp_known, sample->temp_cdeg);
    if (attitude_push_sample(&app->estimator, sample->range_mm, sample->status, present,
                             &record.output)) {
        record.t_us = sample->t_us;
        record.temp_known = sample->temp_known; /* the window's last row's */
        record.temp_cdeg = sample->temp_cdeg;
        ++app->counters.estimates;
        if (out->ops != NULL && out->ops->estimate != NULL) {
            out->ops->estimate(out->ctx, &record);
        }
    }
}

/* Assembled samples flow here, during the sensor reads: the temperature read with them, then
 * held for the next iteration (see struct tof_app, deferred), or processed at once when the
 * ring is full (none is lost). */
static void on_sample(void *ctx, const struct tof_sample *assembled) {
    struct tof_app *app = ctx;
    struct tof_sample with_temp = *assembled;
    const struct tof_sample *sample = &with_temp;
    tof_app_read_temperature(app, &with_temp);
    ++app->counters.samples;
    if (app->slot_first_us < app->assembler_cfg.period_us) {
        app->phase_us = app->slot_first_us; /* when the sensors report within a slot */
    }
    app->slot_first_us = app->assembler_cfg.period_us;
    if (app->deferred_count < TOF_APP_DEFERRED) {
        const unsigned at = (app->deferred_head + app->deferred_count) % TOF_APP_DEFERRED;
        app->deferred[at] = *sample;
        ++app->deferred_count;
        return;
    }
    process_sample(app, sample);
}

/* The oldest held-back sample, if any: processed now; true if there was one. */
static bool process_deferred(struct tof_app *app) {
    if (app->deferred_count == 0u) {
        return false;
    }
    const struct tof_sample sample = app->deferred[app->deferred_head];
    app->deferred_head = (uint8_t)((app->deferred_head + 1u) % TOF_APP_DEFERRED);
    --app->deferred_count;
    process_sample(app, &sample);
    return true;
}

/* Slot boundaries are multiples of the period on the firmware timeline. */
static uint64_t next_boundary(uint64_t now_us, uint32_t period_us) {
    return (now_us / period_us + 1u) * period_us;
}

/*
 * Sensors start ranging at the same offset into a slot (start_offset_us), so every
 * sensor's n-th measurement completes in the same slot: samples are simultaneous
 * across the four sensors and slot k is measurement k. A sensor brought up (or back)
 * is stopped and started at the next such offset by tof_app_step().
 */
static void park_until_boundary(struct tof_app *app, unsigned sensor) {
    struct vl53_dev *dev = vl53_array_sensor(&app->array, sensor);
    if (vl53_is_ranging(dev)) {
        (void)vl53_stop_ranging(dev); /* a failure shows up as an error at the start */
    }
    app->start_pending[sensor] = true;
}

static void note_error(struct tof_app *app, unsigned sensor, int err) {
    ++app->counters.read_errors[sensor];
    ++app->counters.errors_by_code[tof_app_error_slot(err)];
    const enum tof_health_state before = app->health[sensor].state;
    const bool bus_wide = err == HAL_ERR_BUS_STUCK || err == HAL_ERR_BUS_BUSY;
    /* The sensor reported its own hardware fault: re-initialise it, the bus is fine. */
    const enum tof_error_scope scope = bus_wide                ? TOF_ERROR_BUS
                                       : err == HAL_ERR_DEVICE ? TOF_ERROR_DEVICE
                                                               : TOF_ERROR_SENSOR;
    tof_health_on_error(&app->health[sensor], &app->cfg.health, (uint32_t)(app->uptime_us / 1000u),
                        scope);
    if (app->health[sensor].state != before) {
        emit_event(app, TOF_EVENT_HEALTH, sensor, before, app->health[sensor].state, err);
    }
    if (bus_wide) {
        const int rc = vl53_array_recover_bus(&app->array);
        ++app->counters.bus_recoveries;
        emit_event(app, TOF_EVENT_BUS_RECOVERY, 0xFFu, before, before, rc);
    }
}

static void note_good(struct tof_app *app, unsigned sensor) {
    const enum tof_health_state before = app->health[sensor].state;
    tof_health_on_good(&app->health[sensor], &app->cfg.health, (uint32_t)(app->uptime_us / 1000u));
    if (app->health[sensor].state != before) {
        emit_event(app, TOF_EVENT_HEALTH, sensor, before, app->health[sensor].state, HAL_OK);
    }
}

static void poll_sensor(struct tof_app *app, unsigned sensor) {
    if (!tof_health_usable(&app->health[sensor]) || app->start_pending[sensor] ||
        sensor == app->vhv.active) {
        return;
    }
    struct vl53_result result;
    const int rc = vl53_array_poll(&app->array, sensor, &result);
    if (rc == HAL_ERR_NOT_READY) {
        return;
    }
    if (rc != HAL_OK) {
        note_error(app, sensor, rc);
        return;
    }
    note_good(app, sensor);
    ++app->counters.readings;
    /* The reading's time on the 64-bit timeline: now minus how long ago it was read. */
    (void)tof_app_now_us(app);
    const uint32_t age_us = hal_time_elapsed_us(app->last_raw_us, result.time_us);
    const uint64_t t_us = app->uptime_us >= age_us ? app->uptime_us - age_us : 0u;
    if (t_us >= app->assembler.origin_us) {
        const uint32_t offset =
            (uint32_t)((t_us - app->assembler.origin_us) % app->assembler_cfg.period_us);
        if (offset < app->slot_first_us) {
            app->slot_first_us = offset;
        }
    }
    const struct tof_sample_sink sink = {.emit = on_sample, .ctx = app};
    tof_assembler_add(&app->assembler, &app->assembler_cfg, sensor, t_us, result.distance_mm,
                      result.range_status, &sink);
}

/* A re-initialisation ended (`rc` from the array): count it, park the sensor for the next
 * slot on success, free a stuck bus on failure, tell the health state machine. */
static void reinit_done(struct tof_app *app, unsigned sensor, int rc) {
    if (rc == HAL_OK) {
        ++app->counters.reinits_ok;
        park_until_boundary(app, sensor);
        tof_vhv_calibrated(&app->vhv, sensor, app->temp_known, app->temp_cdeg); /* its VHV ran */
    } else {
        ++app->counters.reinits_failed;
        ++app->counters.errors_by_code[tof_app_error_slot(rc)];
        if (rc == HAL_ERR_BUS_STUCK || rc == HAL_ERR_BUS_BUSY) {
            /* A stuck bus fails every re-init: free it, or the sensor can never come back. */
            const int bus_rc = vl53_array_recover_bus(&app->array);
            ++app->counters.bus_recoveries;
            emit_event(app, TOF_EVENT_BUS_RECOVERY, 0xFFu, TOF_HEALTH_LOST, TOF_HEALTH_LOST,
                       bus_rc);
        }
    }
    const enum tof_health_state lost = app->health[sensor].state;
    tof_health_on_reinit_done(&app->health[sensor], &app->cfg.health,
                              (uint32_t)(app->uptime_us / 1000u), rc == HAL_OK);
    emit_event(app, TOF_EVENT_REINIT, sensor, lost, app->health[sensor].state, rc);
}

/* Carry out the fault manager's decision for one sensor; returns true if it did bus work
 * for a re-initialisation. A re-init runs in two halves: the XSHUT cycle up to the start of
 * ST's ~100 ms VHV range, then, in later iterations, its end once the range is over, so
 * the other sensors keep being read meanwhile. */
static bool manage_sensor(struct tof_app *app, unsigned sensor) {
    if (vl53_array_report(&app->array, sensor)->state == VL53_SENSOR_CONFIGURING) {
        const int rc = vl53_array_recover_sensor_step(&app->array, sensor);
        if (rc == HAL_ERR_NOT_READY) {
            return false; /* VHV range still running: one quick look, nothing else */
        }
        (void)tof_app_now_us(app);
        reinit_done(app, sensor, rc);
        return true;
    }
    const uint32_t now_ms = (uint32_t)(app->uptime_us / 1000u);
    const enum tof_health_state before = app->health[sensor].state;
    const enum tof_health_action action =
        tof_health_poll(&app->health[sensor], &app->cfg.health, now_ms);
    if (app->health[sensor].state != before) {
        emit_event(app, TOF_EVENT_HEALTH, sensor, before, app->health[sensor].state,
                   HAL_ERR_TIMEOUT);
    }
    if (action != TOF_HEALTH_ACT_REINIT) {
        return false;
    }
    const int rc = vl53_array_recover_sensor_begin(&app->array, sensor);
    (void)tof_app_now_us(app);
    if (rc != HAL_OK) {
        reinit_done(app, sensor, rc); /* failed before the VHV range */
    }
    return true;
}

/*
 * Where in a slot the sensors are started. A VL53L1X ends its first range one timing budget
 * after the start and the next ones a period apart (ST ULD, timed ranging; sim/'s model does
 * the same), and a reading belongs to the slot it is read in. Started at a boundary, the
 * readings would end budget_ms into every slot (15 of 20 ms by default) and one read a few
 * ms late (four reads, a long iteration) would land in the next slot. So the start is one
 * budget before a boundary plus FIRST_READING_US: every reading ends that far into its slot,
 * leaving the rest of the slot (and a window's estimate and telemetry in the iteration after
 * it) before it would be overwritten or mis-slotted.
 */
#define FIRST_READING_US 2000u

static uint32_t start_offset_us(const struct tof_app *app) {
    const uint32_t period_us = app->assembler_cfg.period_us;
    const uint32_t budget_us = (uint32_t)app->cfg.timing.budget_ms * 1000u % period_us;
    return (period_us - budget_us + FIRST_READING_US) % period_us;
}

static void start_pending_sensors(struct tof_app *app) {
    const uint32_t period_us = app->assembler_cfg.period_us;
    /* Start only in the idle_us after the start offset, so every sensor's readings end in the
     * same early part of a slot (see start_offset_us). */
    const uint64_t shifted = app->uptime_us + period_us - start_offset_us(app);
    if (shifted % period_us > app->cfg.idle_us) {
        return;
    }
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        if (!app->start_pending[i]) {
            continue;
        }
        app->start_pending[i] = false;
        const int rc = vl53_start_ranging(vl53_array_sensor(&app->array, i));
        if (rc != HAL_OK) {
            note_error(app, i, rc);
        }
    }
}

/*
 * How long an idle iteration sleeps. The sensors start at the same offset into a slot, so
 * their readings arrive at the same offset into every slot (phase_us, learnt from the last
 * sample). Once every sensor has reported for the pending slots there is nothing to do
 * until one idle_us before that offset in the next slot: sleep until then. Otherwise
 * poll every idle_us, which bounds the data-ready latency; with a start pending, wake no
 * later than the opening of its window (start_pending_sensors), which is only idle_us wide:
 * iterations of idle_us plus their own work, locked to the slot period, could else step
 * over it slot after slot (seen in the twin: no start for 60 ms, then a re-init).
 */
/* The longest idle sleep: the watchdog is kicked once an iteration, and the L476's expires
 * after 400 ms (boards/stm32/stm32_board.c); a period of up to 10 s (set-period) sleeps in
 * slices. Found by the twin: a 500 ms period reset the board every 0.7 s. */
#define MAX_SLEEP_US 50000u

static uint32_t idle_time_us(const struct tof_app *app, uint64_t now_us) {
    if (app->deferred_count != 0u) {
        return 0u; /* a held-back sample: its iteration comes at once */
    }
    /* The phase is a first reading's time once read: a reading that takes longer on the wire
     * than an idle step (a 100 kHz bus: 3.5 ms) must wake that much earlier too, or each
     * sample's phase comes later than the last and the reads fall behind the parts (found by
     * host_sim --i2c-khz 100: 0.9 ms a sample, a reading lost every 11 samples). */
    const uint32_t read_us = tof_app_sample_bus_us(app->cfg.i2c_khz) / TOF_SENSORS;
    const uint32_t early =
        read_us > app->cfg.idle_us ? app->cfg.idle_us + read_us : app->cfg.idle_us;
    const uint32_t lead = app->phase_us > early ? app->phase_us - early : 0u;
    const uint64_t next_slot = app->assembler.origin_us +
                               (uint64_t)app->assembler.next_index * app->assembler_cfg.period_us +
                               lead;
    bool waiting = false;
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        waiting = waiting || app->start_pending[i];
    }
    if (!waiting && now_us < next_slot && app->assembler.pending[0].present_mask == 0u) {
        /* at most a period, and at most MAX_SLEEP_US: the iterations kick the watchdog */
        uint64_t sleep_us = next_slot - now_us;
        if (sleep_us > app->assembler_cfg.period_us) {
            sleep_us = app->assembler_cfg.period_us;
        }
        if (sleep_us > MAX_SLEEP_US) {
            sleep_us = MAX_SLEEP_US;
        }
        return (uint32_t)sleep_us;
    }
    if (waiting) {
        const uint32_t period_us = app->assembler_cfg.period_us;
        const uint32_t into = (uint32_t)((now_us + period_us - start_offset_us(app)) % period_us);
        if (into <= app->cfg.idle_us) {
            return 0u; /* in the window now: start in the next iteration */
        }
        const uint32_t to_window = period_us - into;
        return to_window < app->cfg.idle_us ? to_window : app->cfg.idle_us;
    }
    return app->cfg.idle_us;
}

int tof_app_init(struct tof_app *app, const struct tof_platform *platform,
                 const struct tof_app_config *cfg) {
    memset(app, 0, sizeof *app);
    app->platform = platform;
    app->cfg = *cfg;
    if (tof_app_config_check(cfg) != NULL || platform->time.ops == NULL) {
        return HAL_ERR_INVALID;
    }
    app->last_raw_us = platform->time.ops->now_us(platform->time.ctx);
    app->uptime_us = app->last_raw_us; /* the timeline starts at the platform clock's value */
    app->raw_output = cfg->raw_output;
    tof_vhv_schedule_init(&app->vhv); /* the bring-up's VHV: at the first temperature read */
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        app->sensor_cfg[i] = (struct vl53_config){
            .i2c = platform->i2c,
            .gpio = platform->gpio,
            .time = platform->time,
            .address = cfg->address[i],
            .xshut_pin = platform->xshut_pin[i],
            .gpio1_pin = platform->gpio1_pin[i],
            .polarity = VL53_INT_ACTIVE_HIGH,
            .timing = cfg->timing,
            .pads_at_avdd = platform->sensor_pads_at_avdd,
            /* The part has no CRC: a distance that differs on a 2-byte re-read is refused, so
             * a flipped bit cannot reach an `ok` window (docs/explanation/driver-and-bus.md
             * "Integrity"; bus load 14.35 % at 4 x 50 Hz, within the 15 % goal). */
            .verify_distance = true,
            .bus_hz = (uint32_t)cfg->i2c_khz * 1000u, /* the call budgets' wire time */
        };
    }
    app->array_cfg = (struct vl53_array_config){.sensors = app->sensor_cfg, .count = TOF_SENSORS};
    int rc = vl53_array_attach(&app->array, &app->array_cfg);
    if (rc != HAL_OK) {
        return rc;
    }
    const int est_rc = attitude_init(&app->estimator, &cfg->estimator);
    if (est_rc != ATTITUDE_ERR_NONE) {
        app->estimator_error = est_rc;
        return est_rc; /* unchanged: attitude_error_message() names the field */
    }
    /* the product consensus when it runs, else the first estimator that does */
    app->primary = ATTITUDE_EST_CONSENSUS;
    for (unsigned e = 0; e < (unsigned)ATTITUDE_EST_COUNT; ++e) {
        if ((cfg->estimator.estimators & ATTITUDE_EST_BIT(e)) != 0u) {
            app->primary = (enum attitude_estimator)e;
            break;
        }
    }
    app->running = true;
    app->assembler_cfg = (struct tof_assembler_config){
        .period_us = vl53_period_us(&cfg->timing),
        .max_skew_us = cfg->max_skew_us,
        .max_emit_per_call = 8,
    };
    app->slot_first_us = app->assembler_cfg.period_us;
    rc = vl53_array_bring_up(&app->array);
    const uint64_t now = tof_app_now_us(app);
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        tof_health_init(&app->health[i], (uint32_t)(now / 1000u));
        const struct vl53_sensor_report *report = vl53_array_report(&app->array, i);
        if (report->state == VL53_SENSOR_RANGING) {
            park_until_boundary(app, i);
        } else {
            /* Failed bring-up: the fault manager retries it after its back-off. */
            for (uint8_t k = 0; k < cfg->health.errors_to_lost; ++k) {
                tof_health_on_error(&app->health[i], &cfg->health, (uint32_t)(now / 1000u),
                                    TOF_ERROR_SENSOR);
            }
            tof_health_on_reinit_done(&app->health[i], &cfg->health, (uint32_t)(now / 1000u),
                                      false);
            emit_event(app, TOF_EVENT_HEALTH, i, TOF_HEALTH_HEALTHY, app->health[i].state,
                       report->err);
        }
    }
    /* Slot 0 is the first whole period after the sensors start at the next boundary. */
    const uint64_t start = next_boundary(tof_app_now_us(app), app->assembler_cfg.period_us);
    tof_assembler_init(&app->assembler, start + app->assembler_cfg.period_us);
    (void)rc; /* per-sensor failures are in the reports and health states */
    return HAL_OK;
}

/* ST's temperature update, one part at a time (app_temperature.c): its part restarted at the
 * next slot when it ends or fails to begin, a failure the part's error, each step an event.
 * The part's readings are missing meanwhile: the windows say so, the events say why. Returns
 * true if it did bus work beyond one look. */
static bool manage_temperature_update(struct tof_app *app) {
    const struct tof_temp_step_result r = tof_app_temperature_step(app);
    if (r.step == TOF_TEMP_STEP_IDLE) {
        return false;
    }
    const unsigned s = r.sensor;
    if (r.step == TOF_TEMP_STEP_ENDED || r.err != HAL_OK) {
        park_until_boundary(app, s);
    }
    if (r.err != HAL_OK) {
        note_error(app, s, r.err);
    }
    (void)tof_app_now_us(app);
    emit_event(app,
               r.step == TOF_TEMP_STEP_BEGUN ? TOF_EVENT_TEMP_UPDATE : TOF_EVENT_TEMP_UPDATE_DONE,
               s, app->health[s].state, app->health[s].state, r.err);
    return true;
}

/* An iteration's bus work: sensor starts and reads, the fault manager, the assembler. */
static void acquire(struct tof_app *app) {
    start_pending_sensors(app);
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        poll_sensor(app, i);
        (void)tof_app_now_us(app);
    }
    /* At most one re-initialisation or temperature update step per iteration keeps the
     * iteration bounded. */
    bool busy = false;
    for (unsigned i = 0; i < TOF_SENSORS && !busy; ++i) {
        busy = i != app->vhv.active && manage_sensor(app, i);
    }
    if (!busy) {
        (void)manage_temperature_update(app);
    }
    const struct tof_sample_sink sink = {.emit = on_sample, .ctx = app};
    tof_assembler_poll(&app->assembler, &app->assembler_cfg, tof_app_now_us(app), &sink);
}

void tof_app_step(struct tof_app *app, bool idle) {
    const uint64_t begin = tof_app_now_us(app);
    ++app->counters.iterations;
    /* A held-back sample is the iteration's work (its estimate, its telemetry); the
     * sensors are read in the next one (a reading stays in the sensor for a period). */
    if (!process_deferred(app)) {
        acquire(app);
    }
    const uint64_t end = tof_app_now_us(app);
    const uint64_t took = end - begin;
    if (took > app->counters.max_iteration_us) {
        app->counters.max_iteration_us = took > UINT32_MAX ? UINT32_MAX : (uint32_t)took;
    }
    if (took > app->cfg.loop_budget_us) {
        ++app->counters.overruns;
        emit_event(app, TOF_EVENT_OVERRUN, 0xFFu, TOF_HEALTH_HEALTHY, TOF_HEALTH_HEALTHY,
                   HAL_ERR_TIMEOUT);
    } else if (app->platform->watchdog.ops != NULL) {
        app->platform->watchdog.ops->kick(app->platform->watchdog.ctx);
    }
    if (idle) {
        const uint32_t idle_us = idle_time_us(app, end);
        app->platform->time.ops->delay_us(app->platform->time.ctx, idle_us);
    }
}

void tof_app_idle(struct tof_app *app) {
    const uint32_t idle_us = idle_time_us(app, tof_app_now_us(app));
    app->platform->time.ops->delay_us(app->platform->time.ctx, idle_us);
}

int tof_app_set_period(struct tof_app *app, uint32_t period_ms) {
    struct tof_app_config next = app->cfg;
    if (tof_app_config_period(&next, period_ms) != HAL_OK) {
        return HAL_ERR_INVALID;
    }
    if (next.timing.budget_ms == app->cfg.timing.budget_ms &&
        next.timing.inter_measurement_ms == app->cfg.timing.inter_measurement_ms) {
        return HAL_OK; /* the period in force: nothing to re-time, nothing restarted */
    }
    struct attitude_config est = app->estimator.cfg;
    int rc = tof_estimator_period(&est, next.estimator.period_us);
    if (rc == ATTITUDE_ERR_NONE) {
        est.calibration_age_s = tof_app_calibration_age_s(app); /* the walk goes on */
        rc = attitude_init(&app->estimator, &est); /* checked first: a refusal changes nothing */
    }
    if (rc != ATTITUDE_ERR_NONE) {
        return rc;
    }
    app->cfg = next;
    tof_app_temperature_abandon(app); /* its range runs at the old timing */
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        app->sensor_cfg[i].timing = next.timing;
        struct vl53_dev *dev = vl53_array_sensor(&app->array, i);
        /* A configured part (ranging, or parked for its start) is stopped and given the new
         * timing, then started at the new period's next slot. Any other (off, failed, between
         * the halves of a re-init) takes it at its next configuration; so does a part whose
         * write failed, kept from starting until the fault manager re-initialises it. */
        const bool configured = vl53_array_report(&app->array, i)->state == VL53_SENSOR_RANGING;
        if (configured) {
            park_until_boundary(app, i);
            if (vl53_is_ranging(dev)) { /* the stop did not reach it: re-initialise it */
                app->start_pending[i] = false;
                note_error(app, i, HAL_ERR_DEVICE);
                continue;
            }
        }
        (void)vl53_set_timing_next(dev, &next.timing); /* checked above; the part is stopped */
        if (configured) {
            rc = vl53_set_timing(dev, &next.timing);
            app->start_pending[i] = rc == HAL_OK;
            if (rc != HAL_OK) {
                note_error(app, i, rc);
            }
        }
    }
    app->assembler_cfg.period_us = vl53_period_us(&next.timing);
    app->assembler_cfg.max_skew_us = next.max_skew_us;
    app->slot_first_us = app->assembler_cfg.period_us;
    app->phase_us = 0u;
    const uint64_t start = next_boundary(tof_app_now_us(app), app->assembler_cfg.period_us);
    tof_assembler_init(&app->assembler, start + app->assembler_cfg.period_us);
    return HAL_OK;
}

/* Not inlined: its line buffer stays off the main loop's stack (tools/stack_check.py). The
 * code, not its message: the messages' table (estimator/src/attitude_text.c, 1.6 KB) would be
 * the flight image's only use of it, and the 64 KiB budget is full; docs/reference/errors.md and
 * tools/tof_telemetry.py name every code, and the codes' blocks are disjoint. */
static __attribute__((noinline)) void
log_init_failure(const struct tof_app *app, const struct tof_platform *platform, int rc) {
    char line[64]; /* "init failed: estimator error -" and the code */
    struct tof_text t;
    tof_text_init(&t, line, sizeof line);
    tof_text_str(&t, app->estimator_error != 0 ? "init failed: estimator error "
                                               : "init failed: error ");
    tof_text_i64(&t, rc);
    tof_text_str(&t, " (docs/reference/errors.md)");
    tof_log_line(platform, line);
}

int tof_app_main(const struct tof_platform *platform, const struct tof_app_config *cfg,
                 struct tof_app *app, const struct tof_app_service *service,
                 uint32_t max_iterations) {
    tof_log_line(platform, TOF_FW_NAME " " TOF_FW_VERSION);
    tof_log_line(platform, platform->board_name);
    const int rc = tof_app_init(app, platform, cfg);
    if (rc != HAL_OK) {
        log_init_failure(app, platform, rc);
        return rc;
    }
    const bool has_service = service != NULL && service->ops != NULL;
    if (has_service && service->ops->start != NULL) {
        service->ops->start(service->ctx, app);
    }
    for (uint32_t n = 0; max_iterations == 0u || n < max_iterations; ++n) {
        /* The service right after the work, the sleep last: what the service sends (its
         * transmit may block) then follows the readings just taken instead of delaying the
         * ones the sleep waits for. */
        tof_app_step(app, false);
        if (has_service && service->ops->poll != NULL) {
            service->ops->poll(service->ctx);
        }
        tof_app_idle(app);
    }
    return HAL_OK;
}
