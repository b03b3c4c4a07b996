/* Sample assembly: the four sensors' readings grouped into samples by time slot
 * (firmware/assembler.h). */
#include "firmware/assembler.h"

#include <string.h>

#define ALL_SENSORS ((uint8_t)((1u << TOF_SENSOR_COUNT) - 1u))

static void reset_slot(struct tof_sample *s, uint32_t index, uint64_t end_us) {
    memset(s, 0, sizeof *s);
    s->index = index;
    s->t_us = end_us;
}

static uint64_t slot_end(const struct tof_assembler *a, const struct tof_assembler_config *cfg,
                         uint32_t index) {
    return a->origin_us + ((uint64_t)index + 1u) * cfg->period_us;
}

/* Emit pending[0] and shift the two-slot window by one. */
static void emit_oldest(struct tof_assembler *a, const struct tof_assembler_config *cfg,
                        const struct tof_sample_sink *sink) {
    ++a->counters.emitted;
    if (a->pending[0].present_mask != ALL_SENSORS) {
        ++a->counters.incomplete;
    }
    sink->emit(sink->ctx, &a->pending[0]);
    a->pending[0] = a->pending[1];
    ++a->next_index;
    reset_slot(&a->pending[1], a->next_index + 1u, slot_end(a, cfg, a->next_index + 1u));
}

void tof_assembler_init(struct tof_assembler *a, uint64_t origin_us) {
    memset(a, 0, sizeof *a);
    a->origin_us = origin_us;
    /* Slot ends depend on the period, known only with a config: set lazily. */
    a->pending[0].index = 0;
    a->pending[1].index = 1;
}

void tof_assembler_add(struct tof_assembler *a, const struct tof_assembler_config *cfg,
                       unsigned sensor, uint64_t t_us, uint16_t range_mm, uint8_t status,
                       const struct tof_sample_sink *sink) {
    if (sensor >= TOF_SENSOR_COUNT || t_us < a->origin_us) {
        ++a->counters.late; /* before ranging started: cannot belong to any slot */
        return;
    }
    const uint64_t slot64 = (t_us - a->origin_us) / cfg->period_us;
    if (slot64 < a->next_index) {
        ++a->counters.late;
        return;
    }
    /* Make room: the reading's slot must be one of the two pending ones. */
    for (uint8_t n = 0; slot64 > (uint64_t)a->next_index + 1u; ++n) {
        if (n >= cfg->max_emit_per_call) {
            ++a->counters.late; /* too far ahead to catch up in one call: counted */
            return;
        }
        emit_oldest(a, cfg, sink);
    }
    struct tof_sample *s = &a->pending[slot64 == a->next_index ? 0 : 1];
    s->t_us = slot_end(a, cfg, s->index);
    const uint8_t bit = (uint8_t)(1u << sensor);
    if ((s->present_mask & bit) != 0u) {
        ++a->counters.duplicates;
        return;
    }
    s->present_mask = (uint8_t)(s->present_mask | bit);
    s->range_mm[sensor] = range_mm;
    s->status[sensor] = status;
    for (uint8_t n = 0; a->pending[0].present_mask == ALL_SENSORS && n < 2u; ++n) {
        emit_oldest(a, cfg, sink); /* complete: no need to wait for the deadline */
    }
}

void tof_assembler_poll(struct tof_assembler *a, const struct tof_assembler_config *cfg,
                        uint64_t now_us, const struct tof_sample_sink *sink) {
    for (uint8_t n = 0; n < cfg->max_emit_per_call; ++n) {
        const uint64_t deadline = slot_end(a, cfg, a->next_index) + cfg->max_skew_us;
        if (now_us <= deadline) {
            return;
        }
        a->pending[0].t_us = slot_end(a, cfg, a->next_index);
        emit_oldest(a, cfg, sink);
    }
}
