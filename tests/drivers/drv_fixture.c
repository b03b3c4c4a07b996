/* Shared set-up of the driver tests: a simulated head and the product's driver configuration. */
#include "drv_fixture.h"

#include <string.h>

#include "hal/hal_err.h"

uint16_t drv_expected_distance(unsigned sensor, uint32_t index) {
    return (uint16_t)(100u + 10u * sensor + index % 97u);
}

static int drv_source_next(void *ctx, unsigned sensor, uint32_t sample_index,
                           struct sim_range *out) {
    struct drv_source *src = ctx;
    src->calls++;
    if (src->limit != 0u && sample_index >= src->limit) {
        return 1;
    }
    out->distance_mm = drv_expected_distance(sensor, sample_index);
    out->range_status = src->status;
    out->present = src->dropout_every == 0u || (sample_index + 1u) % src->dropout_every != 0u;
    return 0;
}

static const struct sim_range_source_ops drv_source_ops = {.next = drv_source_next};

void drv_fixture_defaults(struct drv_fixture *f) {
    memset(f, 0, sizeof *f);
    sim_rig_default_config(&f->rig_cfg);
    f->rig_cfg.source.ops = &drv_source_ops;
    f->rig_cfg.source.ctx = &f->source;
    for (unsigned i = 0; i < DRV_SENSORS; ++i) {
        struct vl53_config *c = &f->sensor_cfg[i];
        c->address = (uint8_t)(DRV_FIRST_ADDRESS + i);
        c->xshut_pin = SIM_RIG_XSHUT_PIN(i);
        c->gpio1_pin = SIM_RIG_GPIO1_PIN(i);
        c->polarity = VL53_INT_ACTIVE_HIGH;
        c->timing.mode = VL53_DISTANCE_SHORT;
        c->timing.budget_ms = 15u;
        c->timing.inter_measurement_ms = 20u;
        c->verify_distance = false;
        c->pads_at_avdd = true; /* the product's NUCLEO boards: 3V3 pull-ups */
    }
}

void drv_fixture_build(struct drv_fixture *f) {
    f->source.calls = 0u;
    sim_rig_init(&f->rig, &f->rig_cfg);
    for (unsigned i = 0; i < DRV_SENSORS; ++i) {
        f->sensor_cfg[i].i2c = f->rig.i2c;
        f->sensor_cfg[i].gpio = f->rig.hal_gpio;
        f->sensor_cfg[i].time = f->rig.time;
    }
    f->array_cfg.sensors = f->sensor_cfg;
    f->array_cfg.count = DRV_SENSORS;
    memset(&f->array, 0, sizeof f->array);
}

uint64_t drv_now(const struct drv_fixture *f) {
    return sim_clock_now(&f->rig.clock);
}

void drv_sleep(struct drv_fixture *f, uint32_t us) {
    f->rig.time.ops->delay_us(f->rig.time.ctx, us);
}

uint32_t drv_transfer_slack_us(const struct drv_fixture *f) {
    return sim_i2c_transfer_ns(f->rig.bus.bus_hz, 2u + VL53_DEFAULT_CONFIG_LEN, 0u) / 1000u + 6u;
}

/* The model published `p` and the driver reported `r` for it: the driver's status is the
 * model's, or the first-after-start mark on a valid one. */
static bool same_status(const struct sim_vl53_published *p, const struct vl53_result *r) {
    return p->range_status == r->range_status ||
           (p->range_status == VL53_RANGE_VALID && r->range_status == VL53_RANGE_NO_WRAP_CHECK &&
            (r->flags & VL53_RESULT_FIRST) != 0u);
}

bool drv_result_matches(const struct sim_vl53 *m, const struct vl53_result *r) {
    for (size_t k = 0; k < 2u; ++k) {
        const struct sim_vl53_published *p = &m->published[k];
        if (p->valid && p->stream_count == r->stream_count && p->distance_mm == r->distance_mm &&
            same_status(p, r)) {
            return true;
        }
    }
    return false;
}

