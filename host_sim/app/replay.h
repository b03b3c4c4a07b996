/*
 * host_sim replay: a recorded trace drives four simulated VL53 devices on the
 * simulated I²C bus, and the unchanged firmware (drivers, fault manager,
 * assembler, estimators) runs against them in simulated time.
 */
#ifndef HOST_SIM_REPLAY_H
#define HOST_SIM_REPLAY_H

#include "cli.h"

/* Run `host_sim replay` with parsed arguments. Returns the process exit status. */
int replay_run(const struct replay_args *args);

#endif /* HOST_SIM_REPLAY_H */
