#include "drv_fixture.h"

#include <string.h>

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
    return sim_i2c_transfer_ns(f->rig.bus.bus_hz, 2u, 30u) / 1000u + 6u;
}
