/* VL53L1X device model: the NVM-read registers, strict to ST's sequence ([NVMR]). */
/*
 * Each step is accepted only in the state ST's sequence leaves the part in before it (firmware
 * off, power force on and settled, NVM powered, clocked and in read mode, the READN pulse
 * long enough); any other access to these registers is NACKed and counted
 * (nvm_violations, protocol_errors), so a driver that leaves a step out cannot read an
 * identity by luck. What a real part does then is undocumented; NACKing is the model's
 * choice. Words other than the identity's read as 0.
 */
#include <stddef.h>

#include "hal/hal_err.h"
#include "sim/sim_vl53.h"
#include "sim_vl53_model.h"
#include "sim_vl53_regs.h"

bool sim_vl53_nvm_reg(uint16_t reg) {
    return reg == M_CLK_CTRL1 || (reg >= M_NVM_CTRL_FIRST && reg <= M_NVM_CTRL_LAST);
}

uint64_t sim_vl53_part_id(const struct sim_vl53 *dev) {
    return dev->cfg.part_id != 0u ? dev->cfg.part_id : SIM_VL53_DEFAULT_PART_ID(dev->cfg.sensor);
}

void sim_vl53_nvm_reset(struct sim_vl53 *dev) {
    const struct sim_vl53_nvm off = {0};
    dev->nvm = off;
}

static bool firmware_off(const struct sim_vl53 *dev) {
    return (dev->regs[M_FIRMWARE_ENABLE] & 0x01u) == 0u;
}

static int violation(struct sim_vl53 *dev) {
    dev->stats.nvm_violations++;
    dev->stats.protocol_errors++;
    return HAL_ERR_DATA_NACK;
}

/* NVM byte `at` (0..511): the identity at 0x1F8..0x1FF, 0 elsewhere. */
static uint8_t nvm_byte(const struct sim_vl53 *dev, unsigned at) {
    if (at < M_NVM_ID_FIRST_BYTE) {
        return 0u;
    }
    const unsigned shift = 8u * (7u - (at - M_NVM_ID_FIRST_BYTE));
    return (uint8_t)(sim_vl53_part_id(dev) >> shift);
}

/* Ready for a word: powered for M_NVM_POWER_UP_US, clocked, read mode, pulse width set. */
static bool nvm_ready(const struct sim_vl53 *dev) {
    const struct sim_vl53_nvm *n = &dev->nvm;
    return firmware_off(dev) && n->powered && n->clock && n->read_mode && n->pulse_set &&
           now(dev) >= n->pdn_us + M_NVM_POWER_UP_US;
}

static int write_readn(struct sim_vl53 *dev, uint8_t value) {
    struct sim_vl53_nvm *n = &dev->nvm;
    if (value == 0u) {
        if (!nvm_ready(dev)) {
            return violation(dev);
        }
        n->readn_low = true;
        n->readn_low_us = now(dev);
        n->data_valid = false;
        return HAL_OK;
    }
    if (!n->readn_low) {
        return HAL_OK; /* high again without a pulse: what ST's disable writes first */
    }
    n->readn_low = false;
    if (!nvm_ready(dev) || now(dev) < n->readn_low_us + M_NVM_TRIGGER_US) {
        return violation(dev); /* the pulse too short: no word latched */
    }
    for (unsigned i = 0; i < 4u; ++i) {
        n->data[i] = nvm_byte(dev, 4u * n->addr + i);
    }
    n->data_valid = true;
    dev->stats.nvm_words++;
    return HAL_OK;
}

/* The step `reg` = `value` of ST's sequence, when the part is in the state for it. */
static int write_step(struct sim_vl53 *dev, uint16_t reg, uint8_t value) {
    struct sim_vl53_nvm *n = &dev->nvm;
    const bool forced = (dev->regs[M_POWER_FORCE] & 0x01u) != 0u;
    switch (reg) {
    case M_NVM_PDN:
        if (value == 0u) {
            const uint64_t force_us = n->force_us;
            sim_vl53_nvm_reset(dev);
            n->force_us = force_us;
            return HAL_OK;
        }
        if (!firmware_off(dev) || !forced || now(dev) < n->force_us + M_FORCE_SETTLE_US) {
            return violation(dev);
        }
        n->powered = true;
        n->pdn_us = now(dev);
        return HAL_OK;
    case M_CLK_CTRL1:
        if (!firmware_off(dev) || !n->powered) {
            return violation(dev);
        }
        n->clock = value == M_CLK_NVM_ON;
        return HAL_OK;
    case M_NVM_MODE:
    case M_NVM_PULSE_MSB:
    case M_NVM_PULSE_LSB:
        if (!firmware_off(dev) || !n->powered || !n->clock ||
            now(dev) < n->pdn_us + M_NVM_POWER_UP_US) {
            return violation(dev);
        }
        n->read_mode = reg == M_NVM_MODE ? value == 0x01u : n->read_mode;
        n->pulse_set = n->pulse_set || reg != M_NVM_MODE;
        return HAL_OK;
    case M_NVM_ADDR:
        if (!nvm_ready(dev) || value >= M_NVM_WORDS) {
            return violation(dev);
        }
        n->addr = value;
        n->data_valid = false;
        return HAL_OK;
    case M_NVM_READN:
        return write_readn(dev, value);
    default:
        return violation(dev); /* DATAOUT and the rest: not written by the sequence */
    }
}

int sim_vl53_nvm_write(struct sim_vl53 *dev, uint16_t reg, uint8_t value) {
    if (dev->cfg.nvm_unreadable) {
        dev->stats.nvm_nacks++;
        return HAL_ERR_DATA_NACK;
    }
    const int rc = write_step(dev, reg, value);
    if (rc == HAL_OK && reg != M_CLK_CTRL1) {
        dev->nvm.ctrl[reg - M_NVM_CTRL_FIRST] = value;
    }
    return rc;
}

int sim_vl53_nvm_read(struct sim_vl53 *dev, uint16_t reg, uint8_t *value) {
    if (dev->cfg.nvm_unreadable) {
        dev->stats.nvm_nacks++;
        return HAL_ERR_DATA_NACK;
    }
    if (reg >= M_NVM_DATAOUT && reg < M_NVM_DATAOUT + 4u) {
        if (!dev->nvm.data_valid || !nvm_ready(dev)) {
            return violation(dev); /* no word latched, or the NVM or firmware state changed */
        }
        *value = dev->nvm.data[reg - M_NVM_DATAOUT];
        return HAL_OK;
    }
    if (reg == M_CLK_CTRL1) {
        *value = dev->nvm.clock ? M_CLK_NVM_ON : 0u;
        return HAL_OK;
    }
    *value = dev->nvm.ctrl[reg - M_NVM_CTRL_FIRST];
    return HAL_OK;
}

int sim_vl53_nvm_guard(struct sim_vl53 *dev, uint16_t reg, uint8_t value) {
    if (reg == M_POWER_FORCE && (value & 0x01u) != 0u && (dev->regs[M_POWER_FORCE] & 0x01u) == 0u) {
        dev->nvm.force_us = now(dev);
    }
    if (reg == M_FIRMWARE_ENABLE && (value & 0x01u) != 0u && dev->nvm.powered) {
        return violation(dev); /* firmware back on with the NVM still powered */
    }
    if (reg == M_POWER_FORCE && (value & 0x01u) == 0u && dev->nvm.powered) {
        return violation(dev); /* power force dropped under a powered NVM */
    }
    return HAL_OK;
}
