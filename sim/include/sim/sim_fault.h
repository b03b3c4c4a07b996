/*
 * Fault injection settings for the simulated I²C bus: one probability per fault
 * kind, drawn independently for every transaction from the bus's seeded PRNG.
 * Integer only (parts per million) so the same settings work on every core;
 * sim_fault_parse() reads the host_sim `--faults` text without floating point.
 */
#ifndef SIM_FAULT_H
#define SIM_FAULT_H

#include <stddef.h>
#include <stdint.h>

enum sim_fault_kind {
    SIM_FAULT_NACK,      /* the addressed device NACKs a burst of 1..nack_burst_max transfers */
    SIM_FAULT_STRETCH,   /* the device stretches SCL past the transfer's timeout */
    SIM_FAULT_RESET,     /* the addressed device resets: reboots at 0x29, ranging stopped */
    SIM_FAULT_DRDY_HIGH, /* its data-ready line (GPIO1 and TIO status bit 0) sticks high */
    SIM_FAULT_DRDY_LOW,  /* ... sticks low; both last until the device resets */
    SIM_FAULT_GARBAGE,   /* a read returns garbage (random bytes, all 0x00 or all 0xFF) */
    SIM_FAULT_BITFLIP,   /* one bit flips in the result-block bytes of a read */
    SIM_FAULT_STUCK,     /* a device holds SDA low: every transfer fails until bus recovery */
    SIM_FAULT_COUNT
};

#define SIM_PPM_ONE                      1000000u
#define SIM_FAULT_DEFAULT_NACK_BURST_MAX 3u

struct sim_fault_config {
    uint32_t ppm[SIM_FAULT_COUNT]; /* probability per transaction, parts per million */
    uint32_t seed;                 /* PRNG seed for the draws */
    uint8_t nack_burst_max;        /* NACK burst length is 1..this (0: default 3) */
};

/* Short name used in specs and reports ("nack", "drdy_high", ...); "?" if out of range. */
const char *sim_fault_name(enum sim_fault_kind kind);

/* The kind named by the first `len` chars of `name`, or -1. */
int sim_fault_kind_from_name(const char *name, size_t len);

/*
 * Parse "kind=probability[,kind=probability...]" (probability a decimal in [0, 1] with at
 * most 6 decimals, e.g. "nack=0.01,reset=0.0005") into out->ppm (other kinds set to 0;
 * seed and burst length untouched). Returns 0, or -1 with *error_at (if not NULL) set to
 * the offset of the offending character and *error_what to a short reason.
 */
int sim_fault_parse(const char *spec, struct sim_fault_config *out, size_t *error_at,
                    const char **error_what);

#endif /* SIM_FAULT_H */
