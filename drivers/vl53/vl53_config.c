/* VL53 driver: timing facts, the default configuration, the VHV step and the timing registers. */
#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53/vl53.h"
#include "vl53/vl53_default_config.h"
#include "vl53_internal.h"

/* Facts transcribed from the ULD (see vl53_regs.h [ULD]). */

/* RANGE_CONFIG__TIMEOUT_MACROP_A / _B for each timing budget, per distance mode
 * ([ULD] VL53L1X_SetTimingBudgetInMs). 15 ms exists in short mode only. */
struct timing_entry {
    uint16_t budget_ms;
    uint16_t macrop_a;
    uint16_t macrop_b;
};

static const struct timing_entry short_mode_timing[] = {
    {15u, 0x001Du, 0x0027u},  {20u, 0x0051u, 0x006Eu},  {33u, 0x00D6u, 0x006Eu},
    {50u, 0x01AEu, 0x01E8u},  {100u, 0x02E1u, 0x0388u}, {200u, 0x03E1u, 0x0496u},
    {500u, 0x0591u, 0x05C1u},
};

static const struct timing_entry long_mode_timing[] = {
    {20u, 0x001Eu, 0x0022u},  {33u, 0x0060u, 0x006Eu},  {50u, 0x00ADu, 0x00C6u},
    {100u, 0x01CCu, 0x01EAu}, {200u, 0x02D9u, 0x02F8u}, {500u, 0x048Fu, 0x04A4u},
};

static const struct timing_entry *find_timing(const struct vl53_timing *timing) {
    const struct timing_entry *table = short_mode_timing;
    size_t count = sizeof short_mode_timing / sizeof short_mode_timing[0];
    if (timing->mode == VL53_DISTANCE_LONG) {
        table = long_mode_timing;
        count = sizeof long_mode_timing / sizeof long_mode_timing[0];
    } else if (timing->mode != VL53_DISTANCE_SHORT) {
        return NULL;
    } else {
        /* short mode: the table chosen above */
    }
    for (size_t i = 0; i < count; ++i) {
        if (table[i].budget_ms == timing->budget_ms) {
            return &table[i];
        }
    }
    return NULL;
}

uint16_t vl53_shortest_budget_ms(enum vl53_distance_mode mode) {
    if (mode == VL53_DISTANCE_LONG) {
        return long_mode_timing[0].budget_ms;
    }
    return mode == VL53_DISTANCE_SHORT ? short_mode_timing[0].budget_ms : 0u;
}

int vl53_timing_check(const struct vl53_timing *timing) {
    if (timing == NULL || find_timing(timing) == NULL) {
        return HAL_ERR_INVALID;
    }
    /* The period must exceed the budget with a 4 ms margin ([I4], [ULD] header note). */
    if (timing->inter_measurement_ms < (uint32_t)timing->budget_ms + VL53_IMP_MARGIN_MS ||
        timing->inter_measurement_ms > VL53_IMP_MAX_MS) {
        return HAL_ERR_INVALID;
    }
    return HAL_OK;
}

uint32_t vl53_period_us(const struct vl53_timing *timing) {
    uint32_t budget = (uint32_t)timing->budget_ms;
    uint32_t period = timing->inter_measurement_ms;
    return (period > budget ? period : budget) * 1000u;
}

const char *vl53_distance_mode_name(enum vl53_distance_mode mode) {
    return mode == VL53_DISTANCE_LONG ? "long" : "short";
}

bool vl53_distance_mode_from_name(const char *name, enum vl53_distance_mode *mode) {
    if (strcmp(name, "short") == 0) {
        *mode = VL53_DISTANCE_SHORT;
        return true;
    }
    if (strcmp(name, "long") == 0) {
        *mode = VL53_DISTANCE_LONG;
        return true;
    }
    return false;
}

static uint8_t mux_ctrl_value(enum vl53_polarity polarity) {
    return (uint8_t)(VL53_GPIO_HV_MUX_LOW_NIBBLE |
                     (polarity == VL53_INT_ACTIVE_LOW ? VL53_GPIO_HV_MUX_POLARITY_LOW_BIT : 0u));
}

/* Registers 0x5E..0x63 in one burst: timeout A (16), VCSEL period A, timeout B (16), VCSEL B. */
static void timing_block(const struct vl53_timing *timing, const struct timing_entry *entry,
                         uint8_t out[6]) {
    bool short_mode = timing->mode == VL53_DISTANCE_SHORT;
    hal_put_be16(&out[0], entry->macrop_a);
    out[2] = short_mode ? VL53_VCSEL_PERIOD_A_SHORT : VL53_VCSEL_PERIOD_A_LONG;
    hal_put_be16(&out[3], entry->macrop_b);
    out[5] = short_mode ? VL53_VCSEL_PERIOD_B_SHORT : VL53_VCSEL_PERIOD_B_LONG;
}

