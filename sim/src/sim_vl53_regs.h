/*
 * The VL53L1X register facts the device model uses, transcribed for the model on its own
 * (it shares nothing with the driver's vl53_regs.h, so a wrong constant on either side
 * shows as a disagreement in the tests).
 *
 * Sources (facts only; no code taken):
 *   [DS]  ST VL53L1X datasheet DocID031281: 16-bit big-endian index, 7-bit address 0x29,
 *         boot time tBOOT 1.2 ms max.
 *   [ULD] ST Ultra Lite Driver STSW-IMG009, VL53L1X_api.c: the default-configuration table
 *         VL51L1X_DEFAULT_CONFIGURATION (0x2D..0x87), SensorInit's VHV step, the budget
 *         tables of SetTimingBudgetInMs / GetTimingBudgetInMs, SetDistanceMode's values,
 *         SetInterMeasurementInMs's formula, CheckForDataReady, GetResult's block layout
 *         and its raw-status table status_rtn.
 *   [REG] ST full API register map vl53l1_register_map.h: register names and bit fields.
 *   [API] ST full API core: stream count wraps 0xFF -> 0x80.
 *   [FR]  field report (a part kept powered across an MCU reset): the first range after
 *         ST's block takes 103 ms.
 *   [NVM] ST full API: vl53l1_register_map.h puts 0x1E, 0x20, 0x22 in the group
 *         "customer_nvm_managed", and vl53l1_api_core.c (VL53L1_read_p2p_data) reads that
 *         group as "G02 registers containing data copied from NVM" once the part has booted;
 *         ST's NVM map (vl53l1_nvm_map.h) holds factory and customer copies of the offsets.
 *   [OFS] [ULD] VL53L1X_CalibrateOffset: zero 0x1E/0x20/0x22, average the ranges, offset =
 *         target - average, write offset x 4 to 0x1E: the part reports its range plus
 *         0x1E / 4. [REG]: 0x1E bits 12:0 signed, fixed point 11.2; 0x20/0x22 signed mm for
 *         the MM1/MM2 steps (0x81 bits 5/6, vl53l1_register_settings.h), which ST's block
 *         leaves off (0x81 = 0x9B); the full API then copies outer x 4 into 0x1E
 *         (vl53l1_api_core.c, "MM1/MM2 disabled").
 *   [NVMR] ST full API vl53l1_register_map.h: POWER_MANAGEMENT__GO1_POWER_FORCE 0x0083,
 *         RANGING_CORE__CLK_CTRL1 0x0683, RANGING_CORE__NVM_CTRL__MODE 0x0780, __PDN 0x0781,
 *         __READN 0x0783, __PULSE_WIDTH_MSB/LSB 0x0784/5, __DATAOUT_MMM..LLL 0x0790..3, __ADDR
 *         0x0794; FIRMWARE__ENABLE 0x0085 default 0x01. ST's NVM read (VL53L1_nvm_enable,
 *         _read, _disable): firmware off, power force, 250 us settling (vl53l1_ll_device.h),
 *         PDN 1 and CLK_CTRL1 0x05, 50 us NVM power-up, MODE 1, pulse width; per word ADDR
 *         (0..127, byte 4·ADDR), READN 0, 5 us, READN 1, 4 bytes of DATAOUT; then READN 1,
 *         PDN 0, power force off, firmware on. vl53l1_nvm_map.h: bytes 0x1F8..0x1FF hold the
 *         EWS lot, wafer and die X/Y.
 */
#ifndef SIM_VL53_REGS_H
#define SIM_VL53_REGS_H

#define M_ADDRESS_DEFAULT 0x29u   /* [DS] */
#define M_I2C_SLAVE_ADDR  0x0001u /* I2C_SLAVE__DEVICE_ADDRESS, 7-bit value [REG] */
#define M_VHV_LOOP_BOUND  0x0008u /* VHV_CONFIG__TIMEOUT_MACROP_LOOP_BOUND [REG] */
#define M_VHV_INIT        0x000Bu /* VHV_CONFIG__INIT [REG] */
#define M_VHV_BOUND_TWO   0x09u   /* [ULD] SensorInit: "two bounds VHV" */
#define M_VHV_INIT_PREV   0x00u   /* [ULD] SensorInit: "start VHV from the previous temperature" */
#define M_VHV_BOUND_FULL  0x81u   /* [ULD] StartTemperatureUpdate: "full VHV" */
#define M_VHV_INIT_FULL   0x92u   /* [ULD] StartTemperatureUpdate: 0x000B before its range */

/* The part's range offsets, loaded from NVM at power-up [NVM], applied as [OFS] says. */
#define M_PART_TO_PART_OFFSET  0x001Eu /* 13-bit signed quarter mm, bits 12:0 [REG] */
#define M_PART_TO_PART_HI_MASK 0x1Fu   /* bits 12:8 in the high byte; 15:13 read as 0 */
#define M_INNER_OFFSET         0x0020u /* 16-bit signed mm [REG] */
#define M_OUTER_OFFSET         0x0022u /* 16-bit signed mm [REG] */
#define M_OFFSET_LAST          0x0023u
#define M_NO_TARGET_MM         8190u /* a distance code, not a range: no offset applied */

