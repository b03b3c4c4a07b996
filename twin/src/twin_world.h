/*
 * What the twin's peripheral models see of the outside world: the sensor head of sim/
 * (four VL53 models on one I²C bus, sim_rig) behind the NUCLEO-L476RG's wiring, fed by a
 * recorded trace, plus the run's bookkeeping (where trace row 0 falls in simulated time).
 */
#ifndef TWIN_TWIN_WORLD_H
#define TWIN_TWIN_WORLD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "scene/row.h"
#include "sim/sim_fault.h"
#include "sim/sim_rig.h"

struct twin_world {
    struct sim_rig rig;
    struct sim_rig_config cfg;
    const struct scene_row *rows;
    size_t row_count;
    uint32_t period_us;
    /* Trace row 0 is the first measurement that completes after `arm_after_us` (the
     * firmware's boot status frame); its completion millisecond is origin_ms. */
    bool armed;
    uint64_t arm_after_us;
    bool origin_set;
    uint64_t origin_ms;
    /* The firmware numbers its slots from 0 at every boot: the trace row of the current
     * boot's slot 0 is that of the first measurement completing after its status frame. */
    bool boot_pending;
    uint64_t boot_after_us;
    int64_t boot_row;
    int source_error;
    FILE *i2c_log;
    uint64_t transfers;
};

/* Build the rig over `rows` (kept by pointer) with `faults` (NULL: none). */
void twin_world_init(struct twin_world *w, const struct scene_row *rows, size_t count,
                     uint32_t period_us, const struct sim_fault_config *faults);

/* Move the simulated world's clock up to `now_us` (never back). */
void twin_world_sync(struct twin_world *w, uint64_t now_us);

/* The next measurement completing after `after_us` becomes trace row 0 (first call only;
 * later calls, after a reset of the MCU, keep the origin: the world does not rewind). */
void twin_world_arm_origin(struct twin_world *w, uint64_t after_us);

/* A (re)boot of the firmware ended at `after_us`: the next measurement completing after it
 * is the new boot's slot 0 (w->boot_row). The first call also arms the origin. */
void twin_world_mark_boot(struct twin_world *w, uint64_t after_us);

/* Trace row of a measurement completed at simulated millisecond `ms` (-1 before row 0). */
int64_t twin_world_row_at_ms(const struct twin_world *w, uint64_t ms);

/* One I²C transaction on the simulated bus (hal_err result), logged if asked. */
int twin_world_transfer(struct twin_world *w, uint8_t addr7, const uint8_t *tx, size_t tx_len,
                        uint8_t *rx, size_t rx_len);

/* XSHUT of sensor s driven to `high`; GPIO1 of sensor s as the MCU pin sees it. */
void twin_world_xshut(struct twin_world *w, unsigned s, bool high);
bool twin_world_gpio1(struct twin_world *w, unsigned s);

/* SDA held low by a device (the stuck-bus fault); the bus recovery clocks release it. */
bool twin_world_sda_stuck(const struct twin_world *w);
void twin_world_recover(struct twin_world *w);

#endif /* TWIN_TWIN_WORLD_H */