/* Registers 0x78..0x7B: WOI_SD0, WOI_SD1, INITIAL_PHASE_SD0, INITIAL_PHASE_SD1. */
static void sd_config_block(enum vl53_distance_mode mode, uint8_t out[4]) {
    bool short_mode = mode == VL53_DISTANCE_SHORT;
    out[0] = short_mode ? VL53_WOI_SD0_SHORT : VL53_WOI_SD0_LONG;
    out[1] = short_mode ? VL53_WOI_SD1_SHORT : VL53_WOI_SD1_LONG;
    out[2] = short_mode ? VL53_INITIAL_PHASE_SHORT : VL53_INITIAL_PHASE_LONG;
    out[3] = out[2];
}

/* period_ms * clock_pll * 1.075, exactly floored without 64-bit arithmetic ([ULD]). */
static uint32_t imp_register_value(uint32_t period_ms, uint16_t clock_pll) {
    uint32_t product = period_ms * (uint32_t)clock_pll; /* <= 10000 * 1023 */
    return (product / 1000u) * VL53_IMP_FACTOR_PER_MILLE +
           ((product % 1000u) * VL53_IMP_FACTOR_PER_MILLE) / 1000u;
}

/* The oscillator calibration, read twice (a single garbled read would skew every period). */
static int read_clock_pll(const struct call *c, uint16_t *clock_pll) {
    uint8_t first[2];
    uint8_t second[2];
    int err = vl53_call_read(c, c->dev->address, VL53_REG_RESULT_OSC_CALIBRATE_VAL, first, 2u);
    if (err == HAL_OK) {
        err = vl53_call_read(c, c->dev->address, VL53_REG_RESULT_OSC_CALIBRATE_VAL, second, 2u);
    }
    if (err != HAL_OK) {
        return err;
    }
    uint16_t value = (uint16_t)(hal_get_be16(first) & VL53_OSC_CALIBRATE_MASK);
    if (value != (uint16_t)(hal_get_be16(second) & VL53_OSC_CALIBRATE_MASK) || value == 0u) {
        return HAL_ERR_CORRUPT;
    }
    *clock_pll = value;
    return HAL_OK;
}

static bool same_bytes(const uint8_t *a, const uint8_t *b, size_t len) {
    for (size_t i = 0; i < len; ++i) {
        if (a[i] != b[i]) {
            return false;
        }
    }
    return true;
}

/* Write distance mode, timing budget and period, then read them back in one burst. */
static int write_timing(const struct call *c, const struct vl53_timing *timing) {
    const struct timing_entry *entry = find_timing(timing);
    if (entry == NULL) {
        return HAL_ERR_INVALID;
    }
    const uint8_t addr = c->dev->address;
    const bool short_mode = timing->mode == VL53_DISTANCE_SHORT;
    const uint8_t phasecal = short_mode ? VL53_PHASECAL_SHORT : VL53_PHASECAL_LONG;
    const uint8_t phase_high =
        short_mode ? VL53_VALID_PHASE_HIGH_SHORT : VL53_VALID_PHASE_HIGH_LONG;
    uint8_t timing_regs[6];
    uint8_t sd_regs[4];
    uint8_t imp_regs[4];
    uint16_t clock_pll = 0u;
    timing_block(timing, entry, timing_regs);
    sd_config_block(timing->mode, sd_regs);

    int err = vl53_call_write(c, addr, VL53_REG_PHASECAL_CONFIG_TIMEOUT_MACROP, &phasecal, 1u);
    if (err == HAL_OK) {
        err = vl53_call_write(c, addr, VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A, timing_regs,
                              sizeof timing_regs);
    }
    if (err == HAL_OK) {
        err = vl53_call_write(c, addr, VL53_REG_RANGE_CONFIG_VALID_PHASE_HIGH, &phase_high, 1u);
    }
    if (err == HAL_OK) {
        err = vl53_call_write(c, addr, VL53_REG_SD_CONFIG_WOI_SD0, sd_regs, sizeof sd_regs);
    }
    if (err == HAL_OK) {
        err = read_clock_pll(c, &clock_pll);
    }
    if (err == HAL_OK) {
        hal_put_be32(imp_regs, imp_register_value(timing->inter_measurement_ms, clock_pll));
        err = vl53_call_write(c, addr, VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD, imp_regs,
                              sizeof imp_regs);
    }
    if (err != HAL_OK) {
        return err;
    }
    /* Read back 0x4B and 0x5E..0x7B (every register written above) and compare. */
    uint8_t phasecal_back = 0u;
    uint8_t back[VL53_REG_SD_CONFIG_WOI_SD0 + 4u - VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A];
    err = vl53_call_read(c, addr, VL53_REG_PHASECAL_CONFIG_TIMEOUT_MACROP, &phasecal_back, 1u);
    if (err == HAL_OK) {
        err = vl53_call_read(c, addr, VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A, back, sizeof back);
    }
    if (err != HAL_OK) {
        return err;
    }
    const size_t phase_ofs =
        VL53_REG_RANGE_CONFIG_VALID_PHASE_HIGH - VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A;
    const size_t imp_ofs =
        VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD - VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A;
    const size_t sd_ofs = VL53_REG_SD_CONFIG_WOI_SD0 - VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A;
    if (phasecal_back != phasecal || !same_bytes(back, timing_regs, sizeof timing_regs) ||
        back[phase_ofs] != phase_high || !same_bytes(&back[imp_ofs], imp_regs, sizeof imp_regs) ||
        !same_bytes(&back[sd_ofs], sd_regs, sizeof sd_regs)) {
        return HAL_ERR_CORRUPT;
    }
    return HAL_OK;
}

