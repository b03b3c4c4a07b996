/*
 * Sample assembly: four sensors range freely at one nominal period; their
 * readings are grouped into four-sensor samples by time slot. Slot k covers
 * [origin + k·period, origin + (k+1)·period); it is emitted as soon as all four
 * sensors have reported for it, or once its end plus the maximum skew has
 * passed, with the sensors that did not report marked missing. Slots in which
 * nothing arrived are still emitted (all missing), so sample k is always slot
 * k: windows counted in samples stay aligned with time (and with trace rows).
 * Pure logic over a 64-bit microsecond timeline; no I/O.
 */
#ifndef FIRMWARE_ASSEMBLER_H
#define FIRMWARE_ASSEMBLER_H

#include <stdbool.h>
#include <stdint.h>

#define TOF_SENSOR_COUNT 4u

/* One four-sensor sample. present_mask bit i set: sensor i reported in this slot. */
struct tof_sample {
    uint32_t index; /* slot number since ranging started */
    uint64_t t_us;  /* end of the slot on the firmware timeline */
    uint16_t range_mm[TOF_SENSOR_COUNT];
    uint8_t status[TOF_SENSOR_COUNT]; /* ULD range status, 0 = valid */
    uint8_t present_mask;
    /* The head's temperature read as the sample was assembled (the application's, never the
     * assembler's: false here). */
    bool temp_known;
    int16_t temp_cdeg; /* 0.01 °C, when temp_known */
};

/* Where assembled samples go: emit(ctx, sample) for each (docs/explanation/architecture.md ops
 * convention). */
struct tof_sample_sink {
    void (*emit)(void *ctx, const struct tof_sample *sample);
    void *ctx;
};

struct tof_assembler_config {
    uint32_t period_us;        /* nominal measurement period of every sensor (> 0) */
    uint32_t max_skew_us;      /* how long after a slot's end its late readings are still awaited */
    uint8_t max_emit_per_call; /* bound on samples emitted by one call (>= 1) */
};

struct tof_assembler_counters {
    uint32_t emitted;
    uint32_t incomplete; /* emitted with at least one sensor missing */
    uint32_t late;       /* readings for a slot already emitted (counted, not used) */
    uint32_t duplicates; /* second reading of a sensor within one slot (counted, not used) */
};

struct tof_assembler {
    uint64_t origin_us;
    uint32_t next_index;          /* oldest slot not yet emitted */
    struct tof_sample pending[2]; /* slots next_index and next_index + 1 */
    struct tof_assembler_counters counters;
};

/* Start assembling: slot 0 begins at `origin_us`. */
void tof_assembler_init(struct tof_assembler *a, uint64_t origin_us);

/*
 * Add a reading of `sensor` (0..3) taken at `t_us` (>= origin). Readings for a
 * slot already emitted are counted as late; a reading two slots ahead first
 * emits older slots. Samples go to `sink`, at most max_emit_per_call of them.
 */
void tof_assembler_add(struct tof_assembler *a, const struct tof_assembler_config *cfg,
                       unsigned sensor, uint64_t t_us, uint16_t range_mm, uint8_t status,
                       const struct tof_sample_sink *sink);

/* Emit every slot whose end + max skew is before `now_us` (at most max_emit_per_call). */
void tof_assembler_poll(struct tof_assembler *a, const struct tof_assembler_config *cfg,
                        uint64_t now_us, const struct tof_sample_sink *sink);

#endif /* FIRMWARE_ASSEMBLER_H */
