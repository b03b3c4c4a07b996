/*
 * The simulated head's temperature sensor, as hal_temp: a reading at simulated time t is the
 * temperature of the trace row whose slot t falls in (row k: slot base + k of `period_us`,
 * the rows' own timeline, as the VL53 models index them). The rows come from a source the
 * replay provides (a trace's temp_c column). A row without a temperature reads as a failed
 * conversion (HAL_ERR_NOT_READY), so the firmware counts it and that sample has none; a board
 * whose trace has no temp_c column at all gets no sensor (hal_temp ops NULL), not this model.
 * Integer only, no heap.
 */
#ifndef SIM_SIM_TEMP_H
#define SIM_SIM_TEMP_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_temp.h"
#include "sim/sim_clock.h"

struct sim_temp_source_ops {
    /* Row `row`'s temperature: 0 with *present (and *cdeg when present), 1 past the last row,
     * or a negative error (the source's data is bad). */
    int (*at)(void *ctx, uint32_t row, bool *present, int16_t *cdeg);
};

struct sim_temp_source {
    const struct sim_temp_source_ops *ops;
    void *ctx;
};

struct sim_temp {
    struct sim_temp_source source;
    const struct sim_clock *clock;
    uint32_t period_us;
    uint64_t base_slot; /* slot of row 0 (UINT64_MAX until the origin is set) */
    /* observations */
    uint32_t reads, no_value; /* reads, and those that gave no temperature */
    int source_error;         /* the source's first negative return (0: none) */
};

/* A sensor on `clock` reading `source`'s rows, one per `period_us` slot. */
void sim_temp_init(struct sim_temp *t, struct sim_temp_source source, const struct sim_clock *clock,
                   uint32_t period_us);

/* Row 0 is the slot that starts at `origin_us` of simulated time (sim_replay_set_origin). */
void sim_temp_set_origin(struct sim_temp *t, uint64_t origin_us);

/*
 * hal_temp read (ctx: struct sim_temp). HAL_OK with the current row's temperature;
 * HAL_ERR_NOT_READY before row 0, past the last row or for a row without one;
 * HAL_ERR_CORRUPT for a value outside HAL_TEMP_MIN_CDEG..HAL_TEMP_MAX_CDEG (the trace allows
 * a wider range than a sensor reads) or a failed source. *cdeg unchanged on an error.
 */
int sim_temp_read_cdeg(void *ctx, int16_t *cdeg);

/* The model as the firmware's hal_temp. */
struct hal_temp sim_temp_hal(struct sim_temp *t);

#endif /* SIM_SIM_TEMP_H */
