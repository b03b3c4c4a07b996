/*
 * host_sim replay's state: what replay.c runs and its parts (the statistics, the distance
 * mode, the plot) fill in, and what the report and summary read. A definition only.
 */
#ifndef HOST_SIM_REPLAY_STATE_H
#define HOST_SIM_REPLAY_STATE_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "cli.h"
#include "firmware/app.h"
#include "i2c_log.h"
#include "calibrate/cal_apply.h"
#include "replay_mode.h"
#include "replay_commands.h"
#include "replay_plot.h"
#include "replay_stats.h"
#include "scene/row_source.h"
#include "scene/trace.h"
#include "sim/sim_fault.h"
#include "sim/sim_replay.h"

/* The replay's state (static: the trace reader alone is ~70 KB). */
struct replay {
    const struct replay_args *args;
    struct trace_reader reader;
    struct scene_row_stream stream;
    double arm_mm;
    uint32_t period_ms;
    struct sim_fault_config faults;
    struct sim_replay sim;
    struct tof_app_config app_cfg;
    struct tof_platform platform;
    struct tof_app app;
    enum attitude_estimator primary;
    FILE *est_out;
    struct i2c_log_file i2c_log;
    struct replay_plot plot;
    struct replay_stats stats;
    uint64_t samples_done;
    bool faults_stopped;
    uint64_t faults_stop_us;
    int64_t recovery_us;
    uint32_t health_events, reinit_events, bus_recovery_events, overrun_events;
    uint32_t temp_update_events, temp_update_failures; /* ST's temperature updates begun, failed */
    int failed;            /* an output or data error: stop and report */
    uint64_t after_end;    /* estimates of slots after the trace's last row: not written */
    uint64_t partial_rows; /* tumbling: rows after the last whole window (no estimate) */
    struct replay_mode distance;
    struct cal_apply cal;            /* the head's calibration (calibrate/cal_apply.h) */
    struct sim_flash flash;          /* the simulated record storage, the calibration in it */
    struct tof_record_store records; /* over it, what the firmware's boot reads */
    int cal_state;                   /* enum tof_cal_state the boot found */
    struct replay_commands commands; /* --command: a host's commands through the link */
};

#endif /* HOST_SIM_REPLAY_STATE_H */
