/*
 * Byte stream interface (the telemetry UART): non-blocking in both directions.
 */
#ifndef HAL_SERIAL_H
#define HAL_SERIAL_H

#include <stddef.h>
#include <stdint.h>

struct hal_serial_ops {
    /* Queue up to `len` bytes for transmission; returns how many were accepted (a full
     * transmit buffer accepts fewer: the caller counts the loss, nothing blocks). */
    size_t (*write)(void *ctx, const uint8_t *data, size_t len);
    /* Copy up to `max` received bytes into `buf`; returns how many (0: none pending). */
    size_t (*read)(void *ctx, uint8_t *buf, size_t max);
    /* Received bytes lost so far (a receiver overrun, a full receive buffer), cumulative;
     * NULL: the port counts none. */
    uint32_t (*rx_lost)(void *ctx);
};

struct hal_serial {
    const struct hal_serial_ops *ops; /* NULL: no serial link */
    void *ctx;
};

#endif /* HAL_SERIAL_H */
