/*
 * VL53L1X-class device model. What it counts as protocol errors: a register index of one
 * byte, an index outside 0x0000..0x01FF, a write before boot completed, a mode start value
 * other than 0x00/0x40. A real part would do something undocumented in these cases; the
 * model counts them so tests can insist on zero. A start without ST's configuration is no
 * protocol error but what a part does with it: nothing (see sim_vl53_refusal), or, without
 * the VHV step, results with raw status 3 (no VHV value found).
 */
#include "sim/sim_vl53.h"

#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"
#include "sim_vl53_regs.h"

#define DEFAULT_BOOT_US        1000u
#define DEFAULT_BOOT_SILENT_US 300u
#define DEFAULT_OSC_CALIBRATE  500u
#define DEFAULT_AMBIENT_RAW    64u     /* 0.5 MCPS in 9.7 */
#define MODEL_SPADS_8_8        0x2000u /* 32 effective SPADs: a plausible value, not a fact */
#define MODEL_SIGMA            0x0020u
#define RESULT_BLOCK_LAST      (M_RESULT_FIRST + M_RESULT_LEN - 1u)

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
    {0x001Eu, 0x0022u, 20u},
    {0x0060u, 0x006Eu, 33u},
    {0x00ADu, 0x00C6u, 50u},
    {0x01CCu, 0x01EAu, 100u},
    {0x02D9u, 0x02F8u, 200u},
    {0x048Fu, 0x04A4u, 500u},
    {M_BLOCK_TIMEOUT_A, M_BLOCK_TIMEOUT_B, M_BLOCK_RANGE_MS}, /* ST's block itself */
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
    put_be16_at(dev->regs, M_MODEL_ID, dev->cfg.model_id);
    put_be16_at(dev->regs, M_OSC_CALIBRATE, dev->cfg.osc_calibrate);
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

static struct sim_range constant_range(void) {
    struct sim_range r = {100u, 0u, true};
    return r;
}

/* Write one result into the block and raise the interrupt. */
static void publish(struct sim_vl53 *dev, const struct sim_range *range, uint32_t sample_index,
                    uint64_t time_us) {
    /* Stream count: 0 on the first range after power-up, then +1, 0xFF wraps to 0x80 ([API]);
     * it does not restart at a later start (issue 14; the model's choice, see docs). */
    if (!dev->stream_started) {
        dev->stream_count = 0u;
        dev->stream_started = true;
    } else if (dev->stream_count == 0xFFu) {
        dev->stream_count = M_STREAM_WRAP_TO;
    } else {
        dev->stream_count++;
    }
    uint8_t raw = raw_for_status(range->range_status);
    uint16_t distance_mm = range->distance_mm;
    if (raw == 0xFFu) {
        dev->stats.unmappable_status++;
        raw = 0u;
    }
    if (dev->forced_left > 0u) {
        dev->forced_left--;
        raw = dev->forced_raw;
        distance_mm = dev->forced_mm;
    } else if (dev->vhv_stage < 3u) {
        raw = M_RAW_NO_VHV; /* the VHV step not done: "no VHV value found" (assumption) */
        dev->stats.no_vhv_results++;
    } else {
        /* the source's status */
    }
    /* Signal rate falls with the square of distance: 1 MCPS (128 in 9.7) at 1 m. A model
     * choice so the field moves plausibly, not a physical calibration. */
    uint32_t d = distance_mm != 0u ? distance_mm : 1u;
    uint32_t signal = 128000000u / (d * d);
    uint16_t signal_raw = signal > 0xFFFFu ? 0xFFFFu : (uint16_t)signal;
    uint8_t *r = dev->regs;
    r[M_RESULT_FIRST] = raw;
    r[M_RESULT_FIRST + 1u] = 0u;
    r[M_RESULT_STREAM] = dev->stream_count;
    put_be16_at(r, M_RESULT_SPADS, MODEL_SPADS_8_8);
    put_be16_at(r, M_RESULT_PEAK, signal_raw); /* peak signal, uncorrected */
    put_be16_at(r, M_RESULT_AMBIENT, dev->cfg.ambient_raw);
    put_be16_at(r, M_RESULT_SIGMA, MODEL_SIGMA);
    put_be16_at(r, M_RESULT_PHASE, 0u); /* phase: not modelled */
    put_be16_at(r, M_RESULT_DISTANCE, distance_mm);
    put_be16_at(r, M_RESULT_PEAK_XTALK, signal_raw);
    if (dev->irq_pending) {
        dev->stats.overruns++; /* the previous result was never cleared: overwritten */
    }
    dev->irq_pending = true;
    dev->stats.published++;
    dev->published[1] = dev->published[0];
    dev->published[0].valid = true;
    dev->published[0].distance_mm = distance_mm;
    dev->published[0].range_status = range->range_status;
    dev->published[0].raw_status = raw;
    dev->published[0].stream_count = dev->stream_count;
    dev->published[0].sample_index = sample_index;
    dev->published[0].time_us = time_us;
}

