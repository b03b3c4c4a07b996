/*
 * VL53L1X-class driver: register-level, bounded in time, one error convention.
 * Register facts and their sources are in vl53_regs.h; what the default
 * configuration writes and why is in docs/driver.md.
 */
#include "vl53/vl53.h"

#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53/vl53_default_config.h"

/* ------------------------------------------------------------------------- */
/* Facts transcribed from the ULD (see vl53_regs.h [ULD]).                    */

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

/* Raw RESULT__RANGE_STATUS (low 5 bits) -> ULD range status ([ULD] status_rtn[24] in
 * VL53L1X_GetRangeStatus / GetResult), with raw 1, 2 and 17, which the ULD leaves unmapped,
 * as hardware fail (5) as ST's full API has them ([SSD]); raw 24..31 are unmapped. */
static const uint8_t raw_to_uld_status[24] = {
    255u, 5u,  5u,   5u,   2u,   4u, 1u,  7u, 3u,   0u,   255u, 255u,
    9u,   13u, 255u, 255u, 255u, 5u, 10u, 6u, 255u, 255u, 11u,  12u,
};

uint8_t vl53_range_status_from_raw(uint8_t raw) {
    uint8_t code = (uint8_t)(raw & VL53_RANGE_STATUS_RAW_MASK);
    if (code >= (uint8_t)sizeof raw_to_uld_status) {
        return VL53_RANGE_UNKNOWN;
    }
    return raw_to_uld_status[code];
}

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

/* ------------------------------------------------------------------------- */
/* Time budget of one call: every transfer gets at most what is left of it.   */

struct call {
    struct vl53_dev *dev;
    uint32_t start_us;
    uint32_t budget_us;
};

static uint32_t now_us(const struct vl53_dev *dev) {
    return dev->cfg->time.ops->now_us(dev->cfg->time.ctx);
}

static void delay_us(const struct vl53_dev *dev, uint32_t us) {
    dev->cfg->time.ops->delay_us(dev->cfg->time.ctx, us);
}

/* True once `now` is at or past `moment` (wrap-safe within half the counter range): the
 * unsigned difference is below 2^31 exactly when (int32_t)(now - moment) >= 0. */
static bool time_reached(uint32_t now, uint32_t moment) {
    const uint32_t since = now - moment;
    return since < 0x80000000u;
}

static uint32_t or_default(uint32_t value, uint32_t fallback) {
    return value != 0u ? value : fallback;
}

static struct call call_begin(struct vl53_dev *dev, uint32_t budget_us) {
    struct call c = {dev, now_us(dev), budget_us};
    return c;
}

/* Timeout for the next transfer, or 0 when the call's budget is spent. */
static uint32_t call_transfer_timeout(const struct call *c) {
    uint32_t elapsed = hal_time_elapsed_us(now_us(c->dev), c->start_us);
    if (elapsed >= c->budget_us) {
        return 0u;
    }
    uint32_t left = c->budget_us - elapsed;
    uint32_t per_transfer = or_default(c->dev->cfg->i2c_timeout_us, VL53_DEFAULT_I2C_TIMEOUT_US);
    return left < per_transfer ? left : per_transfer;
}

static int call_read(const struct call *c, uint8_t addr, uint16_t reg, uint8_t *data, size_t len) {
    uint32_t timeout = call_transfer_timeout(c);
    if (timeout == 0u) {
        return HAL_ERR_TIMEOUT;
    }
    return hal_i2c_reg16_read(&c->dev->cfg->i2c, addr, reg, data, len, timeout);
}

static int call_write(const struct call *c, uint8_t addr, uint16_t reg, const uint8_t *data,
                      size_t len) {
    uint32_t timeout = call_transfer_timeout(c);
    if (timeout == 0u) {
        return HAL_ERR_TIMEOUT;
    }
    return hal_i2c_reg16_write(&c->dev->cfg->i2c, addr, reg, data, len, timeout);
}

static int call_write_byte(const struct call *c, uint16_t reg, uint8_t value) {
    return call_write(c, c->dev->address, reg, &value, 1u);
}

static uint32_t call_budget(const struct vl53_dev *dev) {
    return or_default(dev->cfg->call_budget_us, VL53_DEFAULT_CALL_BUDGET_US);
}

/* ------------------------------------------------------------------------- */
/* Configuration checks and binding.                                          */

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
    return NULL;
}