/* The default configuration as this board needs it: ST's table (or the integrator's) with
 * the pad-voltage bits of 0x2E / 0x2F set for AVDD pull-ups ([ULD] table comments). */
static void default_block(const struct vl53_config *cfg, uint8_t out[VL53_DEFAULT_CONFIG_LEN]) {
    const uint8_t *table =
        cfg->vendor_default_config != NULL ? cfg->vendor_default_config : vl53_default_config;
    for (size_t i = 0; i < VL53_DEFAULT_CONFIG_LEN; ++i) {
        out[i] = table[i];
    }
    if (cfg->pads_at_avdd) {
        out[VL53_REG_PAD_I2C_HV_EXTSUP_CONFIG - VL53_REG_DEFAULT_CONFIG_FIRST] |= VL53_PAD_AVDD_BIT;
        out[VL53_REG_GPIO_HV_PAD_CTRL - VL53_REG_DEFAULT_CONFIG_FIRST] |= VL53_PAD_AVDD_BIT;
    }
}

int vl53_configure_begin(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    /* Stop first so configuring is idempotent whatever state the part was left in (a part
     * that kept power across an MCU reset may still be ranging). */
    int err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP);
    vl53_forget_ranging(dev);
    uint8_t block[VL53_DEFAULT_CONFIG_LEN];
    default_block(dev->cfg, block);
    if (err == HAL_OK) {
        /* [ULD] SensorInit writes 0x2D..0x87 one byte at a time; one auto-incrementing
         * transfer writes the same registers with the same values in the same order. */
        err = vl53_call_write(&c, dev->address, VL53_REG_DEFAULT_CONFIG_FIRST, block, sizeof block);
    }
    if (err == HAL_OK) {
        /* The offsets the part's NVM loaded, replaced by the recorded state (vl53_offset.c):
         * after the block, as the ULD's SetOffset follows SensorInit, and before the VHV
         * range, so every range this boot makes already has them. */
        err = vl53_write_offsets(&c);
    }
    if (err == HAL_OK) {
        /* A part that kept power across an MCU reset may hold a result nobody cleared; its
         * data ready would end the VHV wait at once and the stop would cut the VHV range
         * short. Clear before the start, as the Linux driver's vl53l1x_start_ranging does
         * (the ULD's SensorInit does not, assuming a part fresh from boot). */
        err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    }
    if (err == HAL_OK) {
        err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED);
    }
    if (err == HAL_OK) {
        dev->vhv_running = true;
        dev->vhv_start_us = now_us(dev);
    }
    return err;
}

/* Polarity of data ready during the VHV range: as the block set it (0x30 bit 4), as
 * [ULD] CheckForDataReady reads it. */
static enum vl53_polarity vhv_polarity(const struct vl53_config *cfg) {
    const uint8_t *table =
        cfg->vendor_default_config != NULL ? cfg->vendor_default_config : vl53_default_config;
    const size_t mux_ofs = VL53_REG_GPIO_HV_MUX_CTRL - VL53_REG_DEFAULT_CONFIG_FIRST;
    return (table[mux_ofs] & VL53_GPIO_HV_MUX_POLARITY_LOW_BIT) != 0u ? VL53_INT_ACTIVE_LOW
                                                                      : VL53_INT_ACTIVE_HIGH;
}

