/* VL53 driver, bottom layer: one call's time budget, its register transfers, device-state helpers.
 */
#include <stddef.h>

#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53_internal.h"

uint32_t vl53_call_budget_us(const struct vl53_config *cfg) {
    const uint32_t at_400 = or_default(cfg->call_budget_us, VL53_DEFAULT_CALL_BUDGET_US);
    const uint32_t hz = or_default(cfg->bus_hz, 400000u);
    if (hz >= 400000u) {
        return at_400;
    }
    const uint64_t scaled = ((uint64_t)at_400 * 400000u + hz - 1u) / hz;
    return scaled > UINT32_MAX / 2u ? UINT32_MAX / 2u : (uint32_t)scaled;
}

uint32_t vl53_call_transfer_timeout(const struct call *c) {
    uint32_t elapsed = hal_time_elapsed_us(now_us(c->dev), c->start_us);
    if (elapsed >= c->budget_us) {
        return 0u;
    }
    uint32_t left = c->budget_us - elapsed;
    uint32_t per_transfer = or_default(c->dev->cfg->i2c_timeout_us, VL53_DEFAULT_I2C_TIMEOUT_US);
    return left < per_transfer ? left : per_transfer;
}

int vl53_call_read(const struct call *c, uint8_t addr, uint16_t reg, uint8_t *data, size_t len) {
    uint32_t timeout = vl53_call_transfer_timeout(c);
    if (timeout == 0u) {
        return HAL_ERR_TIMEOUT;
    }
    return hal_i2c_reg16_read(&c->dev->cfg->i2c, addr, reg, data, len, timeout);
}

int vl53_call_write(const struct call *c, uint8_t addr, uint16_t reg, const uint8_t *data,
                    size_t len) {
    uint32_t timeout = vl53_call_transfer_timeout(c);
    if (timeout == 0u) {
        return HAL_ERR_TIMEOUT;
    }
    return hal_i2c_reg16_write(&c->dev->cfg->i2c, addr, reg, data, len, timeout);
}

int vl53_call_write_byte(const struct call *c, uint16_t reg, uint8_t value) {
    return vl53_call_write(c, c->dev->address, reg, &value, 1u);
}

int vl53_read_data_ready(const struct call *c, enum vl53_polarity polarity, bool *ready) {
    uint8_t status = 0u;
    int err = vl53_call_read(c, c->dev->address, VL53_REG_GPIO_TIO_HV_STATUS, &status, 1u);
    if (err != HAL_OK) {
        return err;
    }
    const bool level_high = (status & VL53_TIO_HV_STATUS_LEVEL_BIT) != 0u;
    const bool active_high = polarity == VL53_INT_ACTIVE_HIGH;
    *ready = level_high == active_high;
    return HAL_OK;
}

void vl53_forget_ranging(struct vl53_dev *dev) {
    dev->ranging = false;
    dev->vhv_running = false;
    dev->have_stream = false;
    dev->have_candidate = false;
}