static void complete_measurement(struct sim_vl53 *dev, uint64_t time_us) {
    dev->stats.measurements++;
    if (dev->vhv_stage < 3u) {
        /* Not calibrated: the VHV range itself, or ranging without the VHV step. Its result
         * says "no VHV value found" (raw 3) and measures nothing the scene could supply, so
         * the source is not consulted (the model's choice; the ULD discards this range). */
        if (dev->vhv_stage == 0u) {
            dev->vhv_stage = 1u; /* the first range after the block: the VHV range ([ULD]) */
        }
        const struct sim_range none = {0u, 0u, true};
        publish(dev, &none, dev->next_sample_index, time_us);
        return;
    }
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
    /* Per-mode values of [ULD] SetDistanceMode: phasecal 0x14 / 0x0A, VCSEL A 0x07 / 0x0F,
     * VCSEL B 0x05 / 0x0D, valid phase high 0x38 / 0xB8, WOI 07 05 / 0F 0D, initial phase
     * 06 06 / 0E 0E (short / long). */
    if (r[M_PHASECAL_TIMEOUT] == 0x14u) {
        short_mode = true;
        codes = short_codes;
        count = sizeof short_codes / sizeof short_codes[0];
    } else if (r[M_PHASECAL_TIMEOUT] == 0x0Au) {
        short_mode = false;
        codes = long_codes;
        count = sizeof long_codes / sizeof long_codes[0];
    } else {
        return false;
    }
    const uint8_t phase = short_mode ? 0x06u : 0x0Eu;
    bool consistent = r[M_VCSEL_A] == (short_mode ? 0x07u : 0x0Fu) &&
                      r[M_VCSEL_B] == (short_mode ? 0x05u : 0x0Du) &&
                      r[M_VALID_PHASE_HIGH] == (short_mode ? 0x38u : 0xB8u) &&
                      r[M_WOI_SD0] == (short_mode ? 0x07u : 0x0Fu) &&
                      r[M_WOI_SD0 + 1u] == (short_mode ? 0x05u : 0x0Du) &&
                      r[M_WOI_SD0 + 2u] == phase && r[M_WOI_SD0 + 3u] == phase;
    if (!consistent) {
        return false;
    }
    uint16_t a = be16_at(r, M_TIMEOUT_A);
    uint16_t b = be16_at(r, M_TIMEOUT_B);
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
    uint32_t imp = ((uint32_t)r[M_INTERMEASUREMENT] << 24) |
                   ((uint32_t)r[M_INTERMEASUREMENT + 1u] << 16) |
                   ((uint32_t)r[M_INTERMEASUREMENT + 2u] << 8) | r[M_INTERMEASUREMENT + 3u];
    uint64_t clock_pll = dev->cfg.osc_calibrate & M_OSC_MASK;
    uint64_t imp_us =
        clock_pll != 0u ? ((uint64_t)imp * 1000000u) / (clock_pll * M_IMP_PER_MILLE) : 0u;
    dev->budget_us = (uint64_t)budget_ms * 1000u;
    /* "If the inter-measurement period is shorter than the timing budget, the next ranging
     * starts immediately" (ST VL53L1X presentation, autonomous mode). */
    dev->period_us = imp_us > dev->budget_us ? imp_us : dev->budget_us;
    return true;
}

