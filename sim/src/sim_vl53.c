/*
 * VL53L1X-class device model. What it counts as protocol errors: a register index of one
 * byte, an index outside 0x0000..0x01FF (but the NVM-read registers, sim_vl53_nvm.c), a write
 * before boot completed, a mode start value
 * other than 0x00/0x40. A real part would do something undocumented in these cases; the
 * model counts them so tests can insist on zero. A start without ST's configuration is no
 * protocol error but what a part does with it: nothing (see sim_vl53_refusal), or, without
 * the VHV step, results with raw status 3 (no VHV value found).
 */
#include "sim/sim_vl53.h"

#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"
#include "sim_vl53_model.h"
#include "sim_vl53_regs.h"

#define DEFAULT_BOOT_US        1000u
#define DEFAULT_BOOT_SILENT_US 300u
#define DEFAULT_OSC_CALIBRATE  500u
#define DEFAULT_AMBIENT_RAW    64u /* 0.5 MCPS in 9.7 */
#define RESULT_BLOCK_LAST      (M_RESULT_FIRST + M_RESULT_LEN - 1u)

static void reset_registers(struct sim_vl53 *dev) {
    for (size_t i = 0; i < SIM_VL53_REG_SPACE; ++i) {
        dev->regs[i] = 0u;
    }
    put_be16_at(dev->regs, M_MODEL_ID, dev->cfg.model_id);
    put_be16_at(dev->regs, M_OSC_CALIBRATE, dev->cfg.osc_calibrate);
    /* The offsets from the part's NVM, as its firmware copies them at boot ([NVM]). */
    const uint16_t p2p = (uint16_t)dev->cfg.nvm_part_to_part_qmm;
    put_be16_at(dev->regs, M_PART_TO_PART_OFFSET, p2p);
    dev->regs[M_PART_TO_PART_OFFSET] &= M_PART_TO_PART_HI_MASK;
    put_be16_at(dev->regs, M_INNER_OFFSET, (uint16_t)dev->cfg.nvm_inner_offset_mm);
    put_be16_at(dev->regs, M_OUTER_OFFSET, (uint16_t)dev->cfg.nvm_outer_offset_mm);
    dev->regs[M_FIRMWARE_ENABLE] = M_FIRMWARE_ENABLE_RESET; /* [NVMR]: on after boot */
    sim_vl53_nvm_reset(dev);
}

static void power_up(struct sim_vl53 *dev) {
    reset_registers(dev);
    dev->powered = true;
    dev->booted = false;
    dev->power_up_us = now(dev);
    dev->address = M_ADDRESS_DEFAULT;
    dev->index = 0u;
    dev->ranging = false;
    dev->stream_started = false;
    dev->stream_count = 0u;
    dev->irq_pending = false;
    dev->drdy = SIM_VL53_DRDY_FREE;
    for (size_t i = 0; i < sizeof dev->block_written; ++i) {
        dev->block_written[i] = 0u;
    }
    dev->vhv_stage = 0u;
    dev->vhv_bound_ok = false;
    dev->vhv_init_ok = false;
    dev->temp_update = 0u;
    dev->started_since_boot = false;
    dev->refusal = SIM_VL53_RANGES;
    dev->forced_left = 0u;
    dev->stats.power_ups++;
}

static void power_down(struct sim_vl53 *dev) {
    dev->powered = false;
    dev->booted = false;
    dev->ranging = false;
    dev->irq_pending = false;
    dev->drdy = SIM_VL53_DRDY_FREE;
}

/* The VHV step's last writes ([ULD] SensorInit), after the VHV range and the stop. */
static void vhv_write(struct sim_vl53 *dev, uint16_t reg, uint8_t value) {
    if (dev->vhv_stage != 2u) {
        return;
    }
    if (reg == M_VHV_LOOP_BOUND) {
        dev->vhv_bound_ok = value == M_VHV_BOUND_TWO;
    } else {
        dev->vhv_init_ok = value == M_VHV_INIT_PREV;
    }
    if (dev->vhv_bound_ok && dev->vhv_init_ok) {
        dev->vhv_stage = 3u;
        if (dev->temp_update == 3u) {
            dev->temp_update = 0u;
            dev->stats.temperature_updates++;
        }
    }
}

