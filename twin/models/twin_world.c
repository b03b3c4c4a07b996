/* The twin's simulated world: sim_rig's sensor head fed by trace rows, its clock driven by
 * the emulated core's time, readings mapped to trace rows by the firmware's own slots. */
#include "twin_world.h"

#include <inttypes.h>
#include <math.h>
#include <string.h>

#include "hal/hal_err.h"

/* The VL53 models index their readings by completion time in units of INDEX_PERIOD_US; the
 * twin maps them to trace rows itself, because a boot's slot 0 is only known once the
 * firmware has run its bring-up. 100 us keeps the 32-bit index unwrapped for 119 h, longer
 * than the longest trace tof_twin loads (10^7 rows of 20 ms, 56 h), and is far finer than
 * the distance of a completion from a slot boundary (the sensors start at a boundary and
 * finish a timing budget later, the budget at least VL53_IMP_MARGIN_MS short of the period). */
#define INDEX_PERIOD_US 100u

static int row_next(void *ctx, unsigned sensor, uint32_t sample_index, struct sim_range *out) {
    struct twin_world *w = ctx;
    const int64_t row = twin_world_row_at_us(w, (uint64_t)sample_index * INDEX_PERIOD_US);
    if (row < 0) {
        /* before the boot's first slot: no reading (never used), as sim_replay does it */
        *out = (struct sim_range){.present = false};
        return 0;
    }
    if ((uint64_t)row >= w->row_count && !w->loop) {
        return 1; /* the trace is over */
    }
    const struct scene_row *r = &w->rows[(uint64_t)row % w->row_count];
    *out = (struct sim_range){.distance_mm = r->range_mm[sensor],
                              .range_status = r->status[sensor],
                              .present = r->present[sensor]};
    return 0;
}

static const struct sim_range_source_ops row_ops = {.next = row_next};

bool twin_world_temp_at_us(const struct twin_world *w, uint64_t t_us, int16_t *cdeg) {
    const int64_t row = twin_world_row_at_us(w, t_us);
    if (row < 0 || w->row_count == 0u || ((uint64_t)row >= w->row_count && !w->loop)) {
        return false;
    }
    const struct scene_row *r = &w->rows[(uint64_t)row % w->row_count];
    if (!r->has_temp) {
        return false;
    }
    *cdeg = (int16_t)lround(r->temp_c * 100.0); /* a trace's temp_c: exact to 0.01 °C */
    return true;
}

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

void twin_world_start_boot(struct twin_world *w, uint64_t slot0_us) {
    if (!w->origin_set) {
        w->origin_set = true;
        w->origin_us = slot0_us;
        w->boot_row = 0;
    } else if (slot0_us <= w->origin_us) {
        w->boot_row = 0; /* not after a reset of the MCU: cannot happen, stay defined */
    } else {
        /* the first trace row that begins at or after the new slot 0 */
        w->boot_row = (int64_t)((slot0_us - w->origin_us + w->period_us - 1u) / w->period_us);
    }
    w->boot_origin_us = slot0_us;
}

int64_t twin_world_row_at_us(const struct twin_world *w, uint64_t t_us) {
    if (!w->origin_set || t_us < w->boot_origin_us) {
        return -1;
    }
    return w->boot_row + (int64_t)((t_us - w->boot_origin_us) / w->period_us);
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
        /* docs/reference/tools.md --i2c-log: t_us,addr,write,read,result */
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
