/* VL53 driver: the part's identity (lot, wafer, die X/Y) read from its NVM by ST's sequence. */
/*
 * The register facts, delays and word addressing are [NVM] in vl53_regs.h. The steps are a
 * table (register, value, wait after) walked by one loop: enable, disable and the READN
 * pulse alike; each of the two words takes its address, the pulse and a 4-byte read.
 */
#include <stddef.h>

#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53/vl53.h"
#include "vl53_internal.h"

struct nvm_step {
    uint16_t reg;
    uint8_t value;
    uint8_t wait_us; /* after the write */
};

/* VL53L1_nvm_enable's order: firmware off, power force, settle, NVM power and clock, NVM
 * power-up time, read mode, pulse width (MSB then LSB register: the 16-bit value). */
static const struct nvm_step nvm_on[] = {
    {VL53_REG_FIRMWARE_ENABLE, 0x00u, 0u},
    {VL53_REG_POWER_FORCE, 0x01u, VL53_POWER_FORCE_SETTLE_US},
    {VL53_REG_NVM_PDN, 0x01u, 0u},
    {VL53_REG_CLK_CTRL1, VL53_CLK_CTRL1_NVM_CLOCK, VL53_NVM_POWER_UP_US},
    {VL53_REG_NVM_MODE, 0x01u, 0u},
    {VL53_REG_NVM_PULSE_WIDTH_MSB, VL53_NVM_PULSE_WIDTH_MSB, 0u},
    {VL53_REG_NVM_PULSE_WIDTH_MSB + 1u, VL53_NVM_PULSE_WIDTH_LSB, 0u},
};

/* VL53L1_nvm_disable's: READN high, NVM powered down, power force off, firmware on. */
static const struct nvm_step nvm_off[] = {
    {VL53_REG_NVM_READN, 0x01u, 0u},
    {VL53_REG_NVM_PDN, 0x00u, 0u},
    {VL53_REG_POWER_FORCE, 0x00u, 0u},
    {VL53_REG_FIRMWARE_ENABLE, 0x01u, 0u},
};

static int run_steps(const struct call *c, const struct nvm_step *steps, size_t count) {
    for (size_t i = 0; i < count; ++i) {
        const int err = vl53_call_write_byte(c, steps[i].reg, steps[i].value);
        if (err != HAL_OK) {
            return err;
        }
        if (steps[i].wait_us != 0u) {
            delay_us(c->dev, steps[i].wait_us);
        }
    }
    return HAL_OK;
}

/* The READN pulse that latches the word at NVM_CTRL__ADDR into DATAOUT. */
static const struct nvm_step nvm_pulse[] = {
    {VL53_REG_NVM_READN, 0x00u, VL53_NVM_READ_TRIGGER_US},
    {VL53_REG_NVM_READN, 0x01u, 0u},
};

int vl53_read_part_id(struct vl53_dev *dev, uint64_t *part_id) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    if (dev->ranging || dev->vhv_running) {
        return HAL_ERR_STATE;
    }
    dev->part_id = 0u;
    uint8_t raw[4u * VL53_NVM_ID_WORDS];
    struct call c = call_begin(dev, call_budget(dev));
    int err = run_steps(&c, nvm_on, sizeof nvm_on / sizeof nvm_on[0]);
    for (uint8_t w = 0; w < VL53_NVM_ID_WORDS && err == HAL_OK; ++w) {
        /* one 32-bit word, in a budget of its own (the whole read is ~19 transfers: ~9 ms
         * at 100 kHz): its address, the pulse, DATAOUT (NVM byte 4·word first) */
        c = call_begin(dev, call_budget(dev));
        err = vl53_call_write_byte(&c, VL53_REG_NVM_ADDR, (uint8_t)(VL53_NVM_ID_FIRST_WORD + w));
        if (err == HAL_OK) {
            err = run_steps(&c, nvm_pulse, sizeof nvm_pulse / sizeof nvm_pulse[0]);
        }
        if (err == HAL_OK) {
            err = vl53_call_read(&c, dev->address, VL53_REG_NVM_DATAOUT, &raw[(size_t)w * 4u], 4u);
        }
    }
    /* Never leave the part with its firmware off: the restore runs whatever happened, with
     * a budget of its own (the first error is the one returned). */
    struct call restore = call_begin(dev, call_budget(dev));
    const int off = run_steps(&restore, nvm_off, sizeof nvm_off / sizeof nvm_off[0]);
    err = err != HAL_OK ? err : off;
    if (err != HAL_OK) {
        return err;
    }
    const uint64_t id = (uint64_t)hal_get_be32(&raw[0]) << 32 | hal_get_be32(&raw[4]);
    dev->part_id = id;
    if (part_id != NULL) {
        *part_id = id;
    }
    return HAL_OK;
}

uint64_t vl53_part_id(const struct vl53_dev *dev) {
    return dev_ok(dev) ? dev->part_id : 0u;
}
