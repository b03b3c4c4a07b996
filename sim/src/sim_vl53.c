/*
 * VL53L1X-class device model. What it checks (protocol_errors): a register index of
 * one byte, an index outside 0x0000..0x01FF, a write before boot completed, a mode
 * start value other than 0x00/0x40, and starting with an incomplete or inconsistent
 * distance-mode / timing-budget configuration. A real part would do something
 * undocumented in these cases; the model counts them so tests can insist on zero.
 */
#include "sim/sim_vl53.h"

#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"
#include "vl53/vl53_regs.h"

#define DEFAULT_BOOT_US        1000u
#define DEFAULT_BOOT_SILENT_US 300u
#define DEFAULT_OSC_CALIBRATE  500u
#define DEFAULT_AMBIENT_RAW    64u     /* 0.5 MCPS in 9.7 */
#define MODEL_SPADS_8_8        0x2000u /* 32 effective SPADs: a plausible value, not a fact */
#define MODEL_SIGMA            0x0020u
#define RESULT_BLOCK_LAST      (VL53_REG_RESULT_RANGE_STATUS + VL53_RESULT_BLOCK_LEN - 1u)

/* The timing-budget register pairs a start accepts, per distance mode: an independent
 * transcription of [ULD] VL53L1X_SetTimingBudgetInMs / GetTimingBudgetInMs. */
struct budget_code {
    uint16_t macrop_a;
    uint16_t macrop_b;
    uint16_t budget_ms;
};
static const struct budget_code short_codes[] = {
    {0x001Du, 0x0027u, 15u},  {0x0051u, 0x006Eu, 20u},  {0x00D6u, 0x006Eu, 33u},
    {0x01AEu, 0x01E8u, 50u},  {0x02E1u, 0x0388u, 100u}, {0x03E1u, 0x0496u, 200u},
    {0x0591u, 0x05C1u, 500u},
};
static const struct budget_code long_codes[] = {
    {0x001Eu, 0x0022u, 20u},  {0x0060u, 0x006Eu, 33u},  {0x00ADu, 0x00C6u, 50u},
    {0x01CCu, 0x01EAu, 100u}, {0x02D9u, 0x02F8u, 200u}, {0x048Fu, 0x04A4u, 500u},
};

/* ULD range status -> a raw RESULT__RANGE_STATUS the ULD maps back to it (inverse of
 * [ULD] status_rtn); 0xFF: no raw code gives this status. */
static uint8_t raw_for_status(uint8_t uld_status) {
    static const uint8_t raw_of[14] = {9u, 6u,    4u,  8u,  5u,  3u,  19u,
                                       7u, 0xFFu, 12u, 18u, 22u, 23u, 13u};
    return uld_status < sizeof raw_of ? raw_of[uld_status] : 0xFFu;
}

static uint16_t be16_at(const uint8_t *regs, uint16_t reg) {
    return (uint16_t)(((uint16_t)regs[reg] << 8) | regs[reg + 1u]);
}

static void put_be16_at(uint8_t *regs, uint16_t reg, uint16_t value) {
    regs[reg] = (uint8_t)(value >> 8);
    regs[reg + 1u] = (uint8_t)(value & 0xFFu);
}

static uint64_t now(const struct sim_vl53 *dev) {
    return sim_clock_now(dev->clock);
}

static void reset_registers(struct sim_vl53 *dev) {
    for (size_t i = 0; i < SIM_VL53_REG_SPACE; ++i) {
        dev->regs[i] = 0u;
    }
    put_be16_at(dev->regs, VL53_REG_IDENTIFICATION_MODEL_ID, dev->cfg.model_id);
    put_be16_at(dev->regs, VL53_REG_RESULT_OSC_CALIBRATE_VAL, dev->cfg.osc_calibrate);
}

static void power_up(struct sim_vl53 *dev) {
    reset_registers(dev);
    dev->powered = true;
    dev->booted = false;
    dev->power_up_us = now(dev);
    dev->address = VL53_DEFAULT_ADDRESS;
    dev->index = 0u;
    dev->ranging = false;
    dev->stream_started = false;
    dev->stream_count = 0u;
    dev->irq_pending = false;
    dev->drdy = SIM_VL53_DRDY_FREE;
    dev->stats.power_ups++;
}

