/*
 * Polled I2C master on the STM32 "I2Cv2" peripheral (STM32L4 RM0351 §39,
 * STM32G0 RM0444 §32), implementing hal_i2c: one write-then-read primitive
 * with a repeated start, every wait bounded by the caller's time budget, and
 * bus recovery by bit-banging SCL on the same pins.
 *
 * One driver for both boards: the instance config carries the peripheral base
 * address, the TIMINGR value for its kernel clock, the SCL/SDA pins and the
 * time source. Register access goes through stm32_reg.h, so the host tests run
 * this exact code against a register-level fake.
 */
#ifndef BOARDS_STM32_I2C_H
#define BOARDS_STM32_I2C_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_i2c.h"
#include "hal/hal_time.h"

/* One bus line: GPIO port base, pin number and the alternate function that routes it to I2C. */
struct stm32_i2c_pin {
    uintptr_t port;
    uint8_t pin;
    uint8_t af;
};

/* Per-instance constant configuration. */
struct stm32_i2c_config {
    uintptr_t base;              /* I2Cx base address */
    uint32_t timingr;            /* I2C_TIMINGR for the bus speed at the kernel clock */
    uint32_t byte_time_us;       /* one byte + ACK at the bus speed, rounded up (400 kHz: 23) */
    uint32_t core_cycles_per_us; /* CPU clock in MHz: bounds polls if the time source stalls */
    uint32_t recovery_half_period_us; /* SCL half period while bit-banging recovery (5: 100 kHz) */
    struct stm32_i2c_pin scl;
    struct stm32_i2c_pin sda;
    struct hal_time time; /* monotonic time for every bounded wait */
};

/* Error counters, for telemetry (every failed transfer increments exactly one). */
struct stm32_i2c_stats {
    uint32_t transfers; /* write_read calls that reached the bus */
    uint32_t addr_nacks;
    uint32_t data_nacks;
    uint32_t arbitration_lost; /* ARLO */
    uint32_t bus_errors;       /* BERR seen and cleared (spurious in master mode: ES0250) */
    uint32_t busy;             /* BUSY already set before START */
    uint32_t stuck;            /* SDA or SCL low with the bus idle */
    uint32_t timeouts;
    uint32_t recoveries;
    uint32_t recoveries_failed;
};

/* One I2C bus: const config plus mutable counters. */
struct stm32_i2c {
    const struct stm32_i2c_config *cfg;
    struct stm32_i2c_stats stats;
};

/*
 * Bind `bus` to `cfg`, set SCL/SDA to open-drain alternate function with
 * pull-ups, program TIMINGR and enable the peripheral. The caller has enabled
 * the peripheral and GPIO clocks and selected the kernel clock. HAL_OK or
 * HAL_ERR_INVALID (NULL, no time source, zero timing fields, pin > 15).
 */
int stm32_i2c_init(struct stm32_i2c *bus, const struct stm32_i2c_config *cfg);

/*
 * hal_i2c write_read (contract in hal/hal_i2c.h): write tx, then (if rx_len)
 * repeated-start read; no STOP between. Budget: timeout_us plus
 * (tx_len + rx_len + 2) byte times. HAL_ERR_ADDR_NACK when the address was not
 * acknowledged (NACK before the first TXIS/RXNE), HAL_ERR_DATA_NACK when a
 * written byte was, HAL_ERR_BUS_BUSY for BUSY before START, arbitration loss
 * or a bus error, HAL_ERR_BUS_STUCK when SDA/SCL are low with the bus idle,
 * HAL_ERR_TIMEOUT when the budget runs out (the peripheral is then reset).
 */
int stm32_i2c_write_read(void *ctx, uint8_t addr7, const uint8_t *tx, size_t tx_len, uint8_t *rx,
                         size_t rx_len, uint32_t timeout_us);

/*
 * hal_i2c recover (UM10204 §3.1.16 "Bus clear"): disable the peripheral, drive
 * SCL/SDA as open-drain GPIO, clock SCL up to nine times until SDA is released,
 * generate a STOP, restore the alternate function and re-enable. HAL_OK when
 * both lines are high afterwards, HAL_ERR_BUS_STUCK otherwise.
 */
int stm32_i2c_recover(void *ctx);

extern const struct hal_i2c_ops stm32_i2c_hal_ops;

/* The hal_i2c handle of `bus`. */
struct hal_i2c stm32_i2c_hal(struct stm32_i2c *bus);

#endif /* BOARDS_STM32_I2C_H */
