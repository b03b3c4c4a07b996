/*
 * The reference the bring-up tests hold the driver and the model against: the register
 * image 0x2D..0x87 that ST's Ultra Lite Driver leaves on a VL53L1X for a given distance
 * mode, budget and period, derived step by step from its documented sequence
 * (STSW-IMG009 VL53L1X_api.c): VL53L1X_SensorInit (its table VL51L1X_DEFAULT_CONFIGURATION,
 * pad bits 0x2E/0x2F bit 0 set for pull-ups at AVDD as its comments say, then the VHV
 * range), VL53L1X_SetInterruptPolarity, VL53L1X_SetDistanceMode, VL53L1X_SetTimingBudgetInMs,
 * VL53L1X_SetInterMeasurementInMs, VL53L1X_ClearInterrupt, VL53L1X_StartRanging. The table
 * here is transcribed independently of the driver's, from the Linux IIO driver's copy
 * (drivers/iio/proximity/vl53l1x-i2c.c, vl53l1x_default_config), so a wrong byte in either
 * shows.
 */
#ifndef ULD_REFERENCE_H
#define ULD_REFERENCE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define ULD_BLOCK_FIRST 0x2Du
#define ULD_BLOCK_LEN   91u

extern const uint8_t uld_default_configuration[ULD_BLOCK_LEN];

/* The image 0x2D..0x87 after the sequence above with these settings (`long_mode`,
 * `budget_ms` one of the ULD's, `period_ms`, the part's OSC_CALIBRATE_VAL `osc`,
 * `active_high`, `pads_at_avdd`). False if the ULD has no such budget in that mode. */
bool uld_reference_image(bool long_mode, uint16_t budget_ms, uint32_t period_ms, uint16_t osc,
                         bool active_high, bool pads_at_avdd, uint8_t image[ULD_BLOCK_LEN]);

/* One single-byte register write as the bus carried it. */
struct uld_write {
    uint16_t reg;
    uint8_t value;
};

/*
 * ST's temperature update (STSW-IMG009 VL53L1X_StartTemperatureUpdate, as stm32duino/VL53L1X
 * carries it; /work/shared/calibration-notes.md "Temperature"), written here from those facts
 * alone: 0x0008 <- 0x81, 0x000B <- 0x92, 0x0087 <- 0x40 (start ranging), [data ready],
 * 0x0086 <- 0x01 (clear interrupt), 0x0087 <- 0x00 (stop), 0x0008 <- 0x09, 0x000B <- 0x00.
 * One addition is accepted, only directly before the start: 0x0086 <- 0x01, the clear of a
 * stale interrupt the bring-up makes too (a result left pending would end the data-ready
 * wait at once). `writes` are one sensor's writes from the first to the last of the
 * sequence. Returns -1 when they are that sequence, else the index of the first write that
 * departs from it (n when they stop short).
 */
int uld_temperature_update_check(const struct uld_write *writes, size_t n);

#endif /* ULD_REFERENCE_H */
