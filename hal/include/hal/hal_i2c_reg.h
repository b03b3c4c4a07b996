/*
 * Register access over hal_i2c for devices with 16-bit register indices and
 * explicit big-endian values, built only on the one write_read primitive.
 *
 * VL53L1X datasheet (DocID031281, §4 "Control interface"): every access starts
 * with a two-byte register index, most significant byte first; multi-byte
 * registers are big-endian and the index auto-increments across a burst.
 */
#ifndef HAL_I2C_REG_H
#define HAL_I2C_REG_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_err.h"
#include "hal/hal_i2c.h"

/* Most data bytes one hal_i2c_reg16_write() sends (the index is extra). */
#define HAL_I2C_REG16_MAX_WRITE 96u

/* Store `value` at dst[0..1], most significant byte first. */
static inline void hal_put_be16(uint8_t *dst, uint16_t value) {
    dst[0] = (uint8_t)(value >> 8);
    dst[1] = (uint8_t)(value & 0xFFu);
}

/* Store `value` at dst[0..3], most significant byte first. */
static inline void hal_put_be32(uint8_t *dst, uint32_t value) {
    dst[0] = (uint8_t)(value >> 24);
    dst[1] = (uint8_t)((value >> 16) & 0xFFu);
    dst[2] = (uint8_t)((value >> 8) & 0xFFu);
    dst[3] = (uint8_t)(value & 0xFFu);
}

/* The big-endian 16-bit value at src[0..1]. */
static inline uint16_t hal_get_be16(const uint8_t *src) {
    return (uint16_t)(((uint16_t)src[0] << 8) | (uint16_t)src[1]);
}

/* The big-endian 32-bit value at src[0..3]. */
static inline uint32_t hal_get_be32(const uint8_t *src) {
    return ((uint32_t)src[0] << 24) | ((uint32_t)src[1] << 16) | ((uint32_t)src[2] << 8) |
           (uint32_t)src[3];
}

/*
 * Read `len` (1..) bytes starting at 16-bit register `reg` of device `addr7`:
 * the index is written, then a repeated start reads. HAL_OK or the bus error
 * unchanged; HAL_ERR_INVALID for a NULL bus/buffer or len 0.
 */
static inline int hal_i2c_reg16_read(const struct hal_i2c *bus, uint8_t addr7, uint16_t reg,
                                     uint8_t *data, size_t len, uint32_t timeout_us) {
    if (bus == NULL || bus->ops == NULL || bus->ops->write_read == NULL || data == NULL ||
        len == 0u) {
        return HAL_ERR_INVALID;
    }
    uint8_t index[2];
    hal_put_be16(index, reg);
    return bus->ops->write_read(bus->ctx, addr7, index, sizeof index, data, len, timeout_us);
}

/*
 * Write `len` (1..HAL_I2C_REG16_MAX_WRITE) bytes starting at 16-bit register
 * `reg` of device `addr7` in one transfer. HAL_OK or the bus error unchanged;
 * HAL_ERR_INVALID for a NULL bus/data or a length out of range.
 */
static inline int hal_i2c_reg16_write(const struct hal_i2c *bus, uint8_t addr7, uint16_t reg,
                                      const uint8_t *data, size_t len, uint32_t timeout_us) {
    if (bus == NULL || bus->ops == NULL || bus->ops->write_read == NULL || data == NULL ||
        len == 0u || len > HAL_I2C_REG16_MAX_WRITE) {
        return HAL_ERR_INVALID;
    }
    uint8_t frame[2u + HAL_I2C_REG16_MAX_WRITE];
    hal_put_be16(frame, reg);
    for (size_t i = 0; i < len; ++i) {
        frame[2u + i] = data[i];
    }
    return bus->ops->write_read(bus->ctx, addr7, frame, 2u + len, NULL, 0u, timeout_us);
}

#endif /* HAL_I2C_REG_H */