/* The block [ULD] writes after boot, and the three of its registers that make the part
 * range at all: sequence config (bit 7 range enable [REG]), firmware enable (bit 0 [REG]),
 * interrupt on new sample (0x20 [ULD] comment on 0x46). */
#define M_BLOCK_FIRST       0x002Du
#define M_BLOCK_LAST        0x0087u
#define M_SEQUENCE_CONFIG   0x0081u
#define M_SEQUENCE_RANGE_EN 0x80u
#define M_FIRMWARE_ENABLE   0x0085u
#define M_INT_CONFIG_GPIO   0x0046u
#define M_INT_NEW_SAMPLE    0x20u

#define M_GPIO_HV_MUX_CTRL  0x0030u /* bit 4: active-low interrupt [ULD] */
#define M_MUX_ACTIVE_LOW    0x10u
#define M_GPIO_TIO_STATUS   0x0031u /* bit 0: interrupt line level [ULD] */
#define M_PHASECAL_TIMEOUT  0x004Bu /* 0x14 short, 0x0A long [ULD] SetDistanceMode */
#define M_TIMEOUT_A         0x005Eu /* 16-bit [ULD] */
#define M_VCSEL_A           0x0060u
#define M_TIMEOUT_B         0x0061u /* 16-bit */
#define M_VCSEL_B           0x0063u
#define M_VALID_PHASE_HIGH  0x0069u
#define M_INTERMEASUREMENT  0x006Cu /* 32-bit: ms x (osc & 0x3FF) x 1.075 [ULD] */
#define M_WOI_SD0           0x0078u /* WOI_SD0, WOI_SD1, INITIAL_PHASE_SD0, _SD1 */
#define M_INTERRUPT_CLEAR   0x0086u /* write 0x01 [ULD] */
#define M_MODE_START        0x0087u /* 0x40 timed ranging, 0x00 stop [ULD] */
#define M_START_TIMED       0x40u
#define M_STOP              0x00u
#define M_RESULT_FIRST      0x0089u /* [ULD] GetResult reads 17 bytes from here */
#define M_RESULT_LEN        17u
#define M_RESULT_STREAM     0x008Bu
#define M_RESULT_SPADS      0x008Cu /* 8.8 */
#define M_RESULT_PEAK       0x008Eu /* 9.7 MCPS */
#define M_RESULT_AMBIENT    0x0090u /* 9.7 MCPS */
#define M_RESULT_SIGMA      0x0092u
#define M_RESULT_PHASE      0x0094u
#define M_RESULT_DISTANCE   0x0096u
#define M_RESULT_PEAK_XTALK 0x0098u
#define M_OSC_CALIBRATE     0x00DEu /* RESULT__OSC_CALIBRATE_VAL, low 10 bits [ULD] */
#define M_OSC_MASK          0x03FFu
#define M_IMP_PER_MILLE     1075u
#define M_FIRMWARE_STATUS   0x00E5u /* FIRMWARE__SYSTEM_STATUS [ULD] BootState */
#define M_MODEL_ID          0x010Fu /* 16-bit, 0xEACC [ULD] GetSensorId */
#define M_MODEL_ID_VL53L1X  0xEACCu
#define M_STREAM_WRAP_TO    0x80u /* [API] */

/* Raw RESULT__RANGE_STATUS codes (low 5 bits, [REG] VL53L1_DEVICEERROR_*). */
#define M_RAW_NO_VHV      3u
#define M_RAW_RANGE_VALID 9u

/* The block's own timing: long mode, timeouts A 0x01CC, B 0x01F1 [ULD] table, a pair in no
 * budget table; its range time is the field measurement [FR]. */
#define M_BLOCK_TIMEOUT_A 0x01CCu
#define M_BLOCK_TIMEOUT_B 0x01F1u
#define M_BLOCK_RANGE_MS  103u

/* The NVM-read registers and ST's delays [NVMR]. */
#define M_POWER_FORCE           0x0083u
#define M_CLK_CTRL1             0x0683u
#define M_CLK_NVM_ON            0x05u
#define M_NVM_CTRL_FIRST        0x0780u
#define M_NVM_MODE              0x0780u
#define M_NVM_PDN               0x0781u
#define M_NVM_READN             0x0783u
#define M_NVM_PULSE_MSB         0x0784u
#define M_NVM_PULSE_LSB         0x0785u
#define M_NVM_DATAOUT           0x0790u
#define M_NVM_ADDR              0x0794u
#define M_NVM_CTRL_LAST         0x0795u
#define M_NVM_WORDS             128u
#define M_NVM_ID_FIRST_BYTE     0x01F8u
#define M_FORCE_SETTLE_US       250u
#define M_NVM_POWER_UP_US       50u
#define M_NVM_TRIGGER_US        5u
#define M_FIRMWARE_ENABLE_RESET 0x01u

#endif /* SIM_VL53_REGS_H */