/* One look at the VHV range's data ready at `polarity`: GPIO1 when wired (the same signal,
 * no bus traffic), else GPIO__TIO_HV_STATUS. */
static int vhv_ready_once(const struct call *c, enum vl53_polarity polarity, bool *ready) {
    const struct vl53_config *cfg = c->dev->cfg;
    if (cfg->gpio1_pin == VL53_PIN_NONE) {
        return vl53_read_data_ready(c, polarity, ready);
    }
    bool level_high = false;
    int err = cfg->gpio.ops->read(cfg->gpio.ctx, cfg->gpio1_pin, &level_high);
    *ready = err == HAL_OK && level_high == (polarity == VL53_INT_ACTIVE_HIGH);
    return err;
}

/* One look at the running VHV range (data ready at `polarity`), HAL_ERR_TIMEOUT once
 * `budget_us` since its start has passed without it. */
static int vhv_pending(struct vl53_dev *dev, enum vl53_polarity polarity, uint32_t budget_us) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    if (!dev->vhv_running) {
        return HAL_ERR_STATE;
    }
    struct call c = call_begin(dev, call_budget(dev));
    bool ready = false;
    int err = vhv_ready_once(&c, polarity, &ready);
    if (err == HAL_OK && ready) {
        return HAL_OK;
    }
    if (hal_time_elapsed_us(now_us(dev), dev->vhv_start_us) >= budget_us) {
        return HAL_ERR_TIMEOUT;
    }
    return err != HAL_OK ? err : HAL_ERR_NOT_READY;
}

static uint32_t configure_budget_us(const struct vl53_dev *dev) {
    return or_default(dev->cfg->configure_budget_us, VL53_DEFAULT_CONFIGURE_BUDGET_US);
}

int vl53_configure_pending(struct vl53_dev *dev) {
    return dev_ok(dev) ? vhv_pending(dev, vhv_polarity(dev->cfg), configure_budget_us(dev))
                       : HAL_ERR_INVALID;
}

/* The VHV step's end ([ULD] SensorInit): wait for the first range's data ready, clear,
 * stop, two-bounds VHV from the previous temperature. A poll lost to a bus error is
 * retried within the budget. */
static int finish_vhv(const struct call *c, enum vl53_polarity polarity) {
    const uint32_t poll_us =
        or_default(c->dev->cfg->poll_interval_us, VL53_DEFAULT_POLL_INTERVAL_US);
    const uint32_t max_polls = c->budget_us / poll_us + 1u;
    bool ready = false;
    int err = HAL_OK;
    for (uint32_t poll = 0; poll < max_polls && !ready; ++poll) {
        err = vhv_ready_once(c, polarity, &ready);
        if (err == HAL_ERR_BUS_STUCK || err == HAL_ERR_INVALID) {
            return err;
        }
        if (err != HAL_OK) {
            ready = false; /* a lost poll (NACK, stretch): the next one may get through */
        }
        if (!ready) {
            if (vl53_call_transfer_timeout(c) <= poll_us) {
                return HAL_ERR_TIMEOUT;
            }
            delay_us(c->dev, poll_us);
        }
    }
    if (!ready) {
        return HAL_ERR_TIMEOUT;
    }
    err = vl53_call_write_byte(c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    if (err == HAL_OK) {
        err = vl53_call_write_byte(c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP);
    }
    if (err == HAL_OK) {
        err = vl53_call_write_byte(c, VL53_REG_VHV_CONFIG_TIMEOUT_MACROP_LOOP_BOUND,
                                   VL53_VHV_LOOP_BOUND_TWO_BOUNDS);
    }
    if (err == HAL_OK) {
        err = vl53_call_write_byte(c, VL53_REG_VHV_CONFIG_INIT, 0u);
    }
    return err;
}

int vl53_configure_finish(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    if (!dev->vhv_running) {
        return HAL_ERR_STATE;
    }
    struct call c = call_begin(dev, configure_budget_us(dev));
    int err = finish_vhv(&c, vhv_polarity(dev->cfg));
    dev->vhv_running = false;
    if (err != HAL_OK) {
        return err;
    }
    /* [ULD] SetInterruptPolarity, SetDistanceMode, SetTimingBudgetInMs,
     * SetInterMeasurementInMs, in that order. */
    const uint8_t mux = mux_ctrl_value(dev->cfg->polarity);
    err = vl53_call_write_byte(&c, VL53_REG_GPIO_HV_MUX_CTRL, mux);
    if (err == HAL_OK) {
        err = write_timing(&c, &dev->timing);
    }
    uint8_t mux_back = 0u;
    if (err == HAL_OK) {
        err = vl53_call_read(&c, dev->address, VL53_REG_GPIO_HV_MUX_CTRL, &mux_back, 1u);
    }
    if (err == HAL_OK && mux_back != mux) {
        err = HAL_ERR_CORRUPT;
    }
    return err;
}

int vl53_configure(struct vl53_dev *dev) {
    int err = vl53_configure_begin(dev);
    return err == HAL_OK ? vl53_configure_finish(dev) : err;
}

int vl53_set_timing(struct vl53_dev *dev, const struct vl53_timing *timing) {
    if (!dev_ok(dev) || vl53_timing_check(timing) != HAL_OK) {
        return HAL_ERR_INVALID;
    }
    if (dev->ranging) {
        return HAL_ERR_STATE;
    }
    struct call c = call_begin(dev, call_budget(dev));
    int err = write_timing(&c, timing);
    if (err == HAL_OK) {
        dev->timing = *timing;
    }
    return err;
}

int vl53_set_timing_next(struct vl53_dev *dev, const struct vl53_timing *timing) {
    if (!dev_ok(dev) || vl53_timing_check(timing) != HAL_OK) {
        return HAL_ERR_INVALID;
    }
    if (dev->ranging) {
        return HAL_ERR_STATE;
    }
    dev->timing = *timing; /* written by the next vl53_configure_finish() */
    return HAL_OK;
}

int vl53_set_distance_mode(struct vl53_dev *dev, enum vl53_distance_mode mode) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    struct vl53_timing timing = dev->timing;
    timing.mode = mode;
    return vl53_set_timing(dev, &timing);
}

