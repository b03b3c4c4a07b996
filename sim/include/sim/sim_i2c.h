/*
 * Simulated I²C bus: a hal_i2c implementation that routes every transfer by
 * 7-bit address to the device models attached to it (the pattern of Zephyr's
 * I²C emulators), charges each transfer its time on the wire at the bus speed,
 * keeps statistics, can record every transaction, and injects faults from a
 * seeded PRNG (sim_fault.h). Integer only, no heap; also built for Cortex-M.
 *
 * Several devices acknowledging one address all receive writes, and a read
 * returns the wired-AND of what they drive (SDA is open-drain).
 */
#ifndef SIM_I2C_H
#define SIM_I2C_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal/hal_i2c.h"
#include "sim/sim_clock.h"
#include "sim/sim_fault.h"
#include "sim/sim_prng.h"

#define SIM_I2C_MAX_TARGETS  8u
#define SIM_I2C_MAX_TRANSFER 128u /* bytes in either direction of one transfer */
#define SIM_I2C_RECORD_BYTES 32u  /* bytes of each direction kept in a record */

/* What a device model implements to sit on the bus. Each call first brings the model up
 * to the bus clock's current time. */
struct sim_i2c_target_ops {
    /* Would the device acknowledge `addr7` now (powered, past early boot, its address)? */
    bool (*acks)(void *ctx, uint8_t addr7);
    /* One acknowledged transfer (write tx, then read rx). HAL_OK or HAL_ERR_DATA_NACK. */
    int (*transfer)(void *ctx, const uint8_t *tx, size_t tx_len, uint8_t *rx, size_t rx_len);
    /* Device-side fault (SIM_FAULT_RESET, _DRDY_HIGH, _DRDY_LOW): true if it took effect. */
    bool (*inject)(void *ctx, enum sim_fault_kind kind);
    /* Flip bit `bit_choice` (uniform in 0..8*SIM_I2C_MAX_TRANSFER-1, taken mod the number of
     * eligible bits) among the rx bytes of this transfer that
     * came from the device's result registers; false if none did. */
    bool (*flip_result_bit)(void *ctx, const uint8_t *tx, size_t tx_len, uint8_t *rx, size_t rx_len,
                            uint32_t bit_choice);
};

struct sim_i2c_target {
    const struct sim_i2c_target_ops *ops;
    void *ctx;
    /* Optional: where the device keeps its 7-bit address, for a device whose acks() is false,
     * without side effects, for any other address. The bus then does not ask it about
     * transfers to other addresses (three in four on the product's bus). NULL: always ask. */
    const uint8_t *address;
};

/* One recorded transaction (bytes beyond SIM_I2C_RECORD_BYTES are not kept). */
struct sim_i2c_record {
    uint64_t start_us;
    uint32_t duration_ns;
    uint8_t addr7;
    int result;          /* HAL_OK or the hal_err the master saw */
    uint32_t fault_mask; /* bit k set: fault kind k was injected into this transaction */
    uint16_t tx_len;
    uint16_t rx_len;
    uint8_t tx[SIM_I2C_RECORD_BYTES];
    uint8_t rx[SIM_I2C_RECORD_BYTES];
};

/* One transaction as a log sink sees it: every byte of it (not only SIM_I2C_RECORD_BYTES).
 * rx_len is 0 unless the transfer succeeded. Pointers are valid during the call only. */
struct sim_i2c_transaction {
    uint64_t start_us;
    uint32_t duration_ns;
    uint8_t addr7;
    int result; /* HAL_OK or the hal_err the master saw */
    uint32_t fault_mask;
    const uint8_t *tx;
    size_t tx_len;
    const uint8_t *rx;
    size_t rx_len;
};

/* Where the bus reports every transaction on the wire (requests it rejects before the wire,
 * and bus recovery, are not transactions). */
struct sim_i2c_log_ops {
    void (*transaction)(void *ctx, const struct sim_i2c_transaction *t);
};
struct sim_i2c_log {
    const struct sim_i2c_log_ops *ops; /* NULL: no logging */
    void *ctx;
};

/* Error kinds counted by the statistics, in this order. */
enum sim_i2c_error_index {
    SIM_I2C_ERR_ADDR_NACK,
    SIM_I2C_ERR_DATA_NACK,
    SIM_I2C_ERR_BUS_BUSY,
    SIM_I2C_ERR_TIMEOUT,
    SIM_I2C_ERR_BUS_STUCK,
    SIM_I2C_ERR_COUNT
};

