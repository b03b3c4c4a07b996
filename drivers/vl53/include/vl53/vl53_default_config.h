/*
 * ST's default configuration of the VL53L1X for registers 0x2D..0x87 (91 bytes), which
 * every working driver writes after boot (ST ULD VL53L1X_SensorInit). Facts and their
 * sources: vl53_default_config.c.
 */
#ifndef VL53_DEFAULT_CONFIG_H
#define VL53_DEFAULT_CONFIG_H

#include <stdint.h>

#include "vl53/vl53_regs.h"

/* Byte k is the value of register VL53_REG_DEFAULT_CONFIG_FIRST + k. */
extern const uint8_t vl53_default_config[VL53_DEFAULT_CONFIG_LEN];

#endif /* VL53_DEFAULT_CONFIG_H */
