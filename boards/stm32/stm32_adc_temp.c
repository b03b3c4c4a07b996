/* hal_temp on the STM32L4 ADC's internal temperature sensor (stm32_adc_temp.h). */
#include "stm32_adc_temp.h"

#include <stddef.h>

#include "hal/hal_err.h"
#include "stm32_adc_regs.h"
#include "stm32_reg.h"

/* A calibration half-word: the aligned 32-bit word that holds it, little-endian (the
 * register accessors are 32-bit; system memory reads the same either way). */
static uint16_t read_half(uintptr_t addr) {
    const uint32_t word = stm32_reg_read(addr & ~(uintptr_t)3u);
    return (uint16_t)(word >> ((addr & 2u) * 8u));
}

/* Poll `reg` until (value & mask) == want, within cfg->poll_budget_us of the board's time;
 * the reads are bounded too (one per microsecond of budget, plus one) in case the clock
 * has stopped. */
static int poll(const struct stm32_adc_temp_config *cfg, uint32_t reg, uint32_t mask,
                uint32_t want) {
    const struct hal_time *t = &cfg->time;
    const uint32_t start = t->ops->now_us(t->ctx);
    for (uint32_t reads = 0; reads <= cfg->poll_budget_us; ++reads) {
        if ((stm32_reg_read(cfg->adc_base + reg) & mask) == want) {
            return HAL_OK;
        }
        if (hal_time_elapsed_us(t->ops->now_us(t->ctx), start) > cfg->poll_budget_us) {
            break;
        }
    }
    return HAL_ERR_TIMEOUT;
}

/* Write ADC_CR as `keep | bits`. Its control bits are set by software and cleared by
 * hardware, each allowed only in stated states (§18.6.3), so a read-modify-write that
 * writes back a bit still set (ADSTART, ADCAL) would be a second request: the driver writes
 * only the bits it means. */
static void cr_set(const struct stm32_adc_temp_config *cfg, uint32_t keep, uint32_t bits) {
    stm32_reg_write(cfg->adc_base + STM32_ADC_CR, keep | bits);
}

/* Bring the ADC from reset (or any state a failed bring-up left) to enabled and calibrated:
 * RM0351 §18.4.6 (deep power-down exit, ADVREGEN, tADCVREG_STUP), §18.4.8 (calibration with
 * ADEN = 0, single-ended), §18.4.9 (ADRDY cleared, ADEN, wait ADRDY). */
