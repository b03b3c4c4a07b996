/*
 * Temperature interface: one reading of the board's temperature sensor, in centi-degrees
 * Celsius. Which sensor a board reads (the MCU die, a thermistor on the sensor head) is the
 * board's and is said in docs/explanation/boards.md.
 */
#ifndef HAL_TEMP_H
#define HAL_TEMP_H

#include <stdint.h>

/* The plausible range of any reading, in centi-degrees Celsius: wider than every part's
 * operating range (STM32L4/G0 junction -40..130 °C, VL53L1X -20..85 °C) by the factory
 * calibration's tolerance. A conversion outside it is a fault, never a temperature. */
#define HAL_TEMP_MIN_CDEG (-5500)
#define HAL_TEMP_MAX_CDEG 15000

struct hal_temp_ops {
    /*
     * Measure the temperature now. HAL_OK with *cdeg in HAL_TEMP_MIN_CDEG..HAL_TEMP_MAX_CDEG;
     * or a hal error with *cdeg unchanged: HAL_ERR_TIMEOUT (a conversion step did not
     * finish within its bound), HAL_ERR_CORRUPT (a calibration word or the result is
     * implausible: reported, never clamped), HAL_ERR_NOT_READY (no value to give now).
     * Bounded: returns within the implementation's stated worst case.
     */
    int (*read_cdeg)(void *ctx, int16_t *cdeg);
};

struct hal_temp {
    const struct hal_temp_ops *ops; /* NULL: the board has no temperature sensor */
    void *ctx;
};

#endif /* HAL_TEMP_H */
