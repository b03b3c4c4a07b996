/*
 * What the twin's peripheral models see of the outside world: the sensor head of sim/
 * (four VL53 models on one I²C bus, sim_rig) behind the NUCLEO-L476RG's wiring, fed by a
 * recorded trace, plus the run's bookkeeping (where trace row 0 and each boot's slot 0 fall
 * in simulated time).
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
    /* Trace row 0 is the first boot's slot 0, which begins at origin_us of simulated time
     * (what host_sim gets from the firmware's assembler, sim_replay_set_origin). */
    bool origin_set;
    uint64_t origin_us;
    /* The firmware numbers its slots from 0 at every boot: the current boot's slot 0
     * begins at boot_origin_us and is trace row boot_row. */
    uint64_t boot_origin_us;
    int64_t boot_row;
    bool loop; /* after the last row, row 0 again (tof_twin --pty: the sensors never run dry) */
    int source_error;
    FILE *i2c_log;
    uint64_t transfers;
};

/* Build the rig over `rows` (kept by pointer) with `faults` (NULL: none). Until the first
 * twin_world_start_boot() the models measure nothing (no data ready), as in host_sim. */
void twin_world_init(struct twin_world *w, const struct scene_row *rows, size_t count,
                     uint32_t period_us, const struct sim_fault_config *faults);

/* Move the simulated world's clock up to `now_us` (never back). */
void twin_world_sync(struct twin_world *w, uint64_t now_us);

/* A boot of the firmware numbers its slots from 0 at `slot0_us` of simulated time: a
 * measurement completing in [slot0_us + k·period, + period) is the boot's slot k, trace row
 * boot_row + k; one completing before slot0_us measures nothing. The first boot's slot 0 is
 * trace row 0; a later boot (after an MCU reset: the world does not rewind) goes on with
 * the first trace row that begins at or after its slot 0. */
void twin_world_start_boot(struct twin_world *w, uint64_t slot0_us);

/* Trace row of a measurement completed at simulated microsecond `t_us` (-1: none). */
int64_t twin_world_row_at_us(const struct twin_world *w, uint64_t t_us);

/* The head's temperature at simulated microsecond `t_us`: the temp_c of that moment's trace row
 * (the slot it falls in, as the readings), false if the row has none or there is no row. */
bool twin_world_temp_at_us(const struct twin_world *w, uint64_t t_us, int16_t *cdeg);

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
