/*
 * VL53L1X register map: only the registers this driver and the device model use.
 *
 * Sources (facts only; no code was taken from them):
 *   [DS]  ST VL53L1X datasheet, DocID031281 (rev 2/3): 16-bit big-endian
 *         register index, default 8-bit address 0x52 (7-bit 0x29), boot time.
 *   [ULD] ST VL53L1X Ultra Lite Driver (STSW-IMG009) VL53L1X_api.c/.h and its
 *         user manual UM2510: register addresses, the timing-budget and
 *         distance-mode register values, range-status mapping, result layout.
 *   [API] ST VL53L1 full API core (vl53l1_core.c, VL53L1_update_ll_driver_rd_state):
 *         stream count behaviour.
 *   [REG] ST VL53L1 full API register map (vl53l1_register_map.h): register names and
 *         bit fields.
 *   [SSD] ST VL53L1 full API vl53l1_api.c (SetSimpleData): device statuses 1, 2, 3 and 17
 *         (VCSEL continuity, VCSEL watchdog, no VHV value, multi-clip) are
 *         VL53L1_RANGESTATUS_HARDWARE_FAIL; 9 with stream count 0 is RANGE_VALID_NO_WRAP_CHECK.
 *   [I4]  the register facts this project's driver was specified with.
 *   [P2P] ST full API vl53l1_register_map.h on 0x001E/0x0020/0x0022 (group
 *         "customer_nvm_managed": registers the part's firmware fills from its NVM at boot,
 *         vl53l1_api_core.c VL53L1_read_p2p_data: "G02 registers containing data copied from
 *         NVM"); [ULD] VL53L1X_SetOffset / GetOffset / CalibrateOffset (0x1E = offset x 4,
 *         inner and outer zeroed); vl53l1_register_settings.h (0x81 bits 5, 6 = MM1, MM2).
 *   [I14] a field report: boot state 0x02/0x03 seen at 0x00E5 on a part that kept power across an
 *         MCU reset; the block's first range measured at 103 ms (a field report).
 */
#ifndef VL53_REGS_H
#define VL53_REGS_H

/* 7-bit I²C address every part answers at after boot ([DS] §4: 8-bit 0x52). */
#define VL53_DEFAULT_ADDRESS 0x29u

/* --- identification and boot ---------------------------------------------- */
/* I2C_SLAVE__DEVICE_ADDRESS: write the new 7-bit address ([ULD] SetI2CAddress writes addr>>1). */
#define VL53_REG_I2C_SLAVE_DEVICE_ADDRESS 0x0001u
/* VHV_CONFIG__TIMEOUT_MACROP_LOOP_BOUND: [ULD] SensorInit writes 0x09 after the first range. */
#define VL53_REG_VHV_CONFIG_TIMEOUT_MACROP_LOOP_BOUND 0x0008u
#define VL53_VHV_LOOP_BOUND_TWO_BOUNDS                0x09u
/* [ULD] StartTemperatureUpdate writes 0x81 first: "full VHV". */
#define VL53_VHV_LOOP_BOUND_FULL 0x81u
/* VHV_CONFIG__INIT: [ULD] SensorInit writes 0 ("start VHV from the previous temperature"). */
#define VL53_REG_VHV_CONFIG_INIT 0x000Bu
/* [ULD] StartTemperatureUpdate writes 0x92 here before its range (and 0 after it). */
#define VL53_VHV_INIT_FULL 0x92u
/* FIRMWARE__SYSTEM_STATUS: 0 while booting; bit 0 set once a cold boot completed ([ULD]
 * BootState, [I4]); ST's examples wait only for a non-zero value, and a part that kept power
 * across an MCU reset reads 0x02 or 0x03 ([I14]): any non-zero value means booted. */
#define VL53_REG_FIRMWARE_SYSTEM_STATUS 0x00E5u
#define VL53_FIRMWARE_BOOTED_BIT        0x01u
/* IDENTIFICATION__MODEL_ID (16-bit read): 0xEACC on a VL53L1X ([ULD] GetSensorId, [I4]). */
#define VL53_REG_IDENTIFICATION_MODEL_ID 0x010Fu
#define VL53_MODEL_ID_VL53L1X            0xEACCu

