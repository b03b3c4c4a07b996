/*
 * hal_temp on the STM32L4's internal temperature sensor: ADC1 converts the sensor (channel
 * 17) and the internal reference VREFINT (channel 0), and the factory calibration words in
 * system memory turn the two into a temperature (RM0351 §18.4.32 "Temperature sensor",
 * §18.4.33 "Monitoring the internal voltage reference"); and the same on the STM32G0
 * (sensor on channel 12, VREFINT on 13: RM0444 §15). The sensor is the MCU's die:
 * docs/explanation/boards.md "Temperature" says what that costs against a sensor on the head.
 */
#ifndef BOARDS_STM32_ADC_TEMP_H
#define BOARDS_STM32_ADC_TEMP_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_temp.h"
#include "hal/hal_time.h"

/* The factory calibration of one part: raw 12-bit conversions at Vref+ = 3.0 V. */
struct stm32_adc_temp_cal {
    uint16_t ts_cal1, ts_cal2; /* temperature sensor at ts_cal1_cdeg and ts_cal2_cdeg */
    uint16_t vrefint_cal;      /* VREFINT at 30 °C */
    int16_t ts_cal1_cdeg, ts_cal2_cdeg;
};

struct stm32_adc_temp_config {
    uintptr_t adc_base;    /* ADC1 */
    uintptr_t common_base; /* the ADC common registers (ADC1 base + 0x300 on the L4) */
    /* Addresses of the calibration half-words in system memory (read as the aligned word
     * that holds each: the register accessors are 32-bit). */
    uintptr_t ts_cal1_addr, ts_cal2_addr, vrefint_cal_addr;
    int16_t ts_cal1_cdeg, ts_cal2_cdeg; /* the part's calibration temperatures */
    uint8_t ts_channel, vrefint_channel;
    uint8_t smp_code; /* ADC_SMPRx code of both channels (long enough for the datasheet) */
    /* Bounds of the waits, in microseconds of `time`: the regulator's and sensor's start-up
     * (waited in full), and each flag's poll (an error once exceeded). */
    uint32_t regulator_startup_us, sensor_startup_us, poll_budget_us;
    struct hal_time time;
};

struct stm32_adc_temp {
    const struct stm32_adc_temp_config *cfg;
    bool ready; /* calibrated and enabled */
    struct stm32_adc_temp_cal cal;
};

/* Bind `adc` to `cfg` (kept by pointer); the ADC is brought up by the first read. */
void stm32_adc_temp_init(struct stm32_adc_temp *adc, const struct stm32_adc_temp_config *cfg);

/*
 * hal_temp read (ctx: struct stm32_adc_temp). The first call (and every call after a failed
 * bring-up) brings the ADC up in the order of RM0351 §18.4.6-§18.4.9: exit deep power-down,
 * ADVREGEN and the regulator's start-up time, single-ended calibration (ADCAL until it
 * clears), ADEN until ADRDY; with VREFEN and TSEN and their start-up. Each read converts
 * VREFINT then the sensor (ADSTART until EOC). Every flag wait is bounded by
 * cfg->poll_budget_us: HAL_ERR_TIMEOUT names a stuck step (the ADC is brought up again
 * on the next call). HAL_ERR_CORRUPT: a calibration word or the result is implausible.
 */
int stm32_adc_temp_read_cdeg(void *ctx, int16_t *cdeg);

/*
 * The temperature from one pair of conversions and the calibration (RM0351 §18.4.32):
 * the sensor's reading scaled to Vref+ = 3.0 V by VREFINT_CAL / vrefint_data, then the line
 * through (ts_cal1, ts_cal1_cdeg) and (ts_cal2, ts_cal2_cdeg), rounded to 0.01 °C, in 32-bit
 * integer arithmetic. HAL_OK; HAL_ERR_CORRUPT if a calibration word is erased or out of
 * order, vrefint_data puts VDDA outside 1.5..4.0 V, or the result is outside
 * HAL_TEMP_MIN_CDEG..HAL_TEMP_MAX_CDEG (*cdeg unchanged).
 */
int stm32_adc_temp_convert(const struct stm32_adc_temp_cal *cal, uint16_t ts_data,
                           uint16_t vrefint_data, int16_t *cdeg);

extern const struct hal_temp_ops stm32_adc_temp_ops;

/*
 * The same on the STM32G0's ADC (stm32_adc_g0_temp.c; RM0444 §15, another register layout:
 * stm32_adc_g0_regs.h): the clock mode PCLK/2 (CFGR2), the regulator and its start-up, the
 * paths, ADCAL, ADEN until ADRDY; each reading the channel mask (CHSELR) until CCRDY, then
 * ADSTART until EOC, VREFINT then the sensor. cfg->smp_code is SMP1's code; init and the
 * conversion are stm32_adc_temp_init and stm32_adc_temp_convert. Errors as above.
 */
int stm32_adc_g0_temp_read_cdeg(void *ctx, int16_t *cdeg);

extern const struct hal_temp_ops stm32_adc_g0_temp_ops;

#endif /* BOARDS_STM32_ADC_TEMP_H */