/* All of 0x2D..0x87 written since power-up, with what makes the part range ([ULD] block,
 * [REG] bit fields). */
static bool block_complete(const struct sim_vl53 *dev) {
    for (uint16_t reg = M_BLOCK_FIRST; reg <= M_BLOCK_LAST; ++reg) {
        const unsigned k = (unsigned)(reg - M_BLOCK_FIRST);
        if ((dev->block_written[k / 8u] & (1u << (k % 8u))) == 0u) {
            return false;
        }
    }
    return (dev->regs[M_SEQUENCE_CONFIG] & M_SEQUENCE_RANGE_EN) != 0u &&
           (dev->regs[M_FIRMWARE_ENABLE] & 0x01u) != 0u &&
           dev->regs[M_INT_CONFIG_GPIO] == M_INT_NEW_SAMPLE;
}

static void start_ranging(struct sim_vl53 *dev) {
    dev->stats.starts++;
    dev->started_since_boot = true;
    dev->ranging = false;
    if (!block_complete(dev)) {
        dev->refusal = SIM_VL53_NO_BLOCK; /* not configured: no range, no data ready */
    } else if (!decode_timing(dev)) {
        dev->refusal = SIM_VL53_BAD_TIMING;
    } else {
        dev->refusal = SIM_VL53_RANGES;
        dev->ranging = true;
        dev->range_start_us = now(dev);
        dev->completed = 0u;
        return;
    }
    dev->stats.refused_starts++;
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
    }
}

static bool is_read_only(uint16_t reg) {
    return reg == M_GPIO_TIO_STATUS || (reg >= M_RESULT_FIRST && reg <= RESULT_BLOCK_LAST) ||
           reg == M_OSC_CALIBRATE || reg == M_OSC_CALIBRATE + 1u || reg == M_FIRMWARE_STATUS ||
           reg == M_MODEL_ID || reg == M_MODEL_ID + 1u;
}

static void write_register(struct sim_vl53 *dev, uint16_t reg, uint8_t value,
                           uint8_t *new_address) {
    if (reg >= SIM_VL53_REG_SPACE) {
        dev->stats.protocol_errors++;
        return;
    }
    if (reg >= M_BLOCK_FIRST && reg <= M_BLOCK_LAST) {
        /* 0x31 is read-only, yet ST's block writes it: written all the same */
        const unsigned k = (unsigned)(reg - M_BLOCK_FIRST);
        dev->block_written[k / 8u] = (uint8_t)(dev->block_written[k / 8u] | (1u << (k % 8u)));
    }
    if (is_read_only(reg)) {
        dev->stats.readonly_writes++;
        return;
    }
    switch (reg) {
    case M_VHV_LOOP_BOUND:
    case M_VHV_INIT:
        dev->regs[reg] = value;
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
            start_ranging(dev);
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
         * 0x03 ranging / 0x02 stopped: the values issue 14 reports from a part that kept
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
        !(first <= M_GPIO_TIO_STATUS && M_GPIO_TIO_STATUS < first + rx_len) &&
        !(first <= M_FIRMWARE_STATUS && M_FIRMWARE_STATUS < first + rx_len)) {
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
    dev->next_event_us = next_event_us(dev);
    /* Run with the clock, so measurements complete (and GPIO1 rises) during delays too. */
    (void)sim_clock_listen(clock, clock_advanced, dev);
}