bool drv_result_safe(const struct sim_vl53 *m, const struct vl53_result *r) {
    if (r->range_status != VL53_RANGE_VALID) {
        return true; /* not usable: the consumer drops it, whatever its distance */
    }
    for (size_t k = 0; k < 2u; ++k) {
        const struct sim_vl53_published *p = &m->published[k];
        if (p->valid && p->stream_count == r->stream_count) {
            return p->distance_mm == r->distance_mm && p->range_status == VL53_RANGE_VALID;
        }
    }
    /* A stream count no published result has (a flipped count bit): the reading is still
     * right if it is the newest measurement. */
    return m->published[0].valid && m->published[0].distance_mm == r->distance_mm &&
           m->published[0].range_status == VL53_RANGE_VALID;
}

void drv_manager_init(struct drv_manager *m, struct drv_fixture *f) {
    memset(m, 0, sizeof *m);
    m->f = f;
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        m->healthy_since_us[i] = UINT64_MAX;
        m->last_error_us[i] = drv_now(f);
    }
}

uint32_t drv_manager_bound_us(const struct drv_manager *m, enum drv_call call) {
    const struct drv_fixture *f = m->f;
    uint32_t slack = drv_transfer_slack_us(f);
    switch (call) {
    case DRV_CALL_POLL: {
        return vl53_call_budget_us(&f->sensor_cfg[0]) + slack;
    }
    case DRV_CALL_RECOVER_SENSOR:
        return vl53_array_recover_budget_us(&f->array, 0) + VL53_ARRAY_STEPS_PER_SENSOR * slack;
    case DRV_CALL_RECOVER_BUS:
    default:
        return slack;
    }
}

static uint32_t injected_before[SIM_FAULT_COUNT];

static void faults_mark(const struct drv_manager *m) {
    memcpy(injected_before, m->f->rig.bus.stats.injected, sizeof injected_before);
}

static void faults_attribute(struct drv_manager *m, int err) {
    for (unsigned k = 0; k < (unsigned)SIM_FAULT_COUNT; ++k) {
        uint32_t delta = m->f->rig.bus.stats.injected[k] - injected_before[k];
        if (err == HAL_OK || err == HAL_ERR_NOT_READY) {
            m->faults_absorbed[k] += delta;
        } else {
            m->faults_surfaced[k] += delta;
        }
    }
}

static void timed(struct drv_manager *m, enum drv_call call, uint64_t t0) {
    uint64_t took = drv_now(m->f) - t0;
    m->calls[call]++;
    if (took > m->max_us[call]) {
        m->max_us[call] = (uint32_t)took;
    }
    if (took > drv_manager_bound_us(m, call)) {
        m->over_budget[call]++;
    }
}

static void note_error(struct drv_manager *m, size_t i, int err) {
    int index = -err;
    if (index > 0 && index < 13) {
        m->errors[index]++;
    }
    m->consecutive_errors[i]++;
    m->last_error_us[i] = drv_now(m->f);
    m->ok_since_error[i] = 0u;
    m->healthy_since_us[i] = UINT64_MAX;
}

/* A sensor re-init ended with `err` (its last half, or a failed first half). */
static void recovery_ended(struct drv_manager *m, size_t i, int err) {
    m->last_error_us[i] = drv_now(m->f);
    if (err == HAL_OK) {
        m->recoveries_ok++;
    } else if (err == HAL_ERR_BUS_STUCK) {
        /* Nothing on the bus can work until SDA is released. */
        m->recoveries_failed++;
        uint64_t t1 = drv_now(m->f);
        faults_mark(m);
        int bus_err = vl53_array_recover_bus(&m->f->array);
        faults_attribute(m, bus_err);
        timed(m, DRV_CALL_RECOVER_BUS, t1);
    } else {
        m->recoveries_failed++;
        m->retry_at_us[i] = drv_now(m->f) + DRV_MANAGER_RETRY_US;
    }
}