static void power_down(struct sim_vl53 *dev) {
    dev->powered = false;
    dev->booted = false;
    dev->ranging = false;
    dev->irq_pending = false;
    dev->drdy = SIM_VL53_DRDY_FREE;
}

static struct sim_range constant_range(void) {
    struct sim_range r = {100u, 0u, true};
    return r;
}

/* Write one result into the block and raise the interrupt. */
static void publish(struct sim_vl53 *dev, const struct sim_range *range, uint32_t sample_index,
                    uint64_t time_us) {
    /* Stream count: 0 on the first range after a start, then +1, 0xFF wraps to 0x80 ([API]). */
    if (!dev->stream_started) {
        dev->stream_count = 0u;
        dev->stream_started = true;
    } else if (dev->stream_count == 0xFFu) {
        dev->stream_count = VL53_STREAM_COUNT_WRAP_TO;
    } else {
        dev->stream_count++;
    }
    uint8_t raw = raw_for_status(range->range_status);
    if (raw == 0xFFu) {
        dev->stats.unmappable_status++;
        raw = 0u;
    }
    /* Signal rate falls with the square of distance: 1 MCPS (128 in 9.7) at 1 m. A model
     * choice so the field moves plausibly, not a physical calibration. */
    uint32_t d = range->distance_mm != 0u ? range->distance_mm : 1u;
    uint32_t signal = 128000000u / (d * d);
    uint16_t signal_raw = signal > 0xFFFFu ? 0xFFFFu : (uint16_t)signal;
    uint8_t *r = dev->regs;
    r[VL53_REG_RESULT_RANGE_STATUS] = raw;
    r[VL53_REG_RESULT_RANGE_STATUS + VL53_RESULT_OFS_REPORT] = 0u;
    r[VL53_REG_RESULT_RANGE_STATUS + VL53_RESULT_OFS_STREAM_COUNT] = dev->stream_count;
    put_be16_at(r, VL53_REG_RESULT_RANGE_STATUS + VL53_RESULT_OFS_SPADS, MODEL_SPADS_8_8);
    put_be16_at(r, VL53_REG_RESULT_RANGE_STATUS + 5u, signal_raw); /* peak signal, uncorrected */
    put_be16_at(r, VL53_REG_RESULT_RANGE_STATUS + VL53_RESULT_OFS_AMBIENT, dev->cfg.ambient_raw);
    put_be16_at(r, VL53_REG_RESULT_RANGE_STATUS + 9u, MODEL_SIGMA);
    put_be16_at(r, VL53_REG_RESULT_RANGE_STATUS + 11u, 0u); /* phase: not modelled */
    put_be16_at(r, VL53_REG_RESULT_DISTANCE, range->distance_mm);
    put_be16_at(r, VL53_REG_RESULT_RANGE_STATUS + VL53_RESULT_OFS_SIGNAL, signal_raw);
    if (dev->irq_pending) {
        dev->stats.overruns++; /* the previous result was never cleared: overwritten */
    }
    dev->irq_pending = true;
    dev->stats.published++;
    dev->published[1] = dev->published[0];
    dev->published[0].valid = true;
    dev->published[0].distance_mm = range->distance_mm;
    dev->published[0].range_status = range->range_status;
    dev->published[0].stream_count = dev->stream_count;
    dev->published[0].sample_index = sample_index;
    dev->published[0].time_us = time_us;
}

static void complete_measurement(struct sim_vl53 *dev, uint64_t time_us) {
    dev->stats.measurements++;
    uint32_t sample_index;
    if (dev->cfg.index_mode == SIM_VL53_INDEX_BY_TIME && dev->cfg.index_period_us != 0u) {
        sample_index = (uint32_t)(time_us / dev->cfg.index_period_us);
    } else {
        sample_index = dev->next_sample_index++;
    }
    struct sim_range range = constant_range();
    if (dev->source.ops != NULL && dev->source.ops->next != NULL) {
        int rc = dev->source.ops->next(dev->source.ctx, dev->cfg.sensor, sample_index, &range);
        if (rc < 0) {
            dev->source_error = rc;
            return;
        }
        if (rc > 0) {
            dev->source_done = true;
            return;
        }
    }
    if (!range.present) {
        dev->stats.dropouts++;
        return;
    }
    publish(dev, &range, sample_index, time_us);
}