/* [ULD] StartTemperatureUpdate's first writes, on a calibrated part that is not ranging:
 * 0x0008 = 0x81 (full VHV), then 0x000B = 0x92; anything else there is SensorInit's. */
static void temp_update_write(struct sim_vl53 *dev, uint16_t reg, uint8_t value) {
    if (dev->vhv_stage != 3u) {
        return;
    }
    if (reg == M_VHV_LOOP_BOUND && value == M_VHV_BOUND_FULL) {
        if (dev->ranging) {
            dev->stats.protocol_errors++; /* ST's update starts from a stopped part */
        }
        dev->temp_update = 1u;
    } else if (reg == M_VHV_INIT && value == M_VHV_INIT_FULL && dev->temp_update == 1u) {
        dev->temp_update = 2u;
    } else {
        dev->temp_update = 0u;
    }
}

/* A start after the update's writes: the next range is a VHV range again, and the part
 * ranges uncalibrated (raw 3) until the update's last writes. */
static void temp_update_start(struct sim_vl53 *dev) {
    if (dev->temp_update == 2u) {
        dev->temp_update = 3u;
        dev->vhv_stage = 0u;
        dev->vhv_bound_ok = false;
        dev->vhv_init_ok = false;
    } else if (dev->temp_update == 1u) {
        dev->stats.protocol_errors++; /* 0x000B = 0x92 missing */
        dev->temp_update = 0u;
    }
}

static bool is_read_only(uint16_t reg) {
    return reg == M_GPIO_TIO_STATUS || (reg >= M_RESULT_FIRST && reg <= RESULT_BLOCK_LAST) ||
           reg == M_OSC_CALIBRATE || reg == M_OSC_CALIBRATE + 1u || reg == M_FIRMWARE_STATUS ||
           reg == M_MODEL_ID || reg == M_MODEL_ID + 1u;
}

/* HAL_OK, or HAL_ERR_DATA_NACK: the part refuses the byte (the NVM-read registers). */
static int write_register(struct sim_vl53 *dev, uint16_t reg, uint8_t value, uint8_t *new_address) {
    if (sim_vl53_nvm_reg(reg)) {
        return sim_vl53_nvm_write(dev, reg, value);
    }
    if (reg >= SIM_VL53_REG_SPACE) {
        dev->stats.protocol_errors++;
        return HAL_OK;
    }
    if (sim_vl53_nvm_guard(dev, reg, value) != HAL_OK) {
        return HAL_ERR_DATA_NACK;
    }
    if (reg >= M_BLOCK_FIRST && reg <= M_BLOCK_LAST) {
        /* 0x31 is read-only, yet ST's block writes it: written all the same */
        const unsigned k = (unsigned)(reg - M_BLOCK_FIRST);
        dev->block_written[k / 8u] = (uint8_t)(dev->block_written[k / 8u] | (1u << (k % 8u)));
    }
    if (is_read_only(reg)) {
        dev->stats.readonly_writes++;
        return HAL_OK;
    }
    if (reg >= M_PART_TO_PART_OFFSET && reg <= M_OFFSET_LAST && dev->cfg.ignores_offset_writes) {
        return HAL_OK; /* the defect: ACKed, kept what NVM loaded */
    }
    switch (reg) {
    case M_PART_TO_PART_OFFSET:
        dev->regs[reg] = (uint8_t)(value & M_PART_TO_PART_HI_MASK); /* bits 15:13 not kept */
        break;
    case M_VHV_LOOP_BOUND:
    case M_VHV_INIT:
        dev->regs[reg] = value;
        temp_update_write(dev, reg, value);
        vhv_write(dev, reg, value);
        break;
    case M_I2C_SLAVE_ADDR:
        dev->regs[reg] = value;
        if (!dev->cfg.ignores_address_change) {
            *new_address = (uint8_t)(value & 0x7Fu); /* takes effect after this transfer */
        }
        break;
    case M_INTERRUPT_CLEAR:
        if ((value & 0x01u) != 0u) {
            dev->irq_pending = false;
            dev->stats.clears++;
        }
        break;
    case M_MODE_START:
        dev->regs[reg] = value;
        if (value == M_START_TIMED) {
            temp_update_start(dev);
            sim_vl53_start_ranging(dev);
        } else if (value == M_STOP) {
            if (dev->ranging) {
                dev->stats.stops++;
            }
            dev->ranging = false;
            if (dev->vhv_stage == 1u) {
                dev->vhv_stage = 2u; /* stopped after the VHV range */
            }
        } else {
            dev->stats.protocol_errors++;
        }
        break;
    default:
        dev->regs[reg] = value;
        break;
    }
    return HAL_OK;
}

