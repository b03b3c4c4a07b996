/* Simulated I²C bus: routing, wire time, statistics, recording, logging, faults. */
#include "sim/sim_i2c.h"

#include "hal/hal_err.h"

/* Bus free time between a STOP and the next START (UM10204 rev 7, Table 10, tBUF):
 * 4.7 µs in standard mode, 1.3 µs in fast mode. Elapses, but the bus is idle. */
static uint32_t bus_free_ns(uint32_t bus_hz) {
    return bus_hz > 100000u ? 1300u : 4700u;
}

static uint32_t bits_ns(uint32_t bus_hz, uint32_t bits) {
    return (uint32_t)(((uint64_t)bits * 1000000000u + bus_hz - 1u) / bus_hz);
}

/* Bits on the wire of a successful transfer (lengths <= SIM_I2C_MAX_TRANSFER). */
static uint32_t transfer_bits(size_t tx_len, size_t rx_len) {
    uint32_t bits = 1u; /* START */
    if (tx_len > 0u) {
        bits += 9u + 9u * (uint32_t)tx_len; /* address + write bytes, each with its ACK */
    }
    if (rx_len > 0u) {
        bits += (tx_len > 0u ? 1u : 0u) + 9u + 9u * (uint32_t)rx_len; /* Sr, address, reads */
    }
    bits += 1u; /* STOP */
    return bits;
}

uint32_t sim_i2c_transfer_ns(uint32_t bus_hz, size_t tx_len, size_t rx_len) {
    return bits_ns(bus_hz, transfer_bits(tx_len, rx_len));
}

/* bits_ns at the bus's speed, remembering the last two answers: a replay's transfers come
 * in two sizes (result block read, interrupt clear), and the 64-bit division is what
 * costs. Keyed by the speed too, as bus_hz is a public field. */
static uint32_t wire_ns(struct sim_i2c_bus *bus, uint32_t bits) {
    for (unsigned i = 0; i < 2u; ++i) {
        if (bus->wire_memo[i].bits == bits && bus->wire_memo[i].bus_hz == bus->bus_hz) {
            return bus->wire_memo[i].ns;
        }
    }
    const uint32_t ns = bits_ns(bus->bus_hz, bits);
    bus->wire_memo[1] = bus->wire_memo[0];
    bus->wire_memo[0].bits = bits;
    bus->wire_memo[0].bus_hz = bus->bus_hz;
    bus->wire_memo[0].ns = ns;
    return ns;
}

/* The master's timeout in ns (capped at 4 s). */
static uint32_t timeout_ns_of(uint32_t timeout_us) {
    return timeout_us > 4000000u ? 4000000000u : timeout_us * 1000u;
}

int sim_i2c_error_index(int err) {
    switch (err) {
    case HAL_ERR_ADDR_NACK:
        return SIM_I2C_ERR_ADDR_NACK;
    case HAL_ERR_DATA_NACK:
        return SIM_I2C_ERR_DATA_NACK;
    case HAL_ERR_BUS_BUSY:
        return SIM_I2C_ERR_BUS_BUSY;
    case HAL_ERR_TIMEOUT:
        return SIM_I2C_ERR_TIMEOUT;
    case HAL_ERR_BUS_STUCK:
        return SIM_I2C_ERR_BUS_STUCK;
    default:
        return -1;
    }
}

