/* VL53 driver: configuration checks and binding, power, boot, identity and address. */
#include <stddef.h>

#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53/vl53.h"
#include "vl53_internal.h"

const char *vl53_config_check(const struct vl53_config *cfg) {
    if (cfg == NULL) {
        return "config";
    }
    if (cfg->i2c.ops == NULL || cfg->i2c.ops->write_read == NULL) {
        return "i2c";
    }
    if (cfg->time.ops == NULL || cfg->time.ops->now_us == NULL || cfg->time.ops->delay_us == NULL) {
        return "time";
    }
    /* 7-bit addresses 0x00-0x07 and 0x78-0x7F are reserved by the I²C specification. */
    if (cfg->address < 0x08u || cfg->address > 0x77u) {
        return "address";
    }
    bool pins_used = cfg->xshut_pin != VL53_PIN_NONE || cfg->gpio1_pin != VL53_PIN_NONE;
    if (pins_used &&
        (cfg->gpio.ops == NULL || cfg->gpio.ops->write == NULL || cfg->gpio.ops->read == NULL)) {
        return "gpio";
    }
    if (cfg->xshut_pin != VL53_PIN_NONE && cfg->xshut_pin == cfg->gpio1_pin) {
        return "gpio1_pin";
    }
    if (cfg->polarity != VL53_INT_ACTIVE_HIGH && cfg->polarity != VL53_INT_ACTIVE_LOW) {
        return "polarity";
    }
    if (vl53_timing_check(&cfg->timing) != HAL_OK) {
        return "timing";
    }
    if (!vl53_offsets_valid(&cfg->offsets)) {
        return "offsets";
    }
    return NULL;
}

int vl53_attach(struct vl53_dev *dev, const struct vl53_config *cfg) {
    if (dev == NULL || vl53_config_check(cfg) != NULL) {
        return HAL_ERR_INVALID;
    }
    dev->cfg = cfg;
    dev->timing = cfg->timing;
    dev->address = VL53_DEFAULT_ADDRESS;
    vl53_forget_ranging(dev);
    dev->last_stream = 0u;
    dev->candidate_stream = 0u;
    dev->candidate_us = now_us(dev);
    dev->power_up_us = now_us(dev);
    dev->ranging_start_us = dev->power_up_us;
    dev->last_result_us = dev->power_up_us;
    dev->data_deadline_us = dev->power_up_us;
    dev->next_register_poll_us = dev->power_up_us;
    dev->boot_state = 0u;
    dev->vhv_running = false;
    dev->vhv_start_us = dev->power_up_us;
    dev->offset_mismatch_reg = 0u;
    dev->part_id = 0u;
    return HAL_OK;
}

uint8_t vl53_current_address(const struct vl53_dev *dev) {
    return dev_ok(dev) ? dev->address : 0u;
}

int vl53_shutdown(struct vl53_dev *dev) {
    if (!dev_ok(dev) || dev->cfg->xshut_pin == VL53_PIN_NONE) {
        return HAL_ERR_INVALID;
    }
    int err = dev->cfg->gpio.ops->write(dev->cfg->gpio.ctx, dev->cfg->xshut_pin, false);
    if (err != HAL_OK) {
        return err;
    }
    /* XSHUT low resets the part: it will come back at the default address, stopped. */
    dev->address = VL53_DEFAULT_ADDRESS;
    vl53_forget_ranging(dev);
    return HAL_OK;
}

int vl53_power_up(struct vl53_dev *dev) {
    if (!dev_ok(dev) || dev->cfg->xshut_pin == VL53_PIN_NONE) {
        return HAL_ERR_INVALID;
    }
    int err = dev->cfg->gpio.ops->write(dev->cfg->gpio.ctx, dev->cfg->xshut_pin, true);
    if (err != HAL_OK) {
        return err;
    }
    dev->power_up_us = now_us(dev);
    dev->address = VL53_DEFAULT_ADDRESS;
    dev->part_id = 0u; /* read again after this boot */
    vl53_forget_ranging(dev);
    return HAL_OK;
}

