/* hal_temp on the STM32G0 ADC's internal temperature sensor (stm32_adc_temp.h, the G0 half). */
#include <stddef.h>

#include "hal/hal_err.h"
#include "stm32_adc_g0_regs.h"
#include "stm32_adc_regs.h"
#include "stm32_adc_temp.h"
#include "stm32_reg.h"

#define ADVREGEN STM32_ADC_G0_CR_ADVREGEN

/* Poll `reg` until (value & mask) == want, within cfg->poll_budget_us (and as many reads). */
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

static void cr_write(const struct stm32_adc_temp_config *cfg, uint32_t value) {
    stm32_reg_write(cfg->adc_base + STM32_ADC_G0_CR, value);
}

/* RM0444 §15.3 "ADC functional description": a conversion left running stopped and the ADC
 * disabled; the clock mode (ADEN = 0); the regulator and its start-up (tADCVREG_STUP);
 * the sensor and VREFINT paths; calibration (ADCAL until it clears, ADEN = 0); their
 * start-up; ADRDY cleared, ADEN, ADRDY; then 12-bit single conversions, one sampling time. */
static int bring_up(const struct stm32_adc_temp_config *cfg) {
    const struct hal_time *t = &cfg->time;
    const uint32_t cr = stm32_reg_read(cfg->adc_base + STM32_ADC_G0_CR);
    int err = HAL_OK;
    if ((cr & STM32_ADC_G0_CR_ADEN) != 0u) {
        if ((cr & STM32_ADC_G0_CR_ADSTART) != 0u) {
            cr_write(cfg, ADVREGEN | STM32_ADC_G0_CR_ADEN | STM32_ADC_G0_CR_ADSTP);
            err = poll(cfg, STM32_ADC_G0_CR, STM32_ADC_G0_CR_ADSTART, 0u);
        }
        if (err == HAL_OK) {
            cr_write(cfg, ADVREGEN | STM32_ADC_G0_CR_ADEN | STM32_ADC_G0_CR_ADDIS);
            err = poll(cfg, STM32_ADC_G0_CR, STM32_ADC_G0_CR_ADEN, 0u);
        }
        if (err != HAL_OK) {
            return err;
        }
    }
    stm32_reg_write(cfg->adc_base + STM32_ADC_G0_CFGR2, STM32_ADC_G0_CFGR2_CKMODE_PCLK2);
    cr_write(cfg, ADVREGEN);
    t->ops->delay_us(t->ctx, cfg->regulator_startup_us);
    stm32_reg_modify(cfg->common_base + STM32_ADC_COMMON_CCR, 0u,
                     STM32_ADC_CCR_VREFEN | STM32_ADC_CCR_TSEN);
    cr_write(cfg, ADVREGEN | STM32_ADC_G0_CR_ADCAL);
    err = poll(cfg, STM32_ADC_G0_CR, STM32_ADC_G0_CR_ADCAL, 0u);
    if (err != HAL_OK) {
        return err;
    }
    t->ops->delay_us(t->ctx, cfg->sensor_startup_us);
    stm32_reg_write(cfg->adc_base + STM32_ADC_G0_ISR, STM32_ADC_G0_ISR_ADRDY);
    cr_write(cfg, ADVREGEN | STM32_ADC_G0_CR_ADEN);
    err = poll(cfg, STM32_ADC_G0_ISR, STM32_ADC_G0_ISR_ADRDY, STM32_ADC_G0_ISR_ADRDY);
    if (err == HAL_OK) {
        stm32_reg_write(cfg->adc_base + STM32_ADC_G0_CFGR1, STM32_ADC_G0_CFGR1_OVRMOD);
        stm32_reg_write(cfg->adc_base + STM32_ADC_G0_SMPR, cfg->smp_code);
    }
    return err;
}

/* One conversion of `channel`: the channel mask, CCRDY (the configuration applied), the
 * flags cleared, ADSTART, EOC; reading DR clears EOC. */
static int convert(const struct stm32_adc_temp_config *cfg, uint8_t channel, uint16_t *raw) {
    stm32_reg_write(cfg->adc_base + STM32_ADC_G0_ISR, STM32_ADC_G0_ISR_CCRDY);
    stm32_reg_write(cfg->adc_base + STM32_ADC_G0_CHSELR, 1u << channel);
    int err = poll(cfg, STM32_ADC_G0_ISR, STM32_ADC_G0_ISR_CCRDY, STM32_ADC_G0_ISR_CCRDY);
    if (err != HAL_OK) {
        return err;
    }
    stm32_reg_write(cfg->adc_base + STM32_ADC_G0_ISR,
                    STM32_ADC_G0_ISR_EOC | STM32_ADC_G0_ISR_EOS | STM32_ADC_G0_ISR_OVR);
    cr_write(cfg, ADVREGEN | STM32_ADC_G0_CR_ADEN | STM32_ADC_G0_CR_ADSTART);
    err = poll(cfg, STM32_ADC_G0_ISR, STM32_ADC_G0_ISR_EOC, STM32_ADC_G0_ISR_EOC);
    if (err == HAL_OK) {
        *raw = (uint16_t)(stm32_reg_read(cfg->adc_base + STM32_ADC_G0_DR) & 0xFFFFu);
    }
    return err;
}

int stm32_adc_g0_temp_read_cdeg(void *ctx, int16_t *cdeg) {
    struct stm32_adc_temp *adc = ctx;
    if (adc == NULL || adc->cfg == NULL || cdeg == NULL) {
        return HAL_ERR_INVALID;
    }
    if (!adc->ready) {
        const int err = bring_up(adc->cfg);
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
        adc->ready = false;
        return err;
    }
    return stm32_adc_temp_convert(&adc->cal, ts_data, vrefint_data, cdeg);
}

const struct hal_temp_ops stm32_adc_g0_temp_ops = {
    .read_cdeg = stm32_adc_g0_temp_read_cdeg,
};
