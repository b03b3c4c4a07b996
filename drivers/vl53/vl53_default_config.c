/* ST's default configuration of the VL53L1X, registers 0x2D..0x87, as facts. */
/*
 * One line per register, its value and (where ST names it) its meaning.
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
    AT(0x2Du) = 0x00u, /* PAD_I2C_HV__CONFIG: bits 2, 5 = fast-mode plus; not used */
    AT(0x2Eu) = 0x00u, /* PAD_I2C_HV__EXTSUP_CONFIG: bit 0 = I2C pulled up at AVDD, not 1V8 */
    AT(0x2Fu) = 0x00u, /* GPIO_HV_PAD__CTRL: bit 0 = GPIO1 pulled up at AVDD, not 1V8 */
    AT(0x30u) = 0x01u, /* GPIO_HV_MUX__CTRL: bit 4 = active-low interrupt; bits 3:0 = 0x1 */
    AT(0x31u) = 0x02u, /* GPIO__TIO_HV_STATUS */
    AT(0x32u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x33u) = 0x02u, /* (ST: not user-modifiable) */
    AT(0x34u) = 0x08u, /* (ST: not user-modifiable) */
    AT(0x35u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x36u) = 0x08u, /* (ST: not user-modifiable) */
    AT(0x37u) = 0x10u, /* (ST: not user-modifiable) */
    AT(0x38u) = 0x01u, /* (ST: not user-modifiable) */
    AT(0x39u) = 0x01u, /* (ST: not user-modifiable) */
    AT(0x3Au) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x3Bu) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x3Cu) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x3Du) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x3Eu) = 0xFFu, /* (ST: not user-modifiable) */
    AT(0x3Fu) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x40u) = 0x0Fu, /* (ST: not user-modifiable) */
    AT(0x41u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x42u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x43u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x44u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x45u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x46u) = 0x20u, /* SYSTEM__INTERRUPT_CONFIG_GPIO: 0x20 = interrupt on new sample */
    AT(0x47u) = 0x0Bu, /* (ST: not user-modifiable) */
    AT(0x48u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x49u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x4Au) = 0x02u, /* (ST: not user-modifiable) */
    AT(0x4Bu) = 0x0Au, /* PHASECAL_CONFIG__TIMEOUT_MACROP: long distance mode */
    AT(0x4Cu) = 0x21u, /* (ST: not user-modifiable) */
    AT(0x4Du) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x4Eu) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x4Fu) = 0x05u, /* (ST: not user-modifiable) */
    AT(0x50u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x51u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x52u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x53u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x54u) = 0xC8u, /* (ST: not user-modifiable) */
    AT(0x55u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x56u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x57u) = 0x38u, /* (ST: not user-modifiable) */
    AT(0x58u) = 0xFFu, /* (ST: not user-modifiable) */
    AT(0x59u) = 0x01u, /* (ST: not user-modifiable) */
    AT(0x5Au) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x5Bu) = 0x08u, /* (ST: not user-modifiable) */
    AT(0x5Cu) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x5Du) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x5Eu) = 0x01u, /* RANGE_CONFIG__TIMEOUT_MACROP_A, high byte */
    AT(0x5Fu) = 0xCCu, /* ... low byte (0x01CC) */
    AT(0x60u) = 0x0Fu, /* RANGE_CONFIG__VCSEL_PERIOD_A (long mode) */
    AT(0x61u) = 0x01u, /* RANGE_CONFIG__TIMEOUT_MACROP_B, high byte */
    AT(0x62u) = 0xF1u, /* ... low byte: 0x01F1, in no ULD budget table */
    AT(0x63u) = 0x0Du, /* RANGE_CONFIG__VCSEL_PERIOD_B (long mode) */
    AT(0x64u) = 0x01u, /* RANGE_CONFIG__SIGMA_THRESH, 14.2 mm, high byte (90 mm) */
    AT(0x65u) = 0x68u, /* ... low byte */
    AT(0x66u) = 0x00u, /* RANGE_CONFIG__MIN_COUNT_RATE_RTN_LIMIT_MCPS, 9.7, high byte */
    AT(0x67u) = 0x80u, /* ... low byte */
    AT(0x68u) = 0x08u, /* (ST: not user-modifiable) */
    AT(0x69u) = 0xB8u, /* RANGE_CONFIG__VALID_PHASE_HIGH (long mode) */
    AT(0x6Au) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x6Bu) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x6Cu) = 0x00u, /* SYSTEM__INTERMEASUREMENT_PERIOD, 32-bit big endian */
    AT(0x6Du) = 0x00u, /* ... */
    AT(0x6Eu) = 0x0Fu, /* ... */
    AT(0x6Fu) = 0x89u, /* ... (0x00000F89) */
    AT(0x70u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x71u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x72u) = 0x00u, /* SYSTEM__THRESH_HIGH (mm), high byte */
    AT(0x73u) = 0x00u, /* ... low byte */
    AT(0x74u) = 0x00u, /* SYSTEM__THRESH_LOW (mm), high byte */
    AT(0x75u) = 0x00u, /* ... low byte */
    AT(0x76u) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x77u) = 0x01u, /* (ST: not user-modifiable) */
    AT(0x78u) = 0x0Fu, /* SD_CONFIG__WOI_SD0 (long mode) */
    AT(0x79u) = 0x0Du, /* SD_CONFIG__WOI_SD1 */
    AT(0x7Au) = 0x0Eu, /* SD_CONFIG__INITIAL_PHASE_SD0 */
    AT(0x7Bu) = 0x0Eu, /* SD_CONFIG__INITIAL_PHASE_SD1 */
    AT(0x7Cu) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x7Du) = 0x00u, /* (ST: not user-modifiable) */
    AT(0x7Eu) = 0x02u, /* (ST: not user-modifiable) */
    AT(0x7Fu) = 0xC7u, /* ROI_CONFIG__USER_ROI_CENTRE_SPAD */
    AT(0x80u) = 0xFFu, /* ROI_CONFIG__USER_ROI_REQUESTED_GLOBAL_XY_SIZE: 16 x 16 */
    AT(0x81u) = 0x9Bu, /* SYSTEM__SEQUENCE_CONFIG: VHV, phasecal, DSS1, DSS2, range enabled */
    AT(0x82u) = 0x00u, /* SYSTEM__GROUPED_PARAMETER_HOLD */
    AT(0x83u) = 0x00u, /* POWER_MANAGEMENT__GO1_POWER_FORCE */
    AT(0x84u) = 0x00u, /* SYSTEM__STREAM_COUNT_CTRL: bit 0 retain stream count */
    AT(0x85u) = 0x01u, /* FIRMWARE__ENABLE */
    AT(0x86u) = 0x00u, /* SYSTEM__INTERRUPT_CLEAR */
    AT(0x87u) = 0x00u, /* SYSTEM__MODE_START: stopped */
};
/* clang-format on */
