/*
 * One four-sensor sample as a scene generator produces it and as a trace v1
 * file stores it (docs/reference/trace-format.md). Shared by the scene generators, the trace
 * reader/writer, host_sim replay and the estimator benchmark.
 */
#ifndef SCENE_ROW_H
#define SCENE_ROW_H

#include <stdbool.h>
#include <stdint.h>

/* Sensor order everywhere: A, B, C, D = 0..3 (docs/explanation/architecture.md). */
enum scene_sensor { SCENE_A = 0, SCENE_B = 1, SCENE_C = 2, SCENE_D = 3 };
#define SCENE_SENSORS 4u

/*
 * Range status written for a sensor that produced no reading at all (dropout).
 * 255 is the VL53L1 API's "no update" status (VL53L1_RANGESTATUS_NONE, ST UM2356);
 * the trace reader turns status 255 into present = false (docs/reference/trace-format.md).
 */
#define SCENE_STATUS_NO_READING 255u

struct scene_row {
    uint32_t t_ms;                    /* sample time, non-decreasing */
    uint16_t range_mm[SCENE_SENSORS]; /* integer millimetres, as VL53 parts report */
    uint8_t status[SCENE_SENSORS];    /* VL53L1X range status, 0 = valid */
    bool present[SCENE_SENSORS];      /* false: no reading (range 0, status 255) */
    bool has_alpha, has_beta;         /* ground truth available for this row */
    double alpha_deg, beta_deg;       /* ground truth (only meaningful if has_*) */
    bool has_distance;                /* truth x̄ (a trace's distance_mm column) */
    double distance_mm;
    bool temp_present; /* the head's temperature (a trace's temp_c column, not empty) */
    int16_t temp_cdeg; /* ... 0.01 °C */
};

/* True when sensor k of row is present with status 0 (a valid reading). */
static inline bool scene_row_valid(const struct scene_row *row, unsigned k) {
    return row->present[k] && row->status[k] == 0u;
}

#endif /* SCENE_ROW_H */