/* When the model next changes state by itself: boot completes, or the next measurement
 * is due. SIM_CLOCK_NEVER while neither is pending. */
static uint64_t next_event_us(const struct sim_vl53 *dev) {
    uint64_t next = SIM_CLOCK_NEVER;
    if (!dev->powered) {
        return next;
    }
    if (!dev->booted) {
        next = dev->power_up_us + dev->cfg.boot_us;
    }
    if (dev->ranging && !dev->source_done && dev->source_error == 0) {
        const uint64_t due = dev->range_start_us + dev->budget_us + dev->completed * dev->period_us;
        next = due < next ? due : next;
    }
    return next;
}

/* After a change from outside (a register write, XSHUT, an injected fault): the next
 * event may be earlier than the clock knows. */
static void reschedule(struct sim_vl53 *dev) {
    dev->next_event_us = next_event_us(dev);
    sim_clock_wake_at(dev->clock, dev->next_event_us);
}

/* The body of sim_vl53_update, for when something is due. */
static void run_due(struct sim_vl53 *dev) {
    const uint64_t t = now(dev);
    if (!dev->powered) {
        return;
    }
    if (!dev->booted && t >= dev->power_up_us + dev->cfg.boot_us) {
        dev->booted = true;
    }
    if (!dev->ranging || dev->source_done || dev->source_error != 0) {
        return;
    }
    const uint64_t first = dev->range_start_us + dev->budget_us;
    if (t < first + dev->completed * dev->period_us) {
        return; /* the next measurement is not due: the common case, no division */
    }
    /* Usually exactly the one measurement the check above found due: no division. */
    const uint64_t due = t < first + (dev->completed + 1u) * dev->period_us
                             ? dev->completed + 1u
                             : (t - first) / dev->period_us + 1u;
    if (due - dev->completed > SIM_VL53_MAX_CATCH_UP) {
        uint64_t skip = due - dev->completed - SIM_VL53_MAX_CATCH_UP;
        dev->stats.skipped += (uint32_t)skip;
        dev->stats.measurements += (uint32_t)skip;
        dev->next_sample_index += (uint32_t)skip;
        dev->completed += skip;
    }
    for (uint32_t n = 0; n < SIM_VL53_MAX_CATCH_UP && dev->completed < due; ++n) {
        complete_measurement(dev, first + dev->completed * dev->period_us);
        dev->completed++;
        if (dev->source_done || dev->source_error != 0) {
            break;
        }
    }
}

void sim_vl53_update(struct sim_vl53 *dev) {
    if (now(dev) < dev->next_event_us) {
        return; /* nothing due: nearly every call (bus accesses, GPIO reads, clock advances) */
    }
    run_due(dev);
    dev->next_event_us = next_event_us(dev);
}

/* Decode the ranging configuration at start; false (a protocol error) if it is not one the
 * ULD writes. */