void sim_i2c_init(struct sim_i2c_bus *bus, struct sim_clock *clock, uint32_t bus_hz) {
    bus->clock = clock;
    bus->bus_hz = bus_hz != 0u ? bus_hz : 400000u;
    bus->target_count = 0u;
    for (size_t i = 0; i < SIM_I2C_MAX_TARGETS; ++i) {
        bus->targets[i].ops = NULL;
        bus->targets[i].ctx = NULL;
        bus->targets[i].address = NULL;
        bus->nack_remaining[i] = 0u;
        bus->nack_is_data[i] = false;
    }
    sim_i2c_set_faults(bus, NULL);
    bus->sda_stuck = false;
    bus->ns_carry = 0u;
    for (unsigned i = 0; i < 2u; ++i) {
        bus->wire_memo[i].bits = 0u; /* no transfer is 0 bits long: empty */
        bus->wire_memo[i].bus_hz = 0u;
        bus->wire_memo[i].ns = 0u;
    }
    sim_i2c_reset_stats(bus);
    sim_i2c_record(bus, NULL, 0u);
    sim_i2c_set_log(bus, NULL);
}

void sim_i2c_set_log(struct sim_i2c_bus *bus, const struct sim_i2c_log *log) {
    bus->log.ops = (log != NULL && log->ops != NULL) ? log->ops : NULL;
    bus->log.ctx = bus->log.ops != NULL ? log->ctx : NULL;
}

int sim_i2c_attach(struct sim_i2c_bus *bus, const struct sim_i2c_target *target) {
    if (bus->target_count >= SIM_I2C_MAX_TARGETS) {
        return -1;
    }
    bus->targets[bus->target_count] = *target;
    bus->target_count++;
    return 0;
}

void sim_i2c_set_faults(struct sim_i2c_bus *bus, const struct sim_fault_config *faults) {
    for (unsigned k = 0; k < (unsigned)SIM_FAULT_COUNT; ++k) {
        bus->faults.ppm[k] = faults != NULL ? faults->ppm[k] : 0u;
    }
    bus->faults.seed = faults != NULL ? faults->seed : 0u;
    bus->faults.nack_burst_max = (faults != NULL && faults->nack_burst_max != 0u)
                                     ? faults->nack_burst_max
                                     : (uint8_t)SIM_FAULT_DEFAULT_NACK_BURST_MAX;
    sim_prng_seed(&bus->prng, bus->faults.seed);
    for (size_t i = 0; i < SIM_I2C_MAX_TARGETS; ++i) {
        bus->nack_remaining[i] = 0u;
    }
}

void sim_i2c_set_sda_stuck(struct sim_i2c_bus *bus, bool stuck) {
    bus->sda_stuck = stuck;
}

void sim_i2c_record(struct sim_i2c_bus *bus, struct sim_i2c_record *records, size_t capacity) {
    bus->records = records;
    bus->record_capacity = records != NULL ? capacity : 0u;
    bus->record_count = 0u;
    bus->record_ring = false;
}

void sim_i2c_record_ring(struct sim_i2c_bus *bus, struct sim_i2c_record *records, size_t capacity) {
    sim_i2c_record(bus, records, capacity);
    bus->record_ring = records != NULL && capacity > 0u;
}

void sim_i2c_reset_stats(struct sim_i2c_bus *bus) {
    struct sim_i2c_stats zero = {0};
    bus->stats = zero;
}

/* Spend `busy_ns` of bus time and then the bus-free gap; the clock moves in whole µs. */
static void spend(struct sim_i2c_bus *bus, uint32_t busy_ns) {
    bus->stats.busy_ns += busy_ns;
    if (busy_ns > bus->stats.max_transfer_ns) {
        bus->stats.max_transfer_ns = busy_ns;
    }
    uint64_t total = (uint64_t)bus->ns_carry + busy_ns + bus_free_ns(bus->bus_hz);
    sim_clock_advance(bus->clock, total / 1000u);
    bus->ns_carry = (uint32_t)(total % 1000u);
}

