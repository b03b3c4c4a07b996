/* The VL53L1X model's ranging engine: the timing a start decodes, the measurements due on
 * the simulated clock, and the result block each one publishes (sim_vl53.c owns the
 * registers and the bus; it calls down into this file, never the reverse). */
#include <stddef.h>

#include "sim/sim_vl53.h"
#include "sim_vl53_model.h"
#include "sim_vl53_regs.h"

#define MODEL_SPADS_8_8 0x2000u /* 32 effective SPADs: a plausible value, not a fact */
#define MODEL_SIGMA     0x0020u

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

/* The range the part reports for the source's `distance_mm`: plus 0x1E / 4 mm ([OFS]),
 * rounded half up and kept in 0..8189, when it is a range at all (not 0, not a no-target
 * code at or above 8190). */
static uint16_t with_offset(const struct sim_vl53 *dev, uint16_t distance_mm) {
    if (distance_mm == 0u || distance_mm >= M_NO_TARGET_MM) {
        return distance_mm;
    }
    const uint16_t field = be16_at(dev->regs, M_PART_TO_PART_OFFSET) & 0x1FFFu;
    const int32_t qmm = (field & 0x1000u) != 0u ? (int32_t)field - 0x2000 : (int32_t)field;
    const int32_t quarters = (int32_t)distance_mm * 4 + qmm + 2; /* + 2: round half up */
    if (quarters < 0) {
        return 0u; /* a target closer than the offset: clipped at the window */
    }
    const int32_t reported = quarters / 4;
    return (uint16_t)(reported < (int32_t)M_NO_TARGET_MM ? reported : (int32_t)M_NO_TARGET_MM - 1);
}

static struct sim_range constant_range(void) {
    struct sim_range r = {100u, 0u, true};
    return r;
}

/* Write one result into the block and raise the interrupt. */
static void publish(struct sim_vl53 *dev, const struct sim_range *range, uint32_t sample_index,
                    uint64_t time_us) {
    /* Stream count: 0 on the first range after power-up, then +1, 0xFF wraps to 0x80 ([API]);
     * it does not restart at a later start (the model's choice, see docs). */
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
        distance_mm = with_offset(dev, distance_mm); /* the source's status, the part's range */
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
uint64_t sim_vl53_next_event_us(const struct sim_vl53 *dev) {
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
void sim_vl53_reschedule(struct sim_vl53 *dev) {
    dev->next_event_us = sim_vl53_next_event_us(dev);
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
    dev->next_event_us = sim_vl53_next_event_us(dev);
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

void sim_vl53_start_ranging(struct sim_vl53 *dev) {
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
