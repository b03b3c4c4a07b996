/*
 * host_sim replay: a recorded trace drives four simulated VL53 devices on the
 * simulated I²C bus, and the unchanged firmware (drivers, fault manager,
 * assembler, estimators) runs against them in simulated time.
 */
#ifndef HOST_SIM_REPLAY_H
#define HOST_SIM_REPLAY_H

#include "cli.h"
#include "estimator/attitude.h"

/* What a replay measured, for the summary, the report and the fault campaign. */
struct replay_result {
    uint64_t rows;
    uint64_t estimates;
    uint32_t status_count[ATTITUDE_EST_COUNT][3]; /* ok, degraded, invalid */
    uint32_t unflagged_wrong[ATTITUDE_EST_COUNT]; /* ok yet > 5x the window's bound off */
    double rms_alpha_deg[ATTITUDE_EST_COUNT];
    double crb_alpha_deg; /* RMS over windows of the bound */
    uint32_t overruns;    /* main-loop iterations over their budget */
    uint32_t max_iteration_us;
    uint32_t reinits, bus_recoveries;
    bool faults_stopped; /* --faults-until was reached */
    int64_t recovery_us; /* from the stop to four healthy sensors (-1: never) */
};

/* Run `host_sim replay` with parsed arguments. Returns the process exit status. */
int replay_run(const struct replay_args *args);

/* Run a replay and fill *result (also writes the files args asks for); 0 on success. */
int replay_execute(const struct replay_args *args, struct replay_result *result);

#endif /* HOST_SIM_REPLAY_H */