static inline __attribute__((always_inline)) void
note(struct sim_i2c_bus *bus, uint64_t start_us, uint32_t duration_ns, uint8_t addr7, int result,
     uint32_t fault_mask, const uint8_t *tx, size_t tx_len, const uint8_t *rx, size_t rx_len) {
    bus->stats.transactions++;
    if (result == HAL_OK) {
        bus->stats.ok++;
        bus->stats.tx_bytes += tx_len;
        bus->stats.rx_bytes += rx_len;
    } else {
        int index = sim_i2c_error_index(result);
        if (index >= 0) {
            bus->stats.errors[index]++;
        }
    }
    if (bus->records != NULL && (bus->record_ring || bus->record_count < bus->record_capacity)) {
        struct sim_i2c_record *r = &bus->records[bus->record_count % bus->record_capacity];
        r->start_us = start_us;
        r->duration_ns = duration_ns;
        r->addr7 = addr7;
        r->result = result;
        r->fault_mask = fault_mask;
        r->tx_len = (uint16_t)tx_len;
        r->rx_len = (uint16_t)rx_len;
        for (size_t i = 0; i < SIM_I2C_RECORD_BYTES; ++i) {
            r->tx[i] = (i < tx_len) ? tx[i] : 0u;
            r->rx[i] = (i < rx_len && result == HAL_OK) ? rx[i] : 0u;
        }
    }
    bus->record_count++;
    if (bus->log.ops != NULL) {
        const struct sim_i2c_transaction t = {start_us, duration_ns, addr7, result, fault_mask,
                                              tx,       tx_len,      rx,    rx_len};
        bus->log.ops->transaction(bus->log.ctx, &t);
    }
}

/* The targets acknowledging `addr7` now, in attach order; returns how many. */
static size_t find_targets(struct sim_i2c_bus *bus, uint8_t addr7, size_t *matched) {
    size_t count = 0u;
    for (size_t i = 0; i < bus->target_count; ++i) {
        const struct sim_i2c_target *t = &bus->targets[i];
        if ((t->address == NULL || *t->address == addr7) && t->ops->acks(t->ctx, addr7)) {
            matched[count++] = i;
        }
    }
    return count;
}

static void count_injection(struct sim_i2c_bus *bus, enum sim_fault_kind kind, uint64_t start_us,
                            uint32_t *fault_mask) {
    bus->stats.injected[kind]++;
    bus->stats.last_injected_us = start_us;
    *fault_mask |= 1u << kind;
}

static void fill_garbage(struct sim_i2c_bus *bus, uint8_t *rx, size_t rx_len) {
    uint32_t pattern = sim_prng_below(&bus->prng, 3u);
    for (size_t i = 0; i < rx_len; ++i) {
        if (pattern == 0u) {
            rx[i] = 0xFFu; /* nobody drives SDA: the pull-up reads as ones */
        } else if (pattern == 1u) {
            rx[i] = 0x00u;
        } else {
            rx[i] = (uint8_t)(sim_prng_next(&bus->prng) & 0xFFu);
        }
    }
}

/* Any fault kind with a non-zero probability? Read each time (not cached), so a test that
 * sets a probability directly in bus->faults is seen at once. */
static bool faults_on(const struct sim_i2c_bus *bus) {
    uint32_t any = 0u;
    for (unsigned k = 0; k < (unsigned)SIM_FAULT_COUNT; ++k) {
        any |= bus->faults.ppm[k];
    }
    return any != 0u;
}

static bool drawn(uint32_t hits, enum sim_fault_kind kind) {
    return (hits & (1u << kind)) != 0u;
}

/* The transfer reaches the matched targets (all of them drive the bus: open drain), then
 * the faults drawn for after delivery: garbage, a flipped result bit, a stuck DRDY line.
 * Inlined like its caller, so the fault-free path keeps no fault branch. */