static int bring_up(struct stm32_adc_temp *adc) {
    const struct stm32_adc_temp_config *cfg = adc->cfg;
    const struct hal_time *t = &cfg->time;
    const uint32_t cr = stm32_reg_read(cfg->adc_base + STM32_ADC_CR);
    if ((cr & STM32_ADC_CR_ADEN) != 0u) {
        /* Left enabled (a failed conversion): disable first, calibration needs ADEN = 0. */
        if ((cr & STM32_ADC_CR_ADSTART) != 0u) {
            cr_set(cfg, STM32_ADC_CR_ADVREGEN | STM32_ADC_CR_ADEN, STM32_ADC_CR_ADSTP);
            int err = poll(cfg, STM32_ADC_CR, STM32_ADC_CR_ADSTART, 0u);
            if (err != HAL_OK) {
                return err;
            }
        }
        cr_set(cfg, STM32_ADC_CR_ADVREGEN | STM32_ADC_CR_ADEN, STM32_ADC_CR_ADDIS);
        int err = poll(cfg, STM32_ADC_CR, STM32_ADC_CR_ADEN, 0u);
        if (err != HAL_OK) {
            return err;
        }
    }
    /* Deep power-down off, then the regulator on, then its start-up time (DS10198
     * "ADC characteristics": tADCVREG_STUP <= 20 us). */
    stm32_reg_write(cfg->adc_base + STM32_ADC_CR, 0u);
    stm32_reg_write(cfg->adc_base + STM32_ADC_CR, STM32_ADC_CR_ADVREGEN);
    t->ops->delay_us(t->ctx, cfg->regulator_startup_us);
    /* Sensor and VREFINT paths on, ADC clock HCLK/2 (synchronous: no RCC kernel clock,
     * §18.4.3; CKMODE may change only with the ADC disabled, as it is here). */
    stm32_reg_modify(cfg->common_base + STM32_ADC_COMMON_CCR, STM32_ADC_CCR_CKMODE_MASK,
                     STM32_ADC_CCR_CKMODE_HCLK2 | STM32_ADC_CCR_VREFEN | STM32_ADC_CCR_TSEN);
    /* Single-ended calibration (ADCALDIF = 0). */
    cr_set(cfg, STM32_ADC_CR_ADVREGEN, STM32_ADC_CR_ADCAL);
    int err = poll(cfg, STM32_ADC_CR, STM32_ADC_CR_ADCAL, 0u);
    if (err != HAL_OK) {
        return err;
    }
    /* ADEN may not be set for 4 ADC clocks after ADCAL clears (§18.4.8); the sensor's and
     * VREFINT buffer's start-up (DS10198 "Temperature sensor characteristics", tSTART, and
     * "Embedded internal voltage reference", tstart_vrefint) is far longer: wait it here. */
    t->ops->delay_us(t->ctx, cfg->sensor_startup_us);
    stm32_reg_write(cfg->adc_base + STM32_ADC_ISR, STM32_ADC_ISR_ADRDY);
    cr_set(cfg, STM32_ADC_CR_ADVREGEN, STM32_ADC_CR_ADEN);
    err = poll(cfg, STM32_ADC_ISR, STM32_ADC_ISR_ADRDY, STM32_ADC_ISR_ADRDY);
    if (err != HAL_OK) {
        return err;
    }
    /* Configuration while no conversion runs (§18.6.4/§18.6.6): 12-bit right-aligned single
     * conversion, the same long sampling time on both channels. */
    stm32_reg_write(cfg->adc_base + STM32_ADC_CFGR, STM32_ADC_CFGR_RESET | STM32_ADC_CFGR_OVRMOD);
    const uint8_t channels[2] = {cfg->vrefint_channel, cfg->ts_channel};
    for (unsigned i = 0; i < 2u; ++i) {
        const uint32_t ch = channels[i];
        const uint32_t reg = ch < 10u ? STM32_ADC_SMPR1 : STM32_ADC_SMPR2;
        const uint32_t shift = (ch % 10u) * STM32_ADC_SMP_BITS;
        stm32_reg_modify(cfg->adc_base + reg, 7u << shift, (uint32_t)cfg->smp_code << shift);
    }
    return HAL_OK;
}

/* One conversion of `channel` (§18.4.18 "Single conversion mode"): SQ1 with L = 0, EOC
 * cleared, ADSTART, EOC; reading DR clears EOC. */
static int convert(const struct stm32_adc_temp_config *cfg, uint8_t channel, uint16_t *raw) {
    stm32_reg_write(cfg->adc_base + STM32_ADC_SQR1, (uint32_t)channel << STM32_ADC_SQR1_SQ1_SHIFT);
    stm32_reg_write(cfg->adc_base + STM32_ADC_ISR,
                    STM32_ADC_ISR_EOC | STM32_ADC_ISR_EOS | STM32_ADC_ISR_OVR);
    cr_set(cfg, STM32_ADC_CR_ADVREGEN | STM32_ADC_CR_ADEN, STM32_ADC_CR_ADSTART);
    const int err = poll(cfg, STM32_ADC_ISR, STM32_ADC_ISR_EOC, STM32_ADC_ISR_EOC);
    if (err != HAL_OK) {
        return err;
    }
    *raw = (uint16_t)(stm32_reg_read(cfg->adc_base + STM32_ADC_DR) & 0xFFFFu);
    return HAL_OK;
}

