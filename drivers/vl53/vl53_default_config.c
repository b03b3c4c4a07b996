/*
 * ST's default configuration of the VL53L1X, registers 0x2D..0x87, as facts: one line per
 * register, its value and (where ST names it) its meaning.
 *
 * Source: ST VL53L1X Ultra Lite Driver STSW-IMG009, VL53L1X_api.c, table
 * VL51L1X_DEFAULT_CONFIGURATION (ST publishes it dual-licensed, BSD-3-Clause). Cross-checked
 * byte for byte against an independent transcription, the Linux IIO driver
 * drivers/iio/proximity/vl53l1x-i2c.c (vl53l1x_default_config). An older ULD release had
 * 0xDB at 0x5F; the current one and the Linux driver have 0xCC (timeout A = 0x01CC).
 * ST documents most of these only as "not user-modifiable"; register names are those of
 * ST's full API register map (vl53l1_register_map.h).
 */
#include "vl53/vl53_default_config.h"

#define AT(reg) [(reg)-VL53_REG_DEFAULT_CONFIG_FIRST]

/* clang-format off: one line per register */
const uint8_t vl53_default_config[VL53_DEFAULT_CONFIG_LEN] = {
    AT(0x2D) = 0x00u, /* PAD_I2C_HV__CONFIG: bits 2, 5 = fast-mode plus; not used */
    AT(0x2E) = 0x00u, /* PAD_I2C_HV__EXTSUP_CONFIG: bit 0 = I2C pulled up at AVDD, not 1V8 */
    AT(0x2F) = 0x00u, /* GPIO_HV_PAD__CTRL: bit 0 = GPIO1 pulled up at AVDD, not 1V8 */
    AT(0x30) = 0x01u, /* GPIO_HV_MUX__CTRL: bit 4 = active-low interrupt; bits 3:0 = 0x1 */
    AT(0x31) = 0x02u, /* GPIO__TIO_HV_STATUS */
    AT(0x32) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x33) = 0x02u, /* (ST: not user-modifiable) */
    AT(0x34) = 0x08u, /* (ST: not user-modifiable) */
    AT(0x35) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x36) = 0x08u, /* (ST: not user-modifiable) */
    AT(0x37) = 0x10u, /* (ST: not user-modifiable) */
    AT(0x38) = 0x01u, /* (ST: not user-modifiable) */
    AT(0x39) = 0x01u, /* (ST: not user-modifiable) */
    AT(0x3A) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x3B) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x3C) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x3D) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x3E) = 0xFFu, /* (ST: not user-modifiable) */
    AT(0x3F) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x40) = 0x0Fu, /* (ST: not user-modifiable) */
    AT(0x41) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x42) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x43) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x44) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x45) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x46) = 0x20u, /* SYSTEM__INTERRUPT_CONFIG_GPIO: 0x20 = interrupt on new sample */
    AT(0x47) = 0x0Bu, /* (ST: not user-modifiable) */
    AT(0x48) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x49) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x4A) = 0x02u, /* (ST: not user-modifiable) */
    AT(0x4B) = 0x0Au, /* PHASECAL_CONFIG__TIMEOUT_MACROP: long distance mode */
    AT(0x4C) = 0x21u, /* (ST: not user-modifiable) */
    AT(0x4D) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x4E) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x4F) = 0x05u, /* (ST: not user-modifiable) */
    AT(0x50) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x51) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x52) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x53) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x54) = 0xC8u, /* (ST: not user-modifiable) */
    AT(0x55) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x56) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x57) = 0x38u, /* (ST: not user-modifiable) */
    AT(0x58) = 0xFFu, /* (ST: not user-modifiable) */
    AT(0x59) = 0x01u, /* (ST: not user-modifiable) */
    AT(0x5A) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x5B) = 0x08u, /* (ST: not user-modifiable) */
    AT(0x5C) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x5D) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x5E) = 0x01u, /* RANGE_CONFIG__TIMEOUT_MACROP_A, high byte */
    AT(0x5F) = 0xCCu, /* ... low byte (0x01CC) */
    AT(0x60) = 0x0Fu, /* RANGE_CONFIG__VCSEL_PERIOD_A (long mode) */
    AT(0x61) = 0x01u, /* RANGE_CONFIG__TIMEOUT_MACROP_B, high byte */
    AT(0x62) = 0xF1u, /* ... low byte: 0x01F1, in no ULD budget table */
    AT(0x63) = 0x0Du, /* RANGE_CONFIG__VCSEL_PERIOD_B (long mode) */
    AT(0x64) = 0x01u, /* RANGE_CONFIG__SIGMA_THRESH, 14.2 mm, high byte (90 mm) */
    AT(0x65) = 0x68u, /* ... low byte */
    AT(0x66) = 0x00u, /* RANGE_CONFIG__MIN_COUNT_RATE_RTN_LIMIT_MCPS, 9.7, high byte */
    AT(0x67) = 0x80u, /* ... low byte */
    AT(0x68) = 0x08u, /* (ST: not user-modifiable) */
    AT(0x69) = 0xB8u, /* RANGE_CONFIG__VALID_PHASE_HIGH (long mode) */
    AT(0x6A) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x6B) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x6C) = 0x00u, /* SYSTEM__INTERMEASUREMENT_PERIOD, 32-bit big endian */
    AT(0x6D) = 0x00u, /* ... */
    AT(0x6E) = 0x0Fu, /* ... */
    AT(0x6F) = 0x89u, /* ... (0x00000F89) */
    AT(0x70) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x71) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x72) = 0x00u, /* SYSTEM__THRESH_HIGH (mm), high byte */
    AT(0x73) = 0x00u, /* ... low byte */
    AT(0x74) = 0x00u, /* SYSTEM__THRESH_LOW (mm), high byte */
    AT(0x75) = 0x00u, /* ... low byte */
    AT(0x76) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x77) = 0x01u, /* (ST: not user-modifiable) */
    AT(0x78) = 0x0Fu, /* SD_CONFIG__WOI_SD0 (long mode) */
    AT(0x79) = 0x0Du, /* SD_CONFIG__WOI_SD1 */
    AT(0x7A) = 0x0Eu, /* SD_CONFIG__INITIAL_PHASE_SD0 */
    AT(0x7B) = 0x0Eu, /* SD_CONFIG__INITIAL_PHASE_SD1 */
    AT(0x7C) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x7D) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x7E) = 0x02u, /* (ST: not user-modifiable) */
    AT(0x7F) = 0xC7u, /* ROI_CONFIG__USER_ROI_CENTRE_SPAD */
    AT(0x80) = 0xFFu, /* ROI_CONFIG__USER_ROI_REQUESTED_GLOBAL_XY_SIZE: 16 x 16 */
    AT(0x81) = 0x9Bu, /* SYSTEM__SEQUENCE_CONFIG: VHV, phasecal, DSS1, DSS2, range enabled */
    AT(0x82) = 0x00u, /* SYSTEM__GROUPED_PARAMETER_HOLD */
    AT(0x83) = 0x00u, /* POWER_MANAGEMENT__GO1_POWER_FORCE */
    AT(0x84) = 0x00u, /* SYSTEM__STREAM_COUNT_CTRL: bit 0 retain stream count */
    AT(0x85) = 0x01u, /* FIRMWARE__ENABLE */
    AT(0x86) = 0x00u, /* SYSTEM__INTERRUPT_CLEAR */
    AT(0x87) = 0x00u, /* SYSTEM__MODE_START: stopped */
};
/* clang-format on */