static inline __attribute__((always_inline)) int
deliver(struct sim_i2c_bus *bus, uint64_t start_us, const size_t *matched, size_t count,
        const uint8_t *tx, size_t tx_len, uint8_t *rx, size_t rx_len, uint32_t hits,
        uint32_t *fault_mask, uint32_t *duration_ns) {
    int result;
    const struct sim_i2c_target *first = &bus->targets[matched[0]];
    result = first->ops->transfer(first->ctx, tx, tx_len, rx, rx_len);
    for (size_t m = 1; m < count && result == HAL_OK; ++m) {
        const struct sim_i2c_target *t = &bus->targets[matched[m]];
        uint8_t driven[SIM_I2C_MAX_TRANSFER];
        result = t->ops->transfer(t->ctx, tx, tx_len, driven, rx_len);
        for (size_t i = 0; i < rx_len; ++i) {
            rx[i] &= driven[i]; /* open-drain: a 0 from anyone wins */
        }
    }
    *duration_ns = wire_ns(bus, result == HAL_OK ? transfer_bits(tx_len, rx_len) : 20u);
    if (result == HAL_OK && rx_len > 0u && drawn(hits, SIM_FAULT_GARBAGE)) {
        fill_garbage(bus, rx, rx_len);
        count_injection(bus, SIM_FAULT_GARBAGE, start_us, fault_mask);
    }
    if (result == HAL_OK && rx_len > 0u && drawn(hits, SIM_FAULT_BITFLIP) &&
        first->ops->flip_result_bit(first->ctx, tx, tx_len, rx, rx_len,
                                    sim_prng_below(&bus->prng, 8u * SIM_I2C_MAX_TRANSFER))) {
        count_injection(bus, SIM_FAULT_BITFLIP, start_us, fault_mask);
    }
    if (drawn(hits, SIM_FAULT_DRDY_HIGH) && first->ops->inject(first->ctx, SIM_FAULT_DRDY_HIGH)) {
        count_injection(bus, SIM_FAULT_DRDY_HIGH, start_us, fault_mask);
    }
    if (drawn(hits, SIM_FAULT_DRDY_LOW) && first->ops->inject(first->ctx, SIM_FAULT_DRDY_LOW)) {
        count_injection(bus, SIM_FAULT_DRDY_LOW, start_us, fault_mask);
    }
    return result;
}

/* One transaction after the request checks, with `hits` the fault kinds drawn for it (bit
 * k: kind k). Inlined into its two callers, so the fault-free one (hits = 0) loses every
 * fault branch at compile time. */
static inline __attribute__((always_inline)) int
transaction(struct sim_i2c_bus *bus, uint64_t start_us, uint8_t addr7, const uint8_t *tx,
            size_t tx_len, uint8_t *rx, size_t rx_len, uint32_t timeout_us, uint32_t hits) {
    uint32_t fault_mask = 0u;
    uint32_t duration_ns;
    int result;
    if (drawn(hits, SIM_FAULT_STUCK) && !bus->sda_stuck) {
        bus->sda_stuck = true;
        count_injection(bus, SIM_FAULT_STUCK, start_us, &fault_mask);
    }
    if (bus->sda_stuck) {
        /* The master finds SDA low and waits for the bus to free up, in vain. */
        duration_ns = timeout_ns_of(timeout_us);
        spend(bus, duration_ns);
        note(bus, start_us, duration_ns, addr7, HAL_ERR_BUS_STUCK, fault_mask, tx, tx_len, rx, 0u);
        return HAL_ERR_BUS_STUCK;
    }

    size_t matched[SIM_I2C_MAX_TARGETS];
    size_t count = find_targets(bus, addr7, matched);
    if (count > 0u && drawn(hits, SIM_FAULT_RESET)) {
        const struct sim_i2c_target *t = &bus->targets[matched[0]];
        if (t->ops->inject(t->ctx, SIM_FAULT_RESET)) {
            count_injection(bus, SIM_FAULT_RESET, start_us, &fault_mask);
            count = find_targets(bus, addr7, matched);
        }
    }
    if (count > 0u && drawn(hits, SIM_FAULT_NACK) && bus->nack_remaining[matched[0]] == 0u) {
        bus->nack_remaining[matched[0]] =
            (uint8_t)(1u + sim_prng_below(&bus->prng, bus->faults.nack_burst_max));
        bus->nack_is_data[matched[0]] = (sim_prng_next(&bus->prng) & 1u) != 0u;
        count_injection(bus, SIM_FAULT_NACK, start_us, &fault_mask);
    }
    if (count == 0u) {
        duration_ns = wire_ns(bus, 11u); /* START, address + NACK, STOP */
        result = HAL_ERR_ADDR_NACK;
    } else if (bus->nack_remaining[matched[0]] > 0u) {
        bus->nack_remaining[matched[0]]--;
        if (bus->nack_is_data[matched[0]] && tx_len > 0u) {
            duration_ns = wire_ns(bus, 20u); /* ... first data byte NACKed, STOP */
            result = HAL_ERR_DATA_NACK;
        } else {
            duration_ns = wire_ns(bus, 11u);
            result = HAL_ERR_ADDR_NACK;
        }
    } else if (drawn(hits, SIM_FAULT_STRETCH)) {
        /* Address ACKed, then SCL held low past the master's timeout; nothing is applied. */
        count_injection(bus, SIM_FAULT_STRETCH, start_us, &fault_mask);
        duration_ns = wire_ns(bus, 10u) + timeout_ns_of(timeout_us) + wire_ns(bus, 1u);
        result = HAL_ERR_TIMEOUT;
    } else {
        result = deliver(bus, start_us, matched, count, tx, tx_len, rx, rx_len, hits, &fault_mask,
                         &duration_ns);
    }
    spend(bus, duration_ns);
    note(bus, start_us, duration_ns, addr7, result, fault_mask, tx, tx_len, rx,
         result == HAL_OK ? rx_len : 0u);
    return result;
}

