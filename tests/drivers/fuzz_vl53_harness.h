/*
 * The driver fuzz harness (drivers/vl53 + drivers/vl53_array) without
 * libFuzzer: a fake hal_i2c whose every answer (ACK, NACK, bus error, how long
 * the transfer took, each byte read) comes from a byte source, a fake GPIO
 * likewise, and a fake clock that only transfers and delays advance. A run
 * reads a sensor configuration, then operations (array bring-up and recovery,
 * polls, every public driver call, sleeps) from the same source, and checks
 * after each call that it returned a hal_err code, that it ended within the
 * time bound its header promises, and the invariants of its result.
 *
 * The byte source is the fuzzer's input (fuzz_vl53.c) or, for the seed corpus,
 * a scripted device model that records what it answers (fuzz_seeds.c): both
 * drive exactly the same code, so a recorded seed replays identically.
 */
#ifndef FUZZ_VL53_HARNESS_H
#define FUZZ_VL53_HARNESS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* What a byte is asked for. */
enum fz_kind {
    FZ_CONFIG, /* configuration at the start of a run */
    FZ_OP,     /* the next operation (also: the run ends when the source is done here) */
    FZ_ARG,    /* an operation's argument */
    FZ_BUS,    /* a transfer's outcome and duration (see fz_bus_byte) */
    FZ_DATA,   /* one byte a read returns */
    FZ_GPIO,   /* a GPIO access's outcome (and level, for reads) */
};

/* The request behind an FZ_BUS / FZ_DATA / FZ_GPIO byte, for a scripted source. */
struct fz_request {
    uint64_t now_us; /* true (unwrapped) time of the harness clock */
    uint8_t addr7;
    const uint8_t *tx;
    size_t tx_len;
    size_t rx_len;
    size_t rx_index; /* FZ_DATA: which byte of the read */
    uint32_t timeout_us;
    bool recover; /* FZ_BUS: a bus recovery rather than a transfer */
    uint16_t pin; /* FZ_GPIO */
    bool gpio_write;
    bool gpio_level; /* written level */
};

struct fz_source {
    uint8_t (*next)(void *ctx, enum fz_kind kind, const struct fz_request *req);
    bool (*done)(void *ctx); /* asked before each operation */
    void *ctx;
};

/* FZ_BUS byte layout: bits 0-2 outcome, bit 3 variant, bits 4-7 duration (x/15 of the
 * timeout, on top of the wire time). Outcomes 0-3 OK, 4 ADDR_NACK, 5 DATA_NACK,
 * 6 TIMEOUT (the whole timeout), 7 BUS_BUSY (variant 0) or BUS_STUCK (variant 1).
 * For a recovery: bit 0 set = SDA stays low (BUS_STUCK). */
#define FZ_BUS_OK          0x00u
#define FZ_BUS_ADDR_NACK   0x04u
#define FZ_BUS_DATA_NACK   0x05u
#define FZ_BUS_TIMEOUT     0x06u
#define FZ_BUS_BUSY        0x07u
#define FZ_BUS_STUCK       0x0Fu
#define FZ_BUS_DURATION(x) ((uint8_t)((x) << 4))

/* FZ_GPIO byte: 0xFF fails the access (HAL_ERR_INVALID); for a read bit 0 is the level. */
#define FZ_GPIO_FAIL 0xFFu

/* Operations (FZ_OP byte modulo FZ_OP_COUNT). */
enum fz_op {
    FZ_OP_BRING_UP,
    FZ_OP_RECOVER_SENSOR, /* arg: index (may be out of range) */
    FZ_OP_RECOVER_BUS,
    FZ_OP_POLL,        /* arg: index */
    FZ_OP_SLEEP,       /* arg: (a & 63) << 5 * (a >> 6) µs: up to ~2 s */
    FZ_OP_DATA_READY,  /* arg: index */
    FZ_OP_SET_TIMING,  /* args: index, which setter, value */
    FZ_OP_START,       /* arg: index */
    FZ_OP_STOP,        /* arg: index */
    FZ_OP_READ_RESULT, /* arg: index */
    FZ_OP_CONFIGURE,   /* arg: index */
    FZ_OP_IDENTIFY,    /* arg: index */
    FZ_OP_SET_ADDRESS, /* args: index, address */
    FZ_OP_WAIT_BOOT,   /* arg: index */
    FZ_OP_CLEAR_IRQ,   /* arg: index */
    FZ_OP_GPIO1_READY, /* arg: index */
    FZ_OP_POWER,       /* args: index, up (bit 0) or down */
    FZ_OP_LONG_SLEEP,  /* 4 args: µs, little-endian (up to 71 minutes: the clock wraps) */
    FZ_OP_POLL_LOOP,   /* args: ticks, tick length (ms): poll every ranging sensor per tick */
    FZ_OP_COUNT,
};

/* Configuration bytes (FZ_CONFIG), in order:
 *   0: sensors - 1 (modulo 4)
 *   1-4: clock origin (µs, little-endian)
 *   5: flags: bit 0 GPIO1 wired, 1 verify_distance, 2 vendor block, 3 active-low,
 *      4 no bus recovery hook, 5 break the configuration (attach must refuse it)
 *   6: timing (index into the valid combinations)
 *   7-10: call budget, configure budget, I2C timeout, poll interval (table indices) */
#define FZ_CFG_GPIO1        0x01u
#define FZ_CFG_VERIFY       0x02u
#define FZ_CFG_VENDOR       0x04u
#define FZ_CFG_ACTIVE_LOW   0x08u
#define FZ_CFG_NO_RECOVER   0x10u
#define FZ_CFG_BAD_CONFIG   0x20u
#define FZ_CFG_BYTES        11u
#define FZ_FIRST_ADDRESS    0x30u /* sensor i moves to 0x30 + i */
#define FZ_XSHUT_PIN(i)     ((uint16_t)(i))
#define FZ_GPIO1_PIN(i)     ((uint16_t)(4u + (i)))
#define FZ_WIRE_NS_PER_BYTE 22500u /* 9 bits at 400 kHz */
#define FZ_RECOVER_US       25u    /* nine clocks and a STOP at 400 kHz */

/* Runs one scenario from `src`; aborts (FUZZ_CHECK) on a violated property. */
void fz_vl53_run(const struct fz_source *src);

#endif /* FUZZ_VL53_HARNESS_H */
