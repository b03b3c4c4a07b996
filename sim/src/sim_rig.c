/* The simulated sensor head: clock, bus, GPIO and four VL53 models wired together
 * (sim/sim_rig.h). */
#include "sim/sim_rig.h"

#include <stddef.h>

void sim_rig_default_config(struct sim_rig_config *cfg) {
    struct sim_rig_config zero = {0};
    *cfg = zero;
    cfg->bus_hz = 400000u;
    for (unsigned i = 0; i < SIM_RIG_SENSORS; ++i) {
        cfg->sensor[i].sensor = i;
        cfg->sensor[i].xshut_wired = true;
        cfg->sensor[i].powered_at_start = true;
    }
}

void sim_rig_init(struct sim_rig *rig, const struct sim_rig_config *cfg) {
    sim_clock_init(&rig->clock, cfg->start_us);
    sim_i2c_init(&rig->bus, &rig->clock, cfg->bus_hz != 0u ? cfg->bus_hz : 400000u);
    sim_gpio_init(&rig->gpio);
    for (unsigned i = 0; i < SIM_RIG_SENSORS; ++i) {
        struct sim_vl53_config sensor_cfg = cfg->sensor[i];
        sensor_cfg.sensor = i;
        sim_vl53_init(&rig->sensor[i], &sensor_cfg, &rig->clock, &cfg->source);
        if (cfg->absent[i]) {
            continue; /* pins stay unwired: XSHUT drives nothing, GPIO1 reads its last level */
        }
        struct sim_i2c_target target = sim_vl53_target(&rig->sensor[i]);
        (void)sim_i2c_attach(&rig->bus, &target); /* 4 <= SIM_I2C_MAX_TARGETS: cannot fail */
        (void)sim_vl53_wire(&rig->sensor[i], &rig->gpio, SIM_RIG_XSHUT_PIN(i),
                            SIM_RIG_GPIO1_PIN(i));
    }
    sim_i2c_set_faults(&rig->bus, &cfg->faults);
    rig->i2c = sim_i2c_hal(&rig->bus);
    rig->hal_gpio = sim_gpio_hal(&rig->gpio);
    rig->time = sim_clock_hal(&rig->clock);
}