/* --- the part's own range offsets ([P2P]) -------------------------------------
 * ALGO__PART_TO_PART_RANGE_OFFSET_MM: bits 12:0, signed, fixed point 11.2 (0.25 mm steps);
 * [ULD] SetOffset writes offset_mm x 4 here, CalibrateOffset computes that offset as target
 * minus the mean range measured with all three zeroed, so the part reports its range plus
 * this value. MM_CONFIG__INNER_OFFSET_MM / __OUTER_OFFSET_MM: 16-bit signed mm, used by the
 * MM1/MM2 steps (0x81 bits 5, 6), which ST's default block leaves off; [ULD] SetOffset zeroes
 * both. All three are loaded from the part's NVM at boot, six consecutive bytes. */
#define VL53_REG_ALGO_PART_TO_PART_RANGE_OFFSET_MM 0x001Eu
#define VL53_REG_MM_CONFIG_INNER_OFFSET_MM         0x0020u
#define VL53_REG_MM_CONFIG_OUTER_OFFSET_MM         0x0022u
#define VL53_OFFSET_REGS_LEN                       6u
#define VL53_PART_TO_PART_MASK                     0x1FFFu
#define VL53_PART_TO_PART_MIN_QMM                  (-4096)
#define VL53_PART_TO_PART_MAX_QMM                  4095

/* --- the vendor default-configuration block -------------------------------- */
/* [ULD] SensorInit writes its 91-byte default configuration to 0x2D..0x87. */
#define VL53_REG_DEFAULT_CONFIG_FIRST 0x002Du
#define VL53_DEFAULT_CONFIG_LEN       91u
/* PAD_I2C_HV__EXTSUP_CONFIG and GPIO_HV_PAD__CTRL: bit 0 set when the I²C lines / GPIO1 are
 * pulled up to AVDD rather than 1V8 ([ULD] comments on 0x2E and 0x2F of its table, [REG]). */
#define VL53_REG_PAD_I2C_HV_EXTSUP_CONFIG 0x002Eu
#define VL53_REG_GPIO_HV_PAD_CTRL         0x002Fu
#define VL53_PAD_AVDD_BIT                 0x01u
/* The block's own timing (long mode, timeout A 0x01CC, B 0x01F1) is not a ULD budget; its
 * first range, the VHV step's, takes about 100 ms (103 ms measured, [I14]). */
#define VL53_VHV_RANGE_TYPICAL_US 103000u

/* --- interrupt / GPIO1 ------------------------------------------------------ */
/* GPIO_HV_MUX__CTRL: bit 4 = 0 active-high, 1 active-low interrupt; bits 3:0 must be 0x1
 * ([ULD] SetInterruptPolarity and the comment on 0x30 in its default configuration). */
#define VL53_REG_GPIO_HV_MUX_CTRL         0x0030u
#define VL53_GPIO_HV_MUX_POLARITY_LOW_BIT 0x10u
#define VL53_GPIO_HV_MUX_LOW_NIBBLE       0x01u
/* GPIO__TIO_HV_STATUS: bit 0 is the interrupt line level; data is ready when it equals the
 * active level ([ULD] CheckForDataReady, [I4]). */
#define VL53_REG_GPIO_TIO_HV_STATUS  0x0031u
#define VL53_TIO_HV_STATUS_LEVEL_BIT 0x01u

