/* The replay harness host_sim and the QEMU image share: trace rows into the four models
 * (sim/sim_replay.h). */
#include "sim/sim_replay.h"

static int row_next(void *ctx, unsigned sensor, uint32_t sample_index, struct sim_range *out) {
    struct sim_replay *r = ctx;
    if (sample_index < r->base_index) {
        /* Measurements before the firmware's first slot: no reading (never used). */
        *out = (struct sim_range){.present = false};
        return 0;
    }
    return r->rows.ops->next(r->rows.ctx, sensor, (uint32_t)(sample_index - r->base_index), out);
}

static const struct sim_range_source_ops row_ops = {.next = row_next};

void sim_replay_init(struct sim_replay *r, struct sim_range_source rows, uint32_t period_us,
                     const struct sim_fault_config *faults) {
    r->rows = rows;
    r->period_us = period_us;
    r->base_index = UINT64_MAX;
    r->last_progress_us = 0;
    r->last_samples = 0;
    sim_rig_default_config(&r->rig_cfg);
    for (unsigned i = 0; i < SIM_RIG_SENSORS; ++i) {
        r->rig_cfg.sensor[i].index_mode = SIM_VL53_INDEX_BY_TIME;
        r->rig_cfg.sensor[i].index_period_us = period_us;
    }
    r->rig_cfg.source = (struct sim_range_source){.ops = &row_ops, .ctx = r};
    if (faults != 0) {
        r->rig_cfg.faults = *faults;
    }
    sim_rig_init(&r->rig, &r->rig_cfg);
    const struct sim_temp_source none = {.ops = NULL, .ctx = NULL};
    sim_temp_init(&r->temp, none, &r->rig.clock, period_us);
}

struct hal_temp sim_replay_temp(struct sim_replay *r, struct sim_temp_source rows) {
    sim_temp_init(&r->temp, rows, &r->rig.clock, r->period_us);
    return sim_temp_hal(&r->temp);
}

void sim_replay_set_origin(struct sim_replay *r, uint64_t origin_us) {
    r->base_index = origin_us / r->period_us;
    sim_temp_set_origin(&r->temp, origin_us);
    r->last_progress_us = sim_clock_now(&r->rig.clock);
}

bool sim_replay_progressing(struct sim_replay *r, uint64_t samples_done) {
    const uint64_t now = sim_clock_now(&r->rig.clock);
    if (samples_done != r->last_samples) {
        r->last_samples = samples_done;
        r->last_progress_us = now;
        return true;
    }
    return now - r->last_progress_us <= SIM_REPLAY_STALL_US;
}