int vl53_wait_boot(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    const uint32_t boot_window_us = VL53_BOOT_TIME_MAX_US + VL53_BOOT_SLACK_US;
    const uint32_t per_transfer = or_default(dev->cfg->i2c_timeout_us, VL53_DEFAULT_I2C_TIMEOUT_US);
    /* Bounded by count as well as by time: the loop ends even if time stood still. */
    const uint32_t max_polls = boot_window_us / VL53_BOOT_POLL_US + 2u;
    /* How long this call may wait, measured from its own start: to the end of the boot
     * window, or one poll once that is over. Not an absolute deadline: compared with the
     * wrapping clock, that would read as "not yet" once power-up lies more than half the
     * counter's range (36 min) back, and the clock could wrap in mid-call. */
    const uint32_t start = now_us(dev);
    const uint32_t since_power_up = hal_time_elapsed_us(start, dev->power_up_us);
    const uint32_t wait_us =
        since_power_up < boot_window_us ? boot_window_us - since_power_up : VL53_BOOT_POLL_US;
    bool answered = false;
    int last_err = HAL_ERR_TIMEOUT;
    for (uint32_t poll = 0; poll < max_polls; ++poll) {
        uint32_t elapsed = hal_time_elapsed_us(now_us(dev), start);
        uint32_t left = elapsed < wait_us ? wait_us - elapsed : VL53_BOOT_POLL_US;
        uint8_t state = 0u;
        int err = hal_i2c_reg16_read(&dev->cfg->i2c, dev->address, VL53_REG_FIRMWARE_SYSTEM_STATUS,
                                     &state, 1u, left < per_transfer ? left : per_transfer);
        if (err == HAL_OK) {
            answered = true;
            if (state != 0u) { /* 0x01 cold, 0x02/0x03 warm: booted either way ([I14]) */
                dev->boot_state = state;
                return HAL_OK;
            }
        }
        last_err = err;
        if (hal_time_elapsed_us(now_us(dev), start) + VL53_BOOT_POLL_US >= wait_us) {
            break;
        }
        delay_us(dev, VL53_BOOT_POLL_US);
    }
    if (last_err == HAL_OK || (answered && last_err == HAL_ERR_ADDR_NACK)) {
        return HAL_ERR_TIMEOUT; /* it answered, but never reported booted */
    }
    return last_err; /* ADDR_NACK throughout: nobody home; or a bus fault, unchanged */
}

bool vl53_warm_boot(const struct vl53_dev *dev) {
    return dev_ok(dev) && dev->boot_state != 0u && dev->boot_state != VL53_FIRMWARE_BOOTED_BIT;
}

static int read_model_id(const struct call *c, uint8_t addr, uint16_t *model_id) {
    uint8_t raw[2];
    int err = vl53_call_read(c, addr, VL53_REG_IDENTIFICATION_MODEL_ID, raw, sizeof raw);
    if (err != HAL_OK) {
        return err;
    }
    uint16_t id = hal_get_be16(raw);
    if (model_id != NULL) {
        *model_id = id;
    }
    return id == VL53_MODEL_ID_VL53L1X ? HAL_OK : HAL_ERR_ID_MISMATCH;
}

int vl53_identify(struct vl53_dev *dev, uint16_t *model_id) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    return read_model_id(&c, dev->address, model_id);
}

int vl53_set_address(struct vl53_dev *dev, uint8_t new_address) {
    if (!dev_ok(dev) || new_address < 0x08u || new_address > 0x77u) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    /* The register takes the 7-bit address ([I4]; [ULD] writes its 8-bit form >> 1). */
    int err = vl53_call_write_byte(&c, VL53_REG_I2C_SLAVE_DEVICE_ADDRESS, new_address);
    if (err != HAL_OK) {
        return err;
    }
    dev->address = new_address;
    return read_model_id(&c, new_address, NULL);
}