static bool drdy_level(const struct sim_vl53 *dev) {
    if (dev->drdy == SIM_VL53_DRDY_STUCK_HIGH) {
        return true;
    }
    if (dev->drdy == SIM_VL53_DRDY_STUCK_LOW) {
        return false;
    }
    bool active_low = (dev->regs[M_GPIO_HV_MUX_CTRL] & M_MUX_ACTIVE_LOW) != 0u;
    return active_low ? !dev->irq_pending : dev->irq_pending;
}

static uint8_t read_register(const struct sim_vl53 *dev, uint16_t reg) {
    if (reg == M_GPIO_TIO_STATUS) {
        return drdy_level(dev) ? 0x01u : 0u;
    }
    if (reg == M_FIRMWARE_STATUS) {
        /* 0 while booting, 0x01 after boot ([ULD] BootState). Once started since power-up,
         * 0x03 ranging / 0x02 stopped: the values a field report gives for a part that kept
         * power across an MCU reset; which bit means what is the model's assumption. */
        if (!dev->booted) {
            return 0u;
        }
        if (!dev->started_since_boot) {
            return 0x01u;
        }
        return dev->ranging ? 0x03u : 0x02u;
    }
    return dev->regs[reg];
}

void sim_vl53_force_results(struct sim_vl53 *dev, uint8_t raw, uint16_t mm, uint32_t count) {
    dev->forced_raw = (uint8_t)(raw & 0x1Fu);
    dev->forced_mm = mm;
    dev->forced_left = count;
}

uint8_t sim_vl53_peek(struct sim_vl53 *dev, uint16_t reg) {
    sim_vl53_update(dev);
    return reg < SIM_VL53_REG_SPACE ? read_register(dev, reg) : 0u;
}

static bool target_acks(void *ctx, uint8_t addr7) {
    struct sim_vl53 *dev = ctx;
    if (dev->address != addr7) {
        return false; /* asked for every device on every transfer; catching up (below) never
                         changes the address, so it can wait for the device's own turn */
    }
    sim_vl53_update(dev);
    return dev->powered && now(dev) >= dev->power_up_us + dev->cfg.boot_silent_us;
}

