/*
 * I²C initiator interface: a const ops struct plus a context pointer, built on
 * one primitive (write, then repeated-start read) with a time budget, the
 * shape of Pigweed's pw_i2c Initiator. 7-bit addresses only.
 */
#ifndef HAL_I2C_H
#define HAL_I2C_H

#include <stddef.h>
#include <stdint.h>

struct hal_i2c_ops {
    /*
     * Write `tx_len` bytes to `addr7`, then (if rx_len > 0) a repeated start and
     * read `rx_len` bytes; either length may be 0 (not both). Returns HAL_OK or
     * HAL_ERR_ADDR_NACK / DATA_NACK / BUS_BUSY / TIMEOUT / BUS_STUCK, never
     * taking longer than `timeout_us` plus the transfer time.
     */
    int (*write_read)(void *ctx, uint8_t addr7, const uint8_t *tx, size_t tx_len, uint8_t *rx,
                      size_t rx_len, uint32_t timeout_us);
    /* Bus recovery: nine SCL clocks with SDA released, then a STOP. HAL_OK if SDA is high after. */
    int (*recover)(void *ctx);
};

struct hal_i2c {
    const struct hal_i2c_ops *ops;
    void *ctx;
};

#endif /* HAL_I2C_H */