static bool decode_timing(struct sim_vl53 *dev) {
    const uint8_t *r = dev->regs;
    const struct budget_code *codes;
    size_t count;
    bool short_mode;
    if (r[VL53_REG_PHASECAL_CONFIG_TIMEOUT_MACROP] == VL53_PHASECAL_SHORT) {
        short_mode = true;
        codes = short_codes;
        count = sizeof short_codes / sizeof short_codes[0];
    } else if (r[VL53_REG_PHASECAL_CONFIG_TIMEOUT_MACROP] == VL53_PHASECAL_LONG) {
        short_mode = false;
        codes = long_codes;
        count = sizeof long_codes / sizeof long_codes[0];
    } else {
        return false;
    }
    bool consistent =
        r[VL53_REG_RANGE_CONFIG_VCSEL_PERIOD_A] ==
            (short_mode ? VL53_VCSEL_PERIOD_A_SHORT : VL53_VCSEL_PERIOD_A_LONG) &&
        r[VL53_REG_RANGE_CONFIG_VCSEL_PERIOD_B] ==
            (short_mode ? VL53_VCSEL_PERIOD_B_SHORT : VL53_VCSEL_PERIOD_B_LONG) &&
        r[VL53_REG_RANGE_CONFIG_VALID_PHASE_HIGH] ==
            (short_mode ? VL53_VALID_PHASE_HIGH_SHORT : VL53_VALID_PHASE_HIGH_LONG) &&
        r[VL53_REG_SD_CONFIG_WOI_SD0] == (short_mode ? VL53_WOI_SD0_SHORT : VL53_WOI_SD0_LONG) &&
        r[VL53_REG_SD_CONFIG_WOI_SD0 + 1u] ==
            (short_mode ? VL53_WOI_SD1_SHORT : VL53_WOI_SD1_LONG) &&
        r[VL53_REG_SD_CONFIG_WOI_SD0 + 2u] ==
            (short_mode ? VL53_INITIAL_PHASE_SHORT : VL53_INITIAL_PHASE_LONG) &&
        r[VL53_REG_SD_CONFIG_WOI_SD0 + 3u] ==
            (short_mode ? VL53_INITIAL_PHASE_SHORT : VL53_INITIAL_PHASE_LONG);
    if (!consistent) {
        return false;
    }
    uint16_t a = be16_at(r, VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A);
    uint16_t b = be16_at(r, VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_B);
    uint16_t budget_ms = 0u;
    for (size_t i = 0; i < count; ++i) {
        if (codes[i].macrop_a == a && codes[i].macrop_b == b) {
            budget_ms = codes[i].budget_ms;
        }
    }
    if (budget_ms == 0u) {
        return false;
    }
    /* SYSTEM__INTERMEASUREMENT_PERIOD = ms * clock_pll * 1.075 ([ULD]); 0 = back to back. */
    uint32_t imp = ((uint32_t)r[VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD] << 24) |
                   ((uint32_t)r[VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD + 1u] << 16) |
                   ((uint32_t)r[VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD + 2u] << 8) |
                   r[VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD + 3u];
    uint64_t clock_pll = dev->cfg.osc_calibrate & VL53_OSC_CALIBRATE_MASK;
    uint64_t imp_us =
        clock_pll != 0u ? ((uint64_t)imp * 1000000u) / (clock_pll * VL53_IMP_FACTOR_PER_MILLE) : 0u;
    dev->budget_us = (uint64_t)budget_ms * 1000u;
    /* "If the inter-measurement period is shorter than the timing budget, the next ranging
     * starts immediately" (ST VL53L1X presentation, autonomous mode). */
    dev->period_us = imp_us > dev->budget_us ? imp_us : dev->budget_us;
    return true;
}

static void start_ranging(struct sim_vl53 *dev) {
    if (!decode_timing(dev)) {
        dev->stats.protocol_errors++;
        dev->ranging = false;
        return;
    }
    dev->ranging = true;
    dev->range_start_us = now(dev);
    dev->completed = 0u;
    dev->stream_started = false;
    dev->stats.starts++;
}

static bool is_read_only(uint16_t reg) {
    return reg == VL53_REG_GPIO_TIO_HV_STATUS ||
           (reg >= VL53_REG_RESULT_RANGE_STATUS && reg <= RESULT_BLOCK_LAST) ||
           reg == VL53_REG_RESULT_OSC_CALIBRATE_VAL ||
           reg == VL53_REG_RESULT_OSC_CALIBRATE_VAL + 1u ||
           reg == VL53_REG_FIRMWARE_SYSTEM_STATUS || reg == VL53_REG_IDENTIFICATION_MODEL_ID ||
           reg == VL53_REG_IDENTIFICATION_MODEL_ID + 1u;
}

static void write_register(struct sim_vl53 *dev, uint16_t reg, uint8_t value,
                           uint8_t *new_address) {
    if (reg >= SIM_VL53_REG_SPACE) {
        dev->stats.protocol_errors++;
        return;
    }
    if (is_read_only(reg)) {
        dev->stats.readonly_writes++;
        return;
    }
    switch (reg) {
    case VL53_REG_I2C_SLAVE_DEVICE_ADDRESS:
        dev->regs[reg] = value;
        if (!dev->cfg.ignores_address_change) {
            *new_address = (uint8_t)(value & 0x7Fu); /* takes effect after this transfer */
        }
        break;
    case VL53_REG_SYSTEM_INTERRUPT_CLEAR:
        if ((value & VL53_INTERRUPT_CLEAR) != 0u) {
            dev->irq_pending = false;
            dev->stats.clears++;
        }
        break;
    case VL53_REG_SYSTEM_MODE_START:
        dev->regs[reg] = value;
        if (value == VL53_MODE_START_TIMED) {
            start_ranging(dev);
        } else if (value == VL53_MODE_STOP) {
            if (dev->ranging) {
                dev->stats.stops++;
            }
            dev->ranging = false;
        } else {
            dev->stats.protocol_errors++;
        }
        break;
    default:
        dev->regs[reg] = value;
        break;
    }
}