/* --- distance mode ([ULD] SetDistanceMode: short / long register values) ---- */
#define VL53_REG_PHASECAL_CONFIG_TIMEOUT_MACROP 0x004Bu
#define VL53_PHASECAL_SHORT                     0x14u
#define VL53_PHASECAL_LONG                      0x0Au
#define VL53_REG_RANGE_CONFIG_VCSEL_PERIOD_A    0x0060u
#define VL53_REG_RANGE_CONFIG_VCSEL_PERIOD_B    0x0063u
#define VL53_VCSEL_PERIOD_A_SHORT               0x07u
#define VL53_VCSEL_PERIOD_B_SHORT               0x05u
#define VL53_VCSEL_PERIOD_A_LONG                0x0Fu
#define VL53_VCSEL_PERIOD_B_LONG                0x0Du
#define VL53_REG_RANGE_CONFIG_VALID_PHASE_HIGH  0x0069u
#define VL53_VALID_PHASE_HIGH_SHORT             0x38u
#define VL53_VALID_PHASE_HIGH_LONG              0xB8u
/* SD_CONFIG__WOI_SD0, WOI_SD1 (0x78, 0x79), INITIAL_PHASE_SD0, SD1 (0x7A, 0x7B). */
#define VL53_REG_SD_CONFIG_WOI_SD0 0x0078u
#define VL53_WOI_SD0_SHORT         0x07u
#define VL53_WOI_SD1_SHORT         0x05u
#define VL53_INITIAL_PHASE_SHORT   0x06u
#define VL53_WOI_SD0_LONG          0x0Fu
#define VL53_WOI_SD1_LONG          0x0Du
#define VL53_INITIAL_PHASE_LONG    0x0Eu

/* --- timing budget ([ULD] SetTimingBudgetInMs: 16-bit A and B macro-period timeouts) --- */
#define VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_A 0x005Eu /* 16-bit, 0x5E..0x5F */
#define VL53_REG_RANGE_CONFIG_TIMEOUT_MACROP_B 0x0061u /* 16-bit, 0x61..0x62 */

/* --- inter-measurement period ---------------------------------------------- */
/* SYSTEM__INTERMEASUREMENT_PERIOD (32-bit) = period_ms * clock_pll * 1.075, where clock_pll
 * is RESULT__OSC_CALIBRATE_VAL & 0x3FF ([ULD] SetInterMeasurementInMs). */
#define VL53_REG_SYSTEM_INTERMEASUREMENT_PERIOD 0x006Cu
#define VL53_REG_RESULT_OSC_CALIBRATE_VAL       0x00DEu
#define VL53_OSC_CALIBRATE_MASK                 0x03FFu
#define VL53_IMP_FACTOR_PER_MILLE               1075u /* the 1.075 factor, in thousandths */

/* --- ranging control ------------------------------------------------------- */
/* SYSTEM__INTERRUPT_CLEAR: write 0x01 to clear the data-ready interrupt ([ULD], [I4]). */
#define VL53_REG_SYSTEM_INTERRUPT_CLEAR 0x0086u
#define VL53_INTERRUPT_CLEAR            0x01u
/* SYSTEM__MODE_START: 0x40 starts timed (continuous) ranging, 0x00 stops ([ULD], [I4]). */
#define VL53_REG_SYSTEM_MODE_START 0x0087u
#define VL53_MODE_START_TIMED      0x40u
#define VL53_MODE_STOP             0x00u

/* --- result block ([ULD] GetResult reads 17 bytes from 0x0089) --------------- */
#define VL53_REG_RESULT_RANGE_STATUS 0x0089u
#define VL53_RESULT_BLOCK_LEN        17u
/* Offsets inside the block (register address − 0x0089). */
#define VL53_RESULT_OFS_RANGE_STATUS 0u /* RESULT__RANGE_STATUS, low 5 bits = raw status */
#define VL53_RESULT_OFS_REPORT       1u /* RESULT__REPORT_STATUS (unused) */
#define VL53_RESULT_OFS_STREAM_COUNT 2u /* RESULT__STREAM_COUNT (0x008B) */
#define VL53_RESULT_OFS_SPADS        3u /* DSS_ACTUAL_EFFECTIVE_SPADS_SD0 (0x008C), 8.8: high byte */
#define VL53_RESULT_OFS_AMBIENT      7u  /* AMBIENT_COUNT_RATE_MCPS_SD0 (0x0090), 9.7 MCPS */
#define VL53_RESULT_OFS_DISTANCE     13u /* FINAL_CROSSTALK_CORRECTED_RANGE_MM_SD0 (0x0096) */
#define VL53_RESULT_OFS_SIGNAL       15u /* PEAK_SIGNAL_COUNT_RATE_CROSSTALK_CORRECTED_MCPS_SD0 */
#define VL53_REG_RESULT_DISTANCE     0x0096u
#define VL53_RANGE_STATUS_RAW_MASK   0x1Fu
/* Raw device statuses the driver treats specially ([SSD], [REG] VL53L1_DEVICEERROR_*). */
#define VL53_RAW_VCSEL_CONTINUITY_FAIL 1u
#define VL53_RAW_VCSEL_WATCHDOG_FAIL   2u
#define VL53_RAW_NO_VHV_VALUE          3u
#define VL53_RAW_RANGE_COMPLETE        9u
#define VL53_RAW_MULTCLIP_FAIL         17u
/* [ULD] reports the 9.7-format MCPS rates times 8 as kcps (2^7 / 1000 ~ 1/8). */
#define VL53_RATE_TO_KCPS_FACTOR 8u

