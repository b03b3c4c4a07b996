/* The twin's simulated world: sim_rig's sensor head fed by trace rows, its clock driven by
 * the emulated core's time, and the trace-row origin found from the firmware's own start. */
#include "twin_world.h"

#include <inttypes.h>
#include <string.h>

#include "hal/hal_err.h"

/* The VL53 models index their readings by completion time in milliseconds: the twin maps
 * them to trace rows itself, because the firmware's slot 0 is only known once it ran. */
#define INDEX_PERIOD_US 1000u

static int row_next(void *ctx, unsigned sensor, uint32_t sample_index, struct sim_range *out) {
    struct twin_world *w = ctx;
    const uint64_t ms = sample_index;
    if (!w->armed || ms * 1000u < w->arm_after_us) {
        *out = (struct sim_range){.present = false}; /* before the firmware's first slot */
        return 0;
    }
    if (!w->origin_set) {
        w->origin_set = true;
        w->origin_ms = ms;
    }
    const int64_t row = twin_world_row_at_ms(w, ms);
    if (w->boot_pending && ms * 1000u >= w->boot_after_us) {
        w->boot_pending = false;
        w->boot_row = row;
    }
    if (row < 0) {
        *out = (struct sim_range){.present = false};
        return 0;
    }
    if ((uint64_t)row >= w->row_count) {
        return 1; /* the trace is over */
    }
    const struct scene_row *r = &w->rows[row];
    *out = (struct sim_range){.distance_mm = r->range_mm[sensor],
                              .range_status = r->status[sensor],
                              .present = r->present[sensor]};
    return 0;
}

static const struct sim_range_source_ops row_ops = {.next = row_next};

void twin_world_init(struct twin_world *w, const struct scene_row *rows, size_t count,
                     uint32_t period_us, const struct sim_fault_config *faults) {
    FILE *log = w->i2c_log;
    memset(w, 0, sizeof *w);
    w->i2c_log = log;
    w->rows = rows;
    w->row_count = count;
    w->period_us = period_us;
    sim_rig_default_config(&w->cfg);
    for (unsigned i = 0; i < SIM_RIG_SENSORS; ++i) {
        w->cfg.sensor[i].index_mode = SIM_VL53_INDEX_BY_TIME;
        w->cfg.sensor[i].index_period_us = INDEX_PERIOD_US;
    }
    w->cfg.source = (struct sim_range_source){.ops = &row_ops, .ctx = w};
    if (faults != NULL) {
        w->cfg.faults = *faults;
    }
    sim_rig_init(&w->rig, &w->cfg);
}

void twin_world_sync(struct twin_world *w, uint64_t now_us) {
    const uint64_t sim_now = sim_clock_now(&w->rig.clock);
    if (now_us > sim_now) {
        sim_clock_advance(&w->rig.clock, now_us - sim_now);
    }
}

void twin_world_arm_origin(struct twin_world *w, uint64_t after_us) {
    if (!w->armed) {
        w->armed = true;
        w->arm_after_us = after_us;
    }
}

void twin_world_mark_boot(struct twin_world *w, uint64_t after_us) {
    twin_world_arm_origin(w, after_us);
    w->boot_pending = true;
    w->boot_after_us = after_us;
}

int64_t twin_world_row_at_ms(const struct twin_world *w, uint64_t ms) {
    if (!w->origin_set || ms < w->origin_ms) {
        return -1;
    }
    /* The four sensors start within a few hundred microseconds of the slot boundary, so a
     * row's completions fall in [origin + k·period, origin + k·period + 1 ms]. */
    return (int64_t)((ms - w->origin_ms) * 1000u / w->period_us);
}

static void hex(FILE *f, const uint8_t *b, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        fprintf(f, "%02x", b[i]);
    }
}

int twin_world_transfer(struct twin_world *w, uint8_t addr7, const uint8_t *tx, size_t tx_len,
                        uint8_t *rx, size_t rx_len) {
    const uint64_t t0 = sim_clock_now(&w->rig.clock);
    /* A stretching device holds the bus this long (the firmware's own budget ends first). */
    const int rc = w->rig.i2c.ops->write_read(w->rig.i2c.ctx, addr7, tx, tx_len, rx, rx_len, 2000u);
    w->transfers++;
    if (w->i2c_log != NULL) {
        /* DESIGN.md §6 --i2c-log: t_us,addr,write,read,result */
        fprintf(w->i2c_log, "%" PRIu64 ",0x%02x,", t0, addr7);
        hex(w->i2c_log, tx, tx_len);
        fputc(',', w->i2c_log);
        if (rc == HAL_OK) {
            hex(w->i2c_log, rx, rx_len);
        }
        fprintf(w->i2c_log, ",%s\n", rc == HAL_OK ? "ok" : hal_err_name(rc));
    }
    return rc;
}

void twin_world_xshut(struct twin_world *w, unsigned s, bool high) {
    (void)w->rig.hal_gpio.ops->write(w->rig.hal_gpio.ctx, SIM_RIG_XSHUT_PIN(s), high);
}

bool twin_world_gpio1(struct twin_world *w, unsigned s) {
    bool level = true;
    (void)w->rig.hal_gpio.ops->read(w->rig.hal_gpio.ctx, SIM_RIG_GPIO1_PIN(s), &level);
    return level;
}

bool twin_world_sda_stuck(const struct twin_world *w) {
    return w->rig.bus.sda_stuck;
}

void twin_world_recover(struct twin_world *w) {
    (void)w->rig.i2c.ops->recover(w->rig.i2c.ctx);
}
