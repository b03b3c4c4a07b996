/* VL53 driver: ranging, data ready, and the result stream with its checks. */
#include <stddef.h>

#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53/vl53.h"
#include "vl53_internal.h"

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

bool vl53_is_ranging(const struct vl53_dev *dev) {
    return dev_ok(dev) && dev->ranging;
}

bool vl53_data_overdue(const struct vl53_dev *dev) {
    return dev_ok(dev) && dev->ranging && time_reached(now_us(dev), dev->data_deadline_us);
}

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
    int err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    if (err == HAL_OK) {
        err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_START_TIMED);
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
    int err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_MODE_START, VL53_MODE_STOP);
    if (err == HAL_OK) {
        vl53_forget_ranging(dev);
    }
    return err;
}

int vl53_data_ready(struct vl53_dev *dev, bool *ready) {
    if (!dev_ok(dev) || ready == NULL) {
        return HAL_ERR_INVALID;
    }
    struct call c = call_begin(dev, call_budget(dev));
    return vl53_read_data_ready(&c, dev->cfg->polarity, ready);
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
    return vl53_call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
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
    int err = vl53_call_read(c, dev->address, VL53_REG_RESULT_RANGE_STATUS, block, sizeof block);
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
        err = vl53_call_read(c, dev->address, VL53_REG_RESULT_RANGE_STATUS, &again, 1u);
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
        err = vl53_call_read(c, dev->address, VL53_REG_RESULT_DISTANCE, again, sizeof again);
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
        err = vl53_read_data_ready(&c, dev->cfg->polarity, &ready);
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
    int clear_err = vl53_call_write_byte(&c, VL53_REG_SYSTEM_INTERRUPT_CLEAR, VL53_INTERRUPT_CLEAR);
    return err != HAL_OK ? err : clear_err;
}
