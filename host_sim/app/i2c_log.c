/* --i2c-log: the simulated bus's transactions as CSV lines in a file. */
#include "i2c_log.h"

#include <errno.h>
#include <string.h>

#include "sim/sim_i2c_csv.h"

static void write_transaction(void *ctx, const struct sim_i2c_transaction *t) {
    struct i2c_log_file *log = ctx;
    char line[SIM_I2C_CSV_LINE_MAX];
    const size_t len = sim_i2c_csv_line(t, line, sizeof line);
    if (len == 0u || fwrite(line, 1u, len, log->file) != len) {
        log->write_failed = 1;
    }
}

static const struct sim_i2c_log_ops file_log_ops = {.transaction = write_transaction};

int i2c_log_open(struct i2c_log_file *log, const char *path, struct sim_i2c_bus *bus) {
    log->path = path;
    log->write_failed = 0;
    log->file = fopen(path, "w");
    if (log->file == NULL || fputs(SIM_I2C_CSV_HEADER "\n", log->file) == EOF) {
        fprintf(stderr, "host_sim replay: --i2c-log %s: %s\n", path, strerror(errno));
        if (log->file != NULL) {
            fclose(log->file);
            log->file = NULL;
        }
        return -1;
    }
    const struct sim_i2c_log sink = {&file_log_ops, log};
    sim_i2c_set_log(bus, &sink);
    return 0;
}

int i2c_log_close(struct i2c_log_file *log, struct sim_i2c_bus *bus) {
    if (log->file == NULL) {
        return 0;
    }
    sim_i2c_set_log(bus, NULL);
    const int close_failed = fclose(log->file) != 0;
    log->file = NULL;
    if (log->write_failed || close_failed) {
        fprintf(stderr, "host_sim replay: --i2c-log %s: write failed\n", log->path);
        return -1;
    }
    return 0;
}