int vl53_set_timing_budget(struct vl53_dev *dev, uint16_t budget_ms) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    struct vl53_timing timing = dev->timing;
    timing.budget_ms = budget_ms;
    return vl53_set_timing(dev, &timing);
}

int vl53_set_inter_measurement(struct vl53_dev *dev, uint32_t period_ms) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    struct vl53_timing timing = dev->timing;
    timing.inter_measurement_ms = period_ms;
    return vl53_set_timing(dev, &timing);
}

/* The temperature update's range runs at the part's own timing (the user's, written by
 * vl53_configure_finish): one budget plus one inter-measurement period, twice over, and never
 * less than the bring-up's VHV bound. */
static uint32_t temperature_update_budget_us(const struct vl53_dev *dev) {
    const uint32_t range_us =
        ((uint32_t)dev->timing.budget_ms + dev->timing.inter_measurement_ms) * 1000u;
    const uint32_t twice = 2u * range_us;
    return twice > configure_budget_us(dev) ? twice : configure_budget_us(dev);
}

int vl53_temperature_update_begin(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    if (dev->ranging || dev->vhv_running) {
        return HAL_ERR_STATE;
    }
    /* [ULD] StartTemperatureUpdate: full VHV (loop bound 0x81), VHV init 0x92, then one
     * timed range, which the part spends on the VHV search. */
    struct call c = call_begin(dev, call_budget(dev));
    int err = vl53_call_write_byte(&c, VL53_REG_VHV_CONFIG_TIMEOUT_MACROP_LOOP_BOUND,
                                   VL53_VHV_LOOP_BOUND_FULL);
    if (err == HAL_OK) {
        err = vl53_call_write_byte(&c, VL53_REG_VHV_CONFIG_INIT, VL53_VHV_INIT_FULL);
    }
    if (err == HAL_OK) {
        /* A result the stop left pending would end the data-ready wait at once and cut the
         * VHV range short: cleared before the start, as the bring-up does (not in the ULD,
         * which assumes a part idle for long). */
        err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    }
    if (err == HAL_OK) {
        err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED);
    }
    if (err == HAL_OK) {
        dev->vhv_running = true;
        dev->vhv_start_us = now_us(dev);
    }
    return err;
}

int vl53_temperature_update_pending(struct vl53_dev *dev) {
    return dev_ok(dev) ? vhv_pending(dev, dev->cfg->polarity, temperature_update_budget_us(dev))
                       : HAL_ERR_INVALID;
}

int vl53_temperature_update_finish(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    if (!dev->vhv_running) {
        return HAL_ERR_STATE;
    }
    /* The rest of [ULD] StartTemperatureUpdate: wait for data ready, clear the interrupt,
     * stop, two-bounds VHV (0x09) from the temperature just found (0x00): SensorInit's tail. */
    struct call c = call_begin(dev, temperature_update_budget_us(dev));
    const int err = finish_vhv(&c, dev->cfg->polarity);
    dev->vhv_running = false;
    return err;
}