static bool drdy_level(const struct sim_vl53 *dev) {
    if (dev->drdy == SIM_VL53_DRDY_STUCK_HIGH) {
        return true;
    }
    if (dev->drdy == SIM_VL53_DRDY_STUCK_LOW) {
        return false;
    }
    bool active_low =
        (dev->regs[VL53_REG_GPIO_HV_MUX_CTRL] & VL53_GPIO_HV_MUX_POLARITY_LOW_BIT) != 0u;
    return active_low ? !dev->irq_pending : dev->irq_pending;
}

static uint8_t read_register(const struct sim_vl53 *dev, uint16_t reg) {
    if (reg == VL53_REG_GPIO_TIO_HV_STATUS) {
        return drdy_level(dev) ? VL53_TIO_HV_STATUS_LEVEL_BIT : 0u;
    }
    if (reg == VL53_REG_FIRMWARE_SYSTEM_STATUS) {
        return dev->booted ? VL53_FIRMWARE_BOOTED_BIT : 0u;
    }
    return dev->regs[reg];
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
    if (tx_len == 1u) {
        dev->stats.protocol_errors++; /* half a register index */
    } else if (tx_len >= 2u) {
        dev->index = (uint16_t)(((uint16_t)tx[0] << 8) | tx[1]);
        if (tx_len > 2u && !dev->booted) {
            dev->stats.protocol_errors++; /* written before the firmware booted: ignored */
            dev->index = (uint16_t)(dev->index + (tx_len - 2u));
        } else {
            for (size_t i = 2; i < tx_len; ++i) {
                write_register(dev, dev->index, tx[i], &new_address);
                dev->index++;
            }
        }
    }
    const size_t first = dev->index;
    if (first + rx_len <= SIM_VL53_REG_SPACE &&
        !(first <= VL53_REG_GPIO_TIO_HV_STATUS && VL53_REG_GPIO_TIO_HV_STATUS < first + rx_len) &&
        !(first <= VL53_REG_FIRMWARE_SYSTEM_STATUS &&
          VL53_REG_FIRMWARE_SYSTEM_STATUS < first + rx_len)) {
        /* Plain registers only (the result block, what a replay reads): what the loop
         * below gives, as one copy. */
        if (rx_len > 0u) {
            memcpy(rx, &dev->regs[first], rx_len);
        }
        dev->index = (uint16_t)(first + rx_len);
    } else {
        for (size_t i = 0; i < rx_len; ++i) {
            if (dev->index >= SIM_VL53_REG_SPACE) {
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
        reschedule(dev); /* a write may have started ranging */
    }
    return HAL_OK;
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
        reschedule(dev);
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
        if (reg >= VL53_REG_RESULT_RANGE_STATUS && reg <= RESULT_BLOCK_LAST) {
            eligible++;
        }
    }
    if (eligible == 0u) {
        return false;
    }
    uint32_t pick = bit_choice % (eligible * 8u);
    for (size_t i = 0; i < rx_len; ++i) {
        uint16_t reg = (uint16_t)(first + i);
        if (reg >= VL53_REG_RESULT_RANGE_STATUS && reg <= RESULT_BLOCK_LAST) {
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
    reschedule(dev);
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
        dev->cfg.model_id = VL53_MODEL_ID_VL53L1X;
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
    dev->address = VL53_DEFAULT_ADDRESS;
    dev->index = 0u;
    dev->stream_started = false;
    dev->stream_count = 0u;
    dev->power_up_us = 0u;
    reset_registers(dev);
    if (!dev->cfg.xshut_wired || dev->cfg.powered_at_start) {
        power_up(dev);
    }
    dev->next_event_us = next_event_us(dev);
    /* Run with the clock, so measurements complete (and GPIO1 rises) during delays too. */
    (void)sim_clock_listen(clock, clock_advanced, dev);
}