static int sim_write_read(void *ctx, uint8_t addr7, const uint8_t *tx, size_t tx_len, uint8_t *rx,
                          size_t rx_len, uint32_t timeout_us) {
    struct sim_i2c_bus *bus = ctx;
    const uint64_t start_us = sim_clock_now(bus->clock);
    if ((tx_len == 0u && rx_len == 0u) || tx_len > SIM_I2C_MAX_TRANSFER ||
        rx_len > SIM_I2C_MAX_TRANSFER || (tx_len > 0u && tx == NULL) ||
        (rx_len > 0u && rx == NULL) || addr7 > 0x7Fu) {
        bus->stats.invalid_requests++;
        return HAL_ERR_INVALID;
    }
    /* With every probability 0 nothing can fire: no draws (the stream's position is then
     * unobservable; sim_i2c_set_faults() reseeds it) and no fault branches. */
    if (!faults_on(bus)) {
        return transaction(bus, start_us, addr7, tx, tx_len, rx, rx_len, timeout_us, 0u);
    }
    /* Draw every kind on every transaction, so one kind's setting never shifts another's. */
    uint32_t hits = 0u;
    for (unsigned k = 0; k < (unsigned)SIM_FAULT_COUNT; ++k) {
        if (sim_prng_chance_ppm(&bus->prng, bus->faults.ppm[k])) {
            hits |= 1u << k;
        }
    }
    return transaction(bus, start_us, addr7, tx, tx_len, rx, rx_len, timeout_us, hits);
}

static int sim_recover(void *ctx) {
    struct sim_i2c_bus *bus = ctx;
    bus->stats.recoveries++;
    /* Nine SCL pulses let a slave finish the byte it is shifting out and release SDA
     * (UM10204 §3.1.16 "Bus clear"), then a STOP. */
    bus->sda_stuck = false;
    spend(bus, wire_ns(bus, 10u));
    return HAL_OK;
}

const struct hal_i2c_ops sim_i2c_hal_ops = {
    .write_read = sim_write_read,
    .recover = sim_recover,
};

struct hal_i2c sim_i2c_hal(struct sim_i2c_bus *bus) {
    struct hal_i2c i2c = {&sim_i2c_hal_ops, bus};
    return i2c;
}