static void forget_ranging(struct vl53_dev *dev) {
    dev->ranging = false;
    dev->vhv_running = false;
    dev->have_stream = false;
    dev->have_candidate = false;
}

int vl53_attach(struct vl53_dev *dev, const struct vl53_config *cfg) {
    if (dev == NULL || vl53_config_check(cfg) != NULL) {
        return HAL_ERR_INVALID;
    }
    dev->cfg = cfg;
    dev->timing = cfg->timing;
    dev->address = VL53_DEFAULT_ADDRESS;
    forget_ranging(dev);
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
    return HAL_OK;
}

static bool dev_ok(const struct vl53_dev *dev) {
    return dev != NULL && dev->cfg != NULL;
}

uint8_t vl53_current_address(const struct vl53_dev *dev) {
    return dev_ok(dev) ? dev->address : 0u;
}

bool vl53_is_ranging(const struct vl53_dev *dev) {
    return dev_ok(dev) && dev->ranging;
}

bool vl53_data_overdue(const struct vl53_dev *dev) {
    return dev_ok(dev) && dev->ranging && time_reached(now_us(dev), dev->data_deadline_us);
}

/* ------------------------------------------------------------------------- */
/* Power, boot, identity, address.                                            */

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
    forget_ranging(dev);
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
    forget_ranging(dev);
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
    int err = call_read(c, addr, VL53_REG_IDENTIFICATION_MODEL_ID, raw, sizeof raw);
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
    int err = call_write_byte(&c, VL53_REG_I2C_SLAVE_DEVICE_ADDRESS, new_address);
    if (err != HAL_OK) {
        return err;
    }
    dev->address = new_address;
    return read_model_id(&c, new_address, NULL);
}

