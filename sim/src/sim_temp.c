/* The simulated temperature sensor fed by the trace's rows (sim/sim_temp.h). */
#include "sim/sim_temp.h"

#include <stddef.h>

#include "hal/hal_err.h"

void sim_temp_init(struct sim_temp *t, struct sim_temp_source source, const struct sim_clock *clock,
                   uint32_t period_us) {
    *t = (struct sim_temp){
        .source = source,
        .clock = clock,
        .period_us = period_us,
        .base_slot = UINT64_MAX,
    };
}

void sim_temp_set_origin(struct sim_temp *t, uint64_t origin_us) {
    t->base_slot = t->period_us != 0u ? origin_us / t->period_us : 0u;
}

int sim_temp_read_cdeg(void *ctx, int16_t *cdeg) {
    struct sim_temp *t = ctx;
    if (t == NULL || cdeg == NULL) {
        return HAL_ERR_INVALID;
    }
    ++t->reads;
    const uint64_t slot = t->period_us != 0u ? sim_clock_now(t->clock) / t->period_us : 0u;
    if (t->base_slot == UINT64_MAX || slot < t->base_slot || t->source.ops == NULL ||
        slot - t->base_slot > UINT32_MAX) {
        ++t->no_value;
        return HAL_ERR_NOT_READY;
    }
    bool present = false;
    int16_t value = 0;
    const int rc =
        t->source.ops->at(t->source.ctx, (uint32_t)(slot - t->base_slot), &present, &value);
    if (rc < 0) {
        if (t->source_error == 0) {
            t->source_error = rc;
        }
        ++t->no_value;
        return HAL_ERR_CORRUPT;
    }
    if (rc > 0 || !present) {
        ++t->no_value;
        return HAL_ERR_NOT_READY;
    }
    if (value < HAL_TEMP_MIN_CDEG || value > HAL_TEMP_MAX_CDEG) {
        ++t->no_value;
        return HAL_ERR_CORRUPT;
    }
    *cdeg = value;
    return HAL_OK;
}

static const struct hal_temp_ops sim_temp_ops = {.read_cdeg = sim_temp_read_cdeg};

struct hal_temp sim_temp_hal(struct sim_temp *t) {
    const struct hal_temp temp = {.ops = &sim_temp_ops, .ctx = t};
    return temp;
}