/* The first half of a re-init (as the firmware does it): up to the VHV range's start. */
static void recover_sensor(struct drv_manager *m, size_t i) {
    uint64_t t0 = drv_now(m->f);
    faults_mark(m);
    int err = vl53_array_recover_sensor_begin(&m->f->array, i);
    faults_attribute(m, err);
    timed(m, DRV_CALL_RECOVER_SENSOR, t0);
    m->consecutive_errors[i] = 0u;
    m->last_error_us[i] = drv_now(m->f);
    m->ok_since_error[i] = 0u;
    m->healthy_since_us[i] = UINT64_MAX;
    if (err != HAL_OK) {
        recovery_ended(m, i, err);
    }
}

/* The second half, one look per tick until the VHV range is over. */
static void step_sensor(struct drv_manager *m, size_t i) {
    uint64_t t0 = drv_now(m->f);
    faults_mark(m);
    int err = vl53_array_recover_sensor_step(&m->f->array, i);
    faults_attribute(m, err);
    timed(m, DRV_CALL_RECOVER_SENSOR, t0);
    if (err != HAL_ERR_NOT_READY) {
        recovery_ended(m, i, err);
    }
}

void drv_manager_tick(struct drv_manager *m, uint32_t tick_us) {
    struct drv_fixture *f = m->f;
    bool bus_recovered = false;
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        if (f->array.report[i].state == VL53_SENSOR_CONFIGURING) {
            step_sensor(m, i);
            continue;
        }
        if (f->array.report[i].state != VL53_SENSOR_RANGING) {
            if (drv_now(f) >= m->retry_at_us[i]) {
                recover_sensor(m, i);
            }
            continue;
        }
        struct vl53_result r;
        uint64_t t0 = drv_now(f);
        faults_mark(m);
        int err = vl53_array_poll(&f->array, i, &r);
        faults_attribute(m, err);
        timed(m, DRV_CALL_POLL, t0);
        if (err == HAL_ERR_NOT_READY) {
            continue;
        }
        if (err == HAL_OK) {
            m->results[i]++;
            /* Errors are forgiven only after a run of clean results, so a sensor that fails
             * every other sample still gets recovered. */
            if (m->ok_since_error[i] + 1u >= DRV_MANAGER_CLEAN_TO_FORGIVE) {
                m->consecutive_errors[i] = 0u;
            }
            if (!drv_result_safe(&f->rig.sensor[i], &r)) {
                m->unsafe_results++;
            } else if (!drv_result_matches(&f->rig.sensor[i], &r)) {
                m->glitches++;
            }
            m->ok_since_error[i]++;
            if (m->ok_since_error[i] == 2u) {
                m->healthy_since_us[i] = drv_now(f);
            }
            continue;
        }
        note_error(m, i, err);
        if (err == HAL_ERR_BUS_STUCK) {
            if (!bus_recovered) {
                t0 = drv_now(f);
                faults_mark(m);
                int bus_err = vl53_array_recover_bus(&f->array);
                faults_attribute(m, bus_err);
                timed(m, DRV_CALL_RECOVER_BUS, t0);
                bus_recovered = true;
            }
            continue;
        }
        /* A hardware fault the sensor reports itself: only a re-init can clear it. */
        if (err == HAL_ERR_DEVICE || m->consecutive_errors[i] >= DRV_MANAGER_ERRORS_TO_RECOVER ||
            vl53_data_overdue(&f->array.dev[i])) {
            recover_sensor(m, i);
        }
    }
    drv_sleep(f, tick_us);
}

uint64_t drv_manager_all_healthy_since(const struct drv_manager *m) {
    uint64_t latest = 0u;
    for (size_t i = 0; i < DRV_SENSORS; ++i) {
        if (m->healthy_since_us[i] > latest) {
            latest = m->healthy_since_us[i];
        }
    }
    return latest;
}

int drv_fixture_default_rig(struct drv_fixture *f) {
    drv_fixture_defaults(f);
    drv_fixture_build(f);
    return 0;
}