void stm32_adc_temp_init(struct stm32_adc_temp *adc, const struct stm32_adc_temp_config *cfg) {
    adc->cfg = cfg;
    adc->ready = false;
    adc->cal = (struct stm32_adc_temp_cal){
        .ts_cal1 = read_half(cfg->ts_cal1_addr),
        .ts_cal2 = read_half(cfg->ts_cal2_addr),
        .vrefint_cal = read_half(cfg->vrefint_cal_addr),
        .ts_cal1_cdeg = cfg->ts_cal1_cdeg,
        .ts_cal2_cdeg = cfg->ts_cal2_cdeg,
    };
}

/* Round-to-nearest signed division (den > 0). */
static int32_t div_round(int32_t num, int32_t den) {
    return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}

int stm32_adc_temp_convert(const struct stm32_adc_temp_cal *cal, uint16_t ts_data,
                           uint16_t vrefint_data, int16_t *cdeg) {
    const uint32_t full_scale = 0xFFFu; /* 12-bit */
    if (cal->ts_cal1 == 0u || cal->ts_cal2 > full_scale || cal->ts_cal2 <= cal->ts_cal1 ||
        cal->vrefint_cal == 0u || cal->vrefint_cal > full_scale ||
        cal->ts_cal2_cdeg <= cal->ts_cal1_cdeg || ts_data > full_scale) {
        return HAL_ERR_CORRUPT;
    }
    /* VDDA = 3.0 V x VREFINT_CAL / vrefint_data; refuse a reading that puts it outside
     * 1.5..4.0 V (the part runs at 1.71..3.6 V, DS10198 "General operating conditions"). */
    const uint32_t vref = vrefint_data;
    if (4u * vref < 3u * cal->vrefint_cal || vref > 2u * cal->vrefint_cal) {
        return HAL_ERR_CORRUPT;
    }
    /* The sensor's reading as if at 3.0 V, with 4 fraction bits: <= 4095 x 4095 x 16 fits
     * 32 bits unsigned, and the result <= 4095 x 16 x 4 / 3. */
    const uint32_t ts16 = (ts_data * (uint32_t)cal->vrefint_cal * 16u + vref / 2u) / vref;
    const int32_t span_cdeg = (int32_t)cal->ts_cal2_cdeg - cal->ts_cal1_cdeg; /* <= 32767 */
    const int32_t span_raw16 = ((int32_t)cal->ts_cal2 - cal->ts_cal1) * 16;
    const int32_t above16 = (int32_t)ts16 - (int32_t)cal->ts_cal1 * 16;
    /* |above16| <= 87360 and span_cdeg <= 16000 in any part's calibration (30..130 °C):
     * bound it so the product cannot overflow whatever the words say. */
    if (span_cdeg > 20000) {
        return HAL_ERR_CORRUPT;
    }
    const int32_t t = cal->ts_cal1_cdeg + div_round(above16 * span_cdeg, span_raw16);
    if (t < HAL_TEMP_MIN_CDEG || t > HAL_TEMP_MAX_CDEG) {
        return HAL_ERR_CORRUPT;
    }
    *cdeg = (int16_t)t;
    return HAL_OK;
}

int stm32_adc_temp_read_cdeg(void *ctx, int16_t *cdeg) {
    struct stm32_adc_temp *adc = ctx;
    if (adc == NULL || adc->cfg == NULL || cdeg == NULL) {
        return HAL_ERR_INVALID;
    }
    if (!adc->ready) {
        const int err = bring_up(adc);
        if (err != HAL_OK) {
            return err;
        }
        adc->ready = true;
    }
    uint16_t vrefint_data = 0u;
    uint16_t ts_data = 0u;
    int err = convert(adc->cfg, adc->cfg->vrefint_channel, &vrefint_data);
    if (err == HAL_OK) {
        err = convert(adc->cfg, adc->cfg->ts_channel, &ts_data);
    }
    if (err != HAL_OK) {
        adc->ready = false; /* a stuck conversion: the next read starts from the top */
        return err;
    }
    return stm32_adc_temp_convert(&adc->cal, ts_data, vrefint_data, cdeg);
}

const struct hal_temp_ops stm32_adc_temp_ops = {
    .read_cdeg = stm32_adc_temp_read_cdeg,
};