static int target_transfer(void *ctx, const uint8_t *tx, size_t tx_len, uint8_t *rx,
                           size_t rx_len) {
    struct sim_vl53 *dev = ctx;
    sim_vl53_update(dev);
    uint8_t new_address = dev->address;
    int result = HAL_OK;
    if (tx_len == 1u) {
        dev->stats.protocol_errors++; /* half a register index */
    } else if (tx_len >= 2u) {
        dev->index = (uint16_t)(((uint16_t)tx[0] << 8) | tx[1]);
        if (tx_len > 2u && !dev->booted) {
            dev->stats.protocol_errors++; /* written before the firmware booted: ignored */
            dev->index = (uint16_t)(dev->index + (tx_len - 2u));
        } else {
            for (size_t i = 2; i < tx_len && result == HAL_OK; ++i) {
                result = write_register(dev, dev->index, tx[i], &new_address);
                dev->index++;
            }
        }
    }
    if (result != HAL_OK) {
        rx_len = 0u; /* NACKed: the master stops there and reads nothing */
    }
    const size_t first = dev->index;
    if (first + rx_len <= SIM_VL53_REG_SPACE &&
        !(first <= M_GPIO_TIO_STATUS && M_GPIO_TIO_STATUS < first + rx_len) &&
        !(first <= M_FIRMWARE_STATUS && M_FIRMWARE_STATUS < first + rx_len)) {
        /* Plain registers only (the result block, what a replay reads): what the loop
         * below gives, as one copy. */
        if (rx_len > 0u) {
            memcpy(rx, &dev->regs[first], rx_len);
        }
        dev->index = (uint16_t)(first + rx_len);
    } else {
        for (size_t i = 0; i < rx_len && result == HAL_OK; ++i) {
            if (sim_vl53_nvm_reg(dev->index)) {
                result = sim_vl53_nvm_read(dev, dev->index, &rx[i]);
            } else if (dev->index >= SIM_VL53_REG_SPACE) {
                dev->stats.protocol_errors++;
                rx[i] = 0u;
            } else {
                rx[i] = read_register(dev, dev->index);
            }
            dev->index++;
        }
    }
    if (new_address != dev->address) {
        dev->address = new_address;
        dev->stats.address_changes++;
    }
    if (tx_len > 2u) {
        sim_vl53_reschedule(dev); /* a write may have started ranging */
    }
    return result;
}

bool sim_vl53_inject(struct sim_vl53 *dev, enum sim_fault_kind kind) {
    sim_vl53_update(dev);
    if (!dev->powered) {
        return false;
    }
    switch (kind) {
    case SIM_FAULT_RESET:
        /* A brown-out or latch-up style reset: the part reboots at 0x29, stopped. */
        power_up(dev);
        dev->stats.injected_resets++;
        sim_vl53_reschedule(dev);
        return true;
    case SIM_FAULT_DRDY_HIGH:
        dev->drdy = SIM_VL53_DRDY_STUCK_HIGH;
        return true;
    case SIM_FAULT_DRDY_LOW:
        dev->drdy = SIM_VL53_DRDY_STUCK_LOW;
        return true;
    default:
        return false;
    }
}

static bool target_inject(void *ctx, enum sim_fault_kind kind) {
    return sim_vl53_inject(ctx, kind);
}

static bool target_flip_result_bit(void *ctx, const uint8_t *tx, size_t tx_len, uint8_t *rx,
                                   size_t rx_len, uint32_t bit_choice) {
    const struct sim_vl53 *dev = ctx;
    (void)tx;
    (void)tx_len;
    /* The transfer has run: the bytes read came from index - rx_len onwards. */
    uint16_t first = (uint16_t)(dev->index - rx_len);
    uint32_t eligible = 0u;
    for (size_t i = 0; i < rx_len; ++i) {
        uint16_t reg = (uint16_t)(first + i);
        if (reg >= M_RESULT_FIRST && reg <= RESULT_BLOCK_LAST) {
            eligible++;
        }
    }
    if (eligible == 0u) {
        return false;
    }
    uint32_t pick = bit_choice % (eligible * 8u);
    for (size_t i = 0; i < rx_len; ++i) {
        uint16_t reg = (uint16_t)(first + i);
        if (reg >= M_RESULT_FIRST && reg <= RESULT_BLOCK_LAST) {
            if (pick < 8u) {
                rx[i] ^= (uint8_t)(1u << pick);
                return true;
            }
            pick -= 8u;
        }
    }
    return false;
}

static const struct sim_i2c_target_ops vl53_target_ops = {
    .acks = target_acks,
    .transfer = target_transfer,
    .inject = target_inject,
    .flip_result_bit = target_flip_result_bit,
};