/*
 * RESULT__STREAM_COUNT: 0 on the first range after a start, then +1 per range, wrapping
 * from 0xFF to 0x80 (never back below 0x80 until ranging restarts) ([API]).
 */
#define VL53_STREAM_COUNT_WRAP_TO 0x80u

/* --- the part's NVM, read for its identity (vl53_nvm.c) ----------------------------------
 * [NVM] ST full API: vl53l1_register_map.h (POWER_MANAGEMENT__GO1_POWER_FORCE 0x0083,
 * FIRMWARE__ENABLE 0x0085, RANGING_CORE__CLK_CTRL1 0x0683, RANGING_CORE__NVM_CTRL__MODE
 * 0x0780, __PDN 0x0781, __READN 0x0783, __PULSE_WIDTH_MSB 0x0784, __DATAOUT_MMM..LLL
 * 0x0790..0x0793, __ADDR 0x0794; e.g. the copy in zephyrproject-rtos/zephyr
 * ext/hal/st/lib/sensor/vl53l1x/api/core/inc); the sequence of VL53L1_nvm_enable, _read and
 * _disable (vl53l1_nvm.c / vl53l1_api.c): firmware off, power force on, 250 us
 * (VL53L1_ENABLE_POWERFORCE_SETTLING_TIME_US, vl53l1_ll_device.h), NVM power up (PDN 1) and
 * clock (CLK_CTRL1 0x05), 50 us (VL53L1_NVM_POWER_UP_DELAY_US), read mode (MODE 1), pulse
 * width 0x0004; per 32-bit word: ADDR = word, READN 0, 5 us (VL53L1_NVM_READ_TRIGGER_DELAY_US),
 * READN 1, 4 bytes from DATAOUT_MMM (NVM byte 4·word first); then READN 1, PDN 0, power
 * force off, firmware on. vl53l1_nvm_map.h: NVM bytes 0x1F8..0x1FF hold the EWS lot (six
 * 6-bit characters), wafer (0x1FD bits 4:0), die X (0x1FE) and Y (0x1FF) coordinates:
 * words 0x7E and 0x7F. */
#define VL53_REG_POWER_FORCE         0x0083u
#define VL53_REG_FIRMWARE_ENABLE     0x0085u
#define VL53_REG_CLK_CTRL1           0x0683u
#define VL53_CLK_CTRL1_NVM_CLOCK     0x05u
#define VL53_REG_NVM_MODE            0x0780u
#define VL53_REG_NVM_PDN             0x0781u
#define VL53_REG_NVM_READN           0x0783u
#define VL53_REG_NVM_PULSE_WIDTH_MSB 0x0784u
#define VL53_NVM_PULSE_WIDTH_MSB     0x00u /* the pulse width 0x0004, high byte */
#define VL53_NVM_PULSE_WIDTH_LSB     0x04u
#define VL53_REG_NVM_DATAOUT         0x0790u
#define VL53_REG_NVM_ADDR            0x0794u
#define VL53_POWER_FORCE_SETTLE_US   250u
#define VL53_NVM_POWER_UP_US         50u
#define VL53_NVM_READ_TRIGGER_US     5u
#define VL53_NVM_ID_FIRST_WORD       0x7Eu /* NVM byte 0x1F8 */
#define VL53_NVM_ID_WORDS            2u

#endif /* VL53_REGS_H */