struct sim_i2c_stats {
    uint32_t transactions;
    uint32_t ok;
    uint32_t errors[SIM_I2C_ERR_COUNT];
    uint32_t invalid_requests; /* rejected before reaching the wire (bad lengths) */
    uint64_t tx_bytes;         /* data bytes (excluding address bytes) of successful transfers */
    uint64_t rx_bytes;
    uint64_t busy_ns;         /* time the bus was not free: wire time, stretching, stuck waits */
    uint32_t max_transfer_ns; /* longest single transaction */
    uint32_t injected[SIM_FAULT_COUNT];
    uint64_t last_injected_us; /* start of the last transaction a fault was injected into */
    uint32_t recoveries;       /* recover() calls */
};

struct sim_i2c_bus {
    struct sim_clock *clock;
    uint32_t bus_hz;
    struct sim_i2c_target targets[SIM_I2C_MAX_TARGETS];
    uint8_t nack_remaining[SIM_I2C_MAX_TARGETS]; /* NACK burst still to come, per target */
    bool nack_is_data[SIM_I2C_MAX_TARGETS]; /* burst NACKs the first data byte, not the address */
    size_t target_count;
    struct sim_fault_config faults;
    struct sim_prng prng;
    bool sda_stuck;
    uint32_t ns_carry; /* sub-microsecond remainder of wire time not yet added to the clock */
    struct {
        uint32_t bits, bus_hz, ns;
    } wire_memo[2]; /* the last two wire times computed ([0] newest; bits 0: empty) */
    struct sim_i2c_stats stats;
    struct sim_i2c_record *records;
    size_t record_capacity;
    size_t record_count; /* transactions seen since recording started (may exceed capacity) */
    bool record_ring;    /* keep the latest `capacity` (record k at k % capacity) */
    struct sim_i2c_log log;
};

/* Empty bus on `clock` at `bus_hz` (e.g. 100000 or 400000), no faults, no recording. */
void sim_i2c_init(struct sim_i2c_bus *bus, struct sim_clock *clock, uint32_t bus_hz);

/* Attach a device model; 0, or -1 when SIM_I2C_MAX_TARGETS are attached already. */
int sim_i2c_attach(struct sim_i2c_bus *bus, const struct sim_i2c_target *target);

/* Replace the fault settings and reseed the PRNG from faults->seed; clears NACK bursts.
 * A NULL `faults` turns injection off. Does not clear a stuck SDA. */
void sim_i2c_set_faults(struct sim_i2c_bus *bus, const struct sim_fault_config *faults);

/* Backdoor: hold SDA low now (as SIM_FAULT_STUCK does) or release it. */
void sim_i2c_set_sda_stuck(struct sim_i2c_bus *bus, bool stuck);

/* Record the following transactions into records[0..capacity-1] (NULL stops recording). */
void sim_i2c_record(struct sim_i2c_bus *bus, struct sim_i2c_record *records, size_t capacity);

/* Same, but keep the latest `capacity` transactions: transaction k goes to k % capacity. */
void sim_i2c_record_ring(struct sim_i2c_bus *bus, struct sim_i2c_record *records, size_t capacity);

/* Report every following transaction to `log` (NULL, or ops NULL: stop). */
void sim_i2c_set_log(struct sim_i2c_bus *bus, const struct sim_i2c_log *log);

/* Zero the statistics. */
void sim_i2c_reset_stats(struct sim_i2c_bus *bus);

/* Wire time in ns of a successful transfer: START, address + ACK, 9 bits per byte, a
 * repeated START and address when it both writes and reads, STOP. */
uint32_t sim_i2c_transfer_ns(uint32_t bus_hz, size_t tx_len, size_t rx_len);

/* Index of a hal_err in stats.errors, or -1 if it is not a bus error. */
int sim_i2c_error_index(int err);

/* hal_i2c over a sim_i2c_bus: ctx is the struct sim_i2c_bus *. */
extern const struct hal_i2c_ops sim_i2c_hal_ops;

/* A hal_i2c handle for `bus`. */
struct hal_i2c sim_i2c_hal(struct sim_i2c_bus *bus);

#endif /* SIM_I2C_H */