/* ------------------------------------------------------------------------- */
/* Configuration.                                                             */

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
    int err = call_read(c, c->dev->address, VL53_REG_RESULT_OSC_CALIBRATE_VAL, first, 2u);
    if (err == HAL_OK) {
        err = call_read(c, c->dev->address, VL53_REG_RESULT_OSC_CALIBRATE_VAL, second, 2u);
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

    int err = call_write(c, addr, VL53_REG_PHASECAL_CONFIG_TIMEOUT_MACROP, &phasecal, 1u);
    if (err == HAL_OK) {
        err = call_write(c, addr, VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A, timing_regs,
                         sizeof timing_regs);
    }
    if (err == HAL_OK) {
        err = call_write(c, addr, VL53_REG_RANGE_CONFIG_VALID_PHASE_HIGH, &phase_high, 1u);
    }
    if (err == HAL_OK) {
        err = call_write(c, addr, VL53_REG_SD_CONFIG_WOI_SD0, sd_regs, sizeof sd_regs);
    }
    if (err == HAL_OK) {
        err = read_clock_pll(c, &clock_pll);
    }
    if (err == HAL_OK) {
        hal_put_be32(imp_regs, imp_register_value(timing->inter_measurement_ms, clock_pll));
        err =
            call_write(c, addr, VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD, imp_regs, sizeof imp_regs);
    }
    if (err != HAL_OK) {
        return err;
    }
    /* Read back 0x4B and 0x5E..0x7B (every register written above) and compare. */
    uint8_t phasecal_back = 0u;
    uint8_t back[VL53_REG_SD_CONFIG_WOI_SD0 + 4u - VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A];
    err = call_read(c, addr, VL53_REG_PHASECAL_CONFIG_TIMEOUT_MACROP, &phasecal_back, 1u);
    if (err == HAL_OK) {
        err = call_read(c, addr, VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A, back, sizeof back);
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

/* Data ready from GPIO__TIO_HV_STATUS for interrupt polarity `polarity`. */
static int read_data_ready(const struct call *c, enum vl53_polarity polarity, bool *ready) {
    uint8_t status = 0u;
    int err = call_read(c, c->dev->address, VL53_REG_GPIO_TIO_HV_STATUS, &status, 1u);
    if (err != HAL_OK) {
        return err;
    }
    const bool level_high = (status & VL53_TIO_HV_STATUS_LEVEL_BIT) != 0u;
    const bool active_high = polarity == VL53_INT_ACTIVE_HIGH;
    *ready = level_high == active_high;
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
    int err = call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP);
    forget_ranging(dev);
    uint8_t block[VL53_DEFAULT_CONFIG_LEN];
    default_block(dev->cfg, block);
    if (err == HAL_OK) {
        /* [ULD] SensorInit writes 0x2D..0x87 one byte at a time; one auto-incrementing
         * transfer writes the same registers with the same values in the same order. */
        err = call_write(&c, dev->address, VL53_REG_DEFAULT_CONFIG_FIRST, block, sizeof block);
    }
    if (err == HAL_OK) {
        /* A part that kept power across an MCU reset may hold a result nobody cleared; its
         * data ready would end the VHV wait at once and the stop would cut the VHV range
         * short. Clear before the start, as the Linux driver's vl53l1x_start_ranging does
         * (the ULD's SensorInit does not, assuming a part fresh from boot). */
        err = call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    }
    if (err == HAL_OK) {
        err = call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED);
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

/* One look at the VHV range's data ready: GPIO1 when wired (the same signal, no bus
 * traffic), else GPIO__TIO_HV_STATUS. */
static int vhv_ready_once(const struct call *c, bool *ready) {
    const struct vl53_config *cfg = c->dev->cfg;
    const enum vl53_polarity polarity = vhv_polarity(cfg);
    if (cfg->gpio1_pin == VL53_PIN_NONE) {
        return read_data_ready(c, polarity, ready);
    }
    bool level_high = false;
    int err = cfg->gpio.ops->read(cfg->gpio.ctx, cfg->gpio1_pin, &level_high);
    *ready = err == HAL_OK && level_high == (polarity == VL53_INT_ACTIVE_HIGH);
    return err;
}

int vl53_configure_pending(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    if (!dev->vhv_running) {
        return HAL_ERR_STATE;
    }
    struct call c = call_begin(dev, call_budget(dev));
    bool ready = false;
    int err = vhv_ready_once(&c, &ready);
    if (err == HAL_OK && ready) {
        return HAL_OK;
    }
    const uint32_t budget =
        or_default(dev->cfg->configure_budget_us, VL53_DEFAULT_CONFIGURE_BUDGET_US);
    if (hal_time_elapsed_us(now_us(dev), dev->vhv_start_us) >= budget) {
        return HAL_ERR_TIMEOUT;
    }
    return err != HAL_OK ? err : HAL_ERR_NOT_READY;
}

/* The VHV step's end ([ULD] SensorInit): wait for the first range's data ready, clear,
 * stop, two-bounds VHV from the previous temperature. A poll lost to a bus error is
 * retried within the budget. */
static int finish_vhv(const struct call *c) {
    const uint32_t poll_us =
        or_default(c->dev->cfg->poll_interval_us, VL53_DEFAULT_POLL_INTERVAL_US);
    const uint32_t max_polls = c->budget_us / poll_us + 1u;
    bool ready = false;
    int err = HAL_OK;
    for (uint32_t poll = 0; poll < max_polls && !ready; ++poll) {
        err = vhv_ready_once(c, &ready);
        if (err == HAL_ERR_BUS_STUCK || err == HAL_ERR_INVALID) {
            return err;
        }
        if (err != HAL_OK) {
            ready = false; /* a lost poll (NACK, stretch): the next one may get through */
        }
        if (!ready) {
            if (call_transfer_timeout(c) <= poll_us) {
                return HAL_ERR_TIMEOUT;
            }
            delay_us(c->dev, poll_us);
        }
    }
    if (!ready) {
        return HAL_ERR_TIMEOUT;
    }
    err = call_write_byte(c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    if (err == HAL_OK) {
        err = call_write_byte(c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP);
    }
    if (err == HAL_OK) {
        err = call_write_byte(c, VL53_REG_VHV_CONFIG_TIMEOUT_MACROP_LOOP_BOUND,
                              VL53_VHV_LOOP_BOUND_TWO_BOUNDS);
    }
    if (err == HAL_OK) {
        err = call_write_byte(c, VL53_REG_VHV_CONFIG_INIT, 0u);
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
    struct call c = call_begin(
        dev, or_default(dev->cfg->configure_budget_us, VL53_DEFAULT_CONFIGURE_BUDGET_US));
    int err = finish_vhv(&c);
    dev->vhv_running = false;
    if (err != HAL_OK) {
        return err;
    }
    /* [ULD] SetInterruptPolarity, SetDistanceMode, SetTimingBudgetInMs,
     * SetInterMeasurementInMs, in that order. */
    const uint8_t mux = mux_ctrl_value(dev->cfg->polarity);
    err = call_write_byte(&c, VL53_REG_GPIO_HV_MUX_CTRL, mux);
    if (err == HAL_OK) {
        err = write_timing(&c, &dev->timing);
    }
    uint8_t mux_back = 0u;
    if (err == HAL_OK) {
        err = call_read(&c, dev->address, VL53_REG_GPIO_HV_MUX_CTRL, &mux_back, 1u);
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

/* ------------------------------------------------------------------------- */
/* Ranging.                                                                   */

/* Data is overdue 1.5 periods + slack after the last: one lost range is tolerated, and a
 * 50 % error in the part's period would still not raise a false alarm. */
static uint32_t overdue_after_us(uint32_t period_us) {
    return period_us + period_us / 2u + VL53_DATA_SLACK_US;
}

int vl53_start_ranging(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    int err = call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    if (err == HAL_OK) {
        err = call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED);
    }
    if (err != HAL_OK) {
        return err;
    }
    uint32_t now = now_us(dev);
    uint32_t budget_us = (uint32_t)dev->timing.budget_ms * 1000u;
    uint32_t period_us = vl53_period_us(&dev->timing);
    dev->ranging = true;
    dev->have_stream = false;
    dev->have_candidate = false;
    dev->ranging_start_us = now;
    dev->last_result_us = now;
    /* First data is due one budget after the start; overdue the usual margin later. */
    dev->next_register_poll_us = now + budget_us;
    dev->data_deadline_us = now + budget_us + overdue_after_us(period_us);
    return HAL_OK;
}

int vl53_stop_ranging(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    int err = call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP);
    if (err == HAL_OK) {
        forget_ranging(dev);
    }
    return err;
}

int vl53_data_ready(struct vl53_dev *dev, bool *ready) {
    if (!dev_ok(dev) || ready == NULL) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    return read_data_ready(&c, dev->cfg->polarity, ready);
}

int vl53_gpio1_ready(struct vl53_dev *dev, bool *ready) {
    if (!dev_ok(dev) || ready == NULL || dev->cfg->gpio1_pin == VL53_PIN_NONE) {
        return HAL_ERR_INVALID;
    }
    bool level_high = false;
    int err = dev->cfg->gpio.ops->read(dev->cfg->gpio.ctx, dev->cfg->gpio1_pin, &level_high);
    if (err != HAL_OK) {
        return err;
    }
    const bool active_high = dev->cfg->polarity == VL53_INT_ACTIVE_HIGH;
    *ready = level_high == active_high;
    return HAL_OK;
}

int vl53_clear_interrupt(struct vl53_dev *dev) {
    if (!dev_ok(dev)) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    return call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
}

/*
 * Ranges between stream counts `from` and `to`: +1 per range, 0xFF wraps to 0x80 ([API]).
 * -1 for a pair no sequence of ranges produces.
 */
static int stream_advance(uint8_t from, uint8_t to) {
    if (to >= from) {
        return (int)to - (int)from;
    }
    if (from < VL53_STREAM_COUNT_WRAP_TO || to < VL53_STREAM_COUNT_WRAP_TO) {
        return -1;
    }
    return (0xFF - (int)from) + 1 + ((int)to - (int)VL53_STREAM_COUNT_WRAP_TO);
}

/* Most ranges that can have completed in `elapsed_us`, with 1/8 tolerance for clock skew. */
static uint32_t ranges_possible(uint32_t elapsed_us, uint32_t period_us) {
    return elapsed_us / period_us + elapsed_us / (8u * period_us) + 1u;
}

static void decode_result(const uint8_t *block, uint32_t time_us, struct vl53_result *result) {
    result->raw_status =
        (uint8_t)(block[VL53_RESULT_OFS_RANGE_STATUS] & VL53_RANGE_STATUS_RAW_MASK);
    result->range_status = vl53_range_status_from_raw(result->raw_status);
    result->stream_count = block[VL53_RESULT_OFS_STREAM_COUNT];
    result->spad_count = block[VL53_RESULT_OFS_SPADS];
    result->ambient_kcps =
        (uint32_t)hal_get_be16(&block[VL53_RESULT_OFS_AMBIENT]) * VL53_RATE_TO_KCPS_FACTOR;
    result->distance_mm = hal_get_be16(&block[VL53_RESULT_OFS_DISTANCE]);
    result->signal_kcps =
        (uint32_t)hal_get_be16(&block[VL53_RESULT_OFS_SIGNAL]) * VL53_RATE_TO_KCPS_FACTOR;
    result->time_us = time_us;
    result->missed = 0u;
    result->flags = 0u;
}

uint16_t vl53_range_max_mm(enum vl53_distance_mode mode) {
    return mode == VL53_DISTANCE_LONG ? (uint16_t)VL53_RANGE_MAX_LONG_MM
                                      : (uint16_t)VL53_RANGE_MAX_SHORT_MM;
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

/* A distance the part cannot report as a valid reading in `mode` (see vl53.h). */
static bool implausible_distance(uint16_t mm, enum vl53_distance_mode mode) {
    return mm == 0u || mm > vl53_range_max_mm(mode); /* 8190, 8191, 65535: beyond 4 m */
}

/* The marks of a result that passed the stream check: first-after-start, plausibility. */
static void mark_result(const struct vl53_dev *dev, struct vl53_result *result) {
    if ((result->flags & VL53_RESULT_FIRST) != 0u &&
        result->range_status == (uint8_t)VL53_RANGE_VALID) {
        result->range_status = VL53_RANGE_NO_WRAP_CHECK; /* ([SSD]) */
    }
    if (implausible_distance(result->distance_mm, dev->timing.mode)) {
        /* Flagged whatever the status; a status already not valid says more, so it stays. */
        result->flags |= VL53_RESULT_IMPLAUSIBLE;
        if (result->range_status == (uint8_t)VL53_RANGE_VALID ||
            result->range_status == (uint8_t)VL53_RANGE_NO_WRAP_CHECK) {
            result->range_status = VL53_RANGE_IMPLAUSIBLE;
        }
    }
}

/*
 * Plausibility of the stream count. A count that does not follow from the last accepted
 * one is refused but remembered: when the next count follows from it, the sequence really
 * jumped (e.g. the part restarted ranging) and is adopted, so one garbled count costs one
 * refused result and a true discontinuity two.
 */
static int check_stream(struct vl53_dev *dev, struct vl53_result *result) {
    const uint32_t period_us = vl53_period_us(&dev->timing);
    uint32_t since = dev->have_stream ? dev->last_result_us : dev->ranging_start_us;
    uint32_t possible = ranges_possible(hal_time_elapsed_us(result->time_us, since), period_us);
    int advance;
    if (dev->have_stream) {
        advance = stream_advance(dev->last_stream, result->stream_count);
        if (advance == 0) {
            return HAL_ERR_CORRUPT; /* data ready claimed, but the block is the one we had */
        }
    } else {
        /* The first result after a start: the part's count does not restart at 0 after a
         * stop ([I14]), so any value can come; nothing to check it against. */
        dev->have_candidate = false;
        result->flags |= VL53_RESULT_FIRST;
        return HAL_OK;
    }
    if (advance < 0 || (uint32_t)advance > possible) {
        int from_candidate =
            dev->have_candidate ? stream_advance(dev->candidate_stream, result->stream_count) : -1;
        uint32_t possible_from_candidate =
            ranges_possible(hal_time_elapsed_us(result->time_us, dev->candidate_us), period_us);
        if (from_candidate < 1 || (uint32_t)from_candidate > possible_from_candidate) {
            dev->have_candidate = true;
            dev->candidate_stream = result->stream_count;
            dev->candidate_us = result->time_us;
            return HAL_ERR_CORRUPT;
        }
        advance = from_candidate;
    }
    dev->have_candidate = false;
    result->missed = (uint8_t)(advance - 1 > 255 ? 255 : advance - 1);
    return HAL_OK;
}

static int read_result_in(const struct call *c, struct vl53_result *result) {
    struct vl53_dev *dev = c->dev;
    uint8_t block[VL53_RESULT_BLOCK_LEN];
    int err = call_read(c, dev->address, VL53_REG_RESULT_RANGE_STATUS, block, sizeof block);
    if (err != HAL_OK) {
        return err;
    }
    decode_result(block, now_us(dev), result);
    if (!dev->have_stream || result->stream_count != dev->last_stream) {
        /* The part produced something new, even if it fails the checks below: data is not
         * overdue (a stuck or dead part is what the deadline is for). */
        dev->data_deadline_us = result->time_us + overdue_after_us(vl53_period_us(&dev->timing));
    }
    if (result->range_status == (uint8_t)VL53_RANGE_UNKNOWN) {
        return HAL_ERR_CORRUPT; /* a raw status the part does not produce: garbled read */
    }
    const uint8_t raw = result->raw_status;
    if (raw == VL53_RAW_VCSEL_CONTINUITY_FAIL || raw == VL53_RAW_VCSEL_WATCHDOG_FAIL ||
        raw == VL53_RAW_NO_VHV_VALUE || raw == VL53_RAW_MULTCLIP_FAIL) {
        /* The part reports its own hardware fault ([SSD]): not the bus's. Read the status
         * again first: a garbled read must not cost the sensor a re-initialisation. */
        uint8_t again = 0u;
        err = call_read(c, dev->address, VL53_REG_RESULT_RANGE_STATUS, &again, 1u);
        if (err != HAL_OK) {
            return err;
        }
        if ((again & VL53_RANGE_STATUS_RAW_MASK) != raw) {
            return HAL_ERR_CORRUPT;
        }
        result->flags |= VL53_RESULT_HW_FAULT;
        return HAL_ERR_DEVICE;
    }
    err = check_stream(dev, result);
    if (err != HAL_OK) {
        return err;
    }
    mark_result(dev, result);
    if (dev->cfg->verify_distance) {
        uint8_t again[2];
        err = call_read(c, dev->address, VL53_REG_RESULT_DISTANCE, again, sizeof again);
        if (err != HAL_OK) {
            return err;
        }
        if (hal_get_be16(again) != result->distance_mm) {
            return HAL_ERR_CORRUPT;
        }
    }
    dev->last_stream = result->stream_count;
    dev->have_stream = true;
    dev->last_result_us = result->time_us;
    return HAL_OK;
}

int vl53_read_result(struct vl53_dev *dev, struct vl53_result *result) {
    if (!dev_ok(dev) || result == NULL) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    return read_result_in(&c, result);
}

/* Bus errors mean the part may not have seen us: no point clearing its interrupt. */
static bool is_bus_error(int err) {
    return err == HAL_ERR_ADDR_NACK || err == HAL_ERR_DATA_NACK || err == HAL_ERR_BUS_BUSY ||
           err == HAL_ERR_TIMEOUT || err == HAL_ERR_BUS_STUCK;
}

int vl53_poll(struct vl53_dev *dev, struct vl53_result *result) {
    if (!dev_ok(dev) || result == NULL) {
        return HAL_ERR_INVALID;
    }
    if (!dev->ranging) {
        return HAL_ERR_STATE;
    }
    struct call c = call_begin(dev, call_budget(dev));
    const uint32_t now = c.start_us;
    bool ready = false;
    bool by_register = false;
    int err = HAL_OK;
    const uint32_t interval = or_default(dev->cfg->poll_interval_us, VL53_DEFAULT_POLL_INTERVAL_US);
    if (dev->cfg->gpio1_pin != VL53_PIN_NONE) {
        err = vl53_gpio1_ready(dev, &ready);
    } else if (time_reached(now, dev->next_register_poll_us)) {
        by_register = true;
        err = read_data_ready(&c, dev->cfg->polarity, &ready);
        dev->next_register_poll_us = now + interval;
    } else {
        /* the next measurement is not due yet: no bus traffic, not ready */
    }
    if (err != HAL_OK) {
        return err;
    }
    if (!ready) {
        return time_reached(now, dev->data_deadline_us) ? HAL_ERR_TIMEOUT : HAL_ERR_NOT_READY;
    }
    err = read_result_in(&c, result);
    if (is_bus_error(err)) {
        return err;
    }
    if (by_register && err == HAL_OK) {
        /* The range finished within the last interval: the next one is a period later.
         * (After a refused block keep polling every interval: the "ready" was not.) */
        uint32_t period_us = vl53_period_us(&dev->timing);
        dev->next_register_poll_us = now + (period_us > interval ? period_us - interval : 0u);
    }
    int clear_err = call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    return err != HAL_OK ? err : clear_err;
}