struct sim_i2c_target sim_vl53_target(struct sim_vl53 *dev) {
    /* target_acks is false, and does nothing, for any address but dev->address. */
    struct sim_i2c_target target = {&vl53_target_ops, dev, &dev->address};
    return target;
}

void sim_vl53_set_xshut(struct sim_vl53 *dev, bool high) {
    if (!dev->cfg.xshut_wired) {
        return;
    }
    sim_vl53_update(dev);
    if (high && !dev->powered) {
        power_up(dev);
    } else if (!high && dev->powered) {
        power_down(dev);
    }
    sim_vl53_reschedule(dev);
}

bool sim_vl53_gpio1_level(struct sim_vl53 *dev) {
    sim_vl53_update(dev);
    return dev->powered ? drdy_level(dev) : true;
}

static void gpio_drive_xshut(void *ctx, bool high) {
    sim_vl53_set_xshut(ctx, high);
}

static bool gpio_sample_gpio1(void *ctx) {
    return sim_vl53_gpio1_level(ctx);
}

int sim_vl53_wire(struct sim_vl53 *dev, struct sim_gpio *gpio, uint16_t xshut_pin,
                  uint16_t gpio1_pin) {
    if (xshut_pin < SIM_GPIO_PINS) {
        if (sim_gpio_wire(gpio, xshut_pin, gpio_drive_xshut, NULL, dev) != 0) {
            return -1;
        }
        gpio->pins[xshut_pin].level = dev->powered;
    }
    if (gpio1_pin < SIM_GPIO_PINS &&
        sim_gpio_wire(gpio, gpio1_pin, NULL, gpio_sample_gpio1, dev) != 0) {
        return -1;
    }
    return 0;
}

static uint64_t clock_advanced(void *ctx) {
    struct sim_vl53 *dev = ctx;
    sim_vl53_update(dev);
    return dev->next_event_us;
}

void sim_vl53_init(struct sim_vl53 *dev, const struct sim_vl53_config *cfg, struct sim_clock *clock,
                   const struct sim_range_source *source) {
    dev->cfg = *cfg;
    if (dev->cfg.boot_us == 0u) {
        dev->cfg.boot_us = DEFAULT_BOOT_US;
    }
    if (dev->cfg.boot_silent_us == 0u) {
        dev->cfg.boot_silent_us = DEFAULT_BOOT_SILENT_US;
    }
    if (dev->cfg.osc_calibrate == 0u) {
        dev->cfg.osc_calibrate = DEFAULT_OSC_CALIBRATE;
    }
    if (dev->cfg.model_id == 0u) {
        dev->cfg.model_id = M_MODEL_ID_VL53L1X;
    }
    if (dev->cfg.ambient_raw == 0u) {
        dev->cfg.ambient_raw = DEFAULT_AMBIENT_RAW;
    }
    dev->clock = clock;
    dev->source.ops = source != NULL ? source->ops : NULL;
    dev->source.ctx = source != NULL ? source->ctx : NULL;
    struct sim_vl53_stats zero_stats = {0};
    dev->stats = zero_stats;
    struct sim_vl53_published none = {0};
    dev->published[0] = none;
    dev->published[1] = none;
    dev->next_sample_index = 0u;
    dev->source_done = false;
    dev->source_error = 0;
    dev->budget_us = 0u;
    dev->period_us = 1u;
    dev->completed = 0u;
    dev->range_start_us = 0u;
    power_down(dev);
    dev->address = M_ADDRESS_DEFAULT;
    dev->index = 0u;
    dev->stream_started = false;
    dev->stream_count = 0u;
    dev->power_up_us = 0u;
    reset_registers(dev);
    if (!dev->cfg.xshut_wired || dev->cfg.powered_at_start) {
        power_up(dev);
    }
    dev->next_event_us = sim_vl53_next_event_us(dev);
    /* Run with the clock, so measurements complete (and GPIO1 rises) during delays too. */
    (void)sim_clock_listen(clock, clock_advanced, dev);
}
