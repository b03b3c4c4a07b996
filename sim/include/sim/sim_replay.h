/*
 * Replay harness shared by host_sim and the QEMU replay image, so both run the
 * firmware against exactly the same simulated rig:
 *  - the four VL53 models take their readings from a source indexed by trace
 *    row, mapped from simulated time (SIM_VL53_INDEX_BY_TIME) so that re-inits
 *    and restarts never shift the rows;
 *  - row 0 is the firmware's first slot (sim_replay_set_origin());
 *  - a progress watchdog: the firmware emits a sample per slot whatever the
 *    sensors do, so a stall is a defect to report, never a hang.
 * Integer C, no heap.
 */
#ifndef SIM_REPLAY_H
#define SIM_REPLAY_H

#include <stdbool.h>
#include <stdint.h>

#include "sim/range_source.h"
#include "sim/sim_fault.h"
#include "sim/sim_rig.h"
#include "sim/sim_temp.h"

/* Simulated time without a new sample after which the replay is declared stalled. */
#define SIM_REPLAY_STALL_US (10u * 1000u * 1000u)

struct sim_replay {
    struct sim_range_source rows; /* readings by trace row */
    uint32_t period_us;
    uint64_t base_index; /* device-model index of row 0 (UINT64_MAX until the origin is set) */
    struct sim_rig_config rig_cfg;
    struct sim_rig rig;
    uint64_t last_progress_us;
    uint64_t last_samples;
    struct sim_temp temp; /* the head's temperature sensor (sim_replay_temp) */
};

/* Build the rig: four models at `period_us` fed by `rows`, with `faults` (NULL: none). */
void sim_replay_init(struct sim_replay *r, struct sim_range_source rows, uint32_t period_us,
                     const struct sim_fault_config *faults);

/* The head's temperature sensor on the replay's clock and slots, reading `rows` (one per
 * trace row, as the readings): the firmware platform's hal_temp. Call after sim_replay_init. */
struct hal_temp sim_replay_temp(struct sim_replay *r, struct sim_temp_source rows);

/* The firmware's slot 0 starts at `origin_us` of simulated time: that slot is row 0 (of the
 * readings and of the temperature). */
void sim_replay_set_origin(struct sim_replay *r, uint64_t origin_us);

/* Call after each main-loop iteration with the samples emitted so far: false once no
 * sample has come for SIM_REPLAY_STALL_US of simulated time. */
bool sim_replay_progressing(struct sim_replay *r, uint64_t samples_done);

#endif /* SIM_REPLAY_H */
