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
#include <stdint.h>

#define ULD_BLOCK_FIRST 0x2Du
#define ULD_BLOCK_LEN   91u

extern const uint8_t uld_default_configuration[ULD_BLOCK_LEN];

/* The image 0x2D..0x87 after the sequence above with these settings (`long_mode`,
 * `budget_ms` one of the ULD's, `period_ms`, the part's OSC_CALIBRATE_VAL `osc`,
 * `active_high`, `pads_at_avdd`). False if the ULD has no such budget in that mode. */
bool uld_reference_image(bool long_mode, uint16_t budget_ms, uint32_t period_ms, uint16_t osc,
                         bool active_high, bool pads_at_avdd, uint8_t image[ULD_BLOCK_LEN]);

#endif /* ULD_REFERENCE_H */
