/*
 * Where a simulated VL53 device gets its distances: the contract between the
 * device models (sim/) and what feeds them (a scene, a recorded trace).
 * Integer only, so the same models link into the QEMU images.
 */
#ifndef SIM_RANGE_SOURCE_H
#define SIM_RANGE_SOURCE_H

#include <stdbool.h>
#include <stdint.h>

/* One reading as the sensor would report it. */
struct sim_range {
    uint16_t distance_mm; /* integer millimetres, as VL53 parts report */
    uint8_t range_status; /* ULD range status code: 0 valid, 1 sigma fail, 2 signal fail, ... */
    bool present;         /* false: the sensor produced no reading for this sample (dropout) */
};

struct sim_range_source_ops {
    /*
     * Reading number `sample_index` (0, 1, 2, ... one per completed measurement)
     * of sensor `sensor` (0..3 = A..D). Returns 0 and fills *out, 1 when the
     * source has no more samples, or a negative error (the source's data is bad).
     */
    int (*next)(void *ctx, unsigned sensor, uint32_t sample_index, struct sim_range *out);
};

struct sim_range_source {
    const struct sim_range_source_ops *ops;
    void *ctx;
};

#endif /* SIM_RANGE_SOURCE_H */
