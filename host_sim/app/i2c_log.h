/*
 * host_sim's --i2c-log: every transaction of the simulated bus written to a CSV file in
 * the format of sim/sim_i2c_csv.h (docs/reference/tools.md), through the bus's log sink.
 */
#ifndef HOST_SIM_I2C_LOG_H
#define HOST_SIM_I2C_LOG_H

#include <stdio.h>

#include "sim/sim_i2c.h"

struct i2c_log_file {
    FILE *file;
    const char *path;
    int write_failed; /* a write failed: i2c_log_close() reports it */
};

/* Create `path`, write the header and attach the sink to `bus`. 0, or -1 after printing
 * the error (naming the file) to stderr. */
int i2c_log_open(struct i2c_log_file *log, const char *path, struct sim_i2c_bus *bus);

/* Detach from `bus` and close; 0, or -1 after printing what failed. No-op if not open. */
int i2c_log_close(struct i2c_log_file *log, struct sim_i2c_bus *bus);

#endif /* HOST_SIM_I2C_LOG_H */
