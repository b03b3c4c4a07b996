/* Register-level fake of the STM32L4 ADC's temperature path (fake_stm32_adc.h). */
#include "fake_stm32_adc.h"

#include <stdio.h>
#include <string.h>

#include "fake_stm32.h"
#include "stm32_adc_regs.h"

struct fake_adc fake_adc;

enum { R_ISR = 0, R_CR = 2, R_CFGR = 3, R_SMPR1 = 5, R_SMPR2 = 6, R_SQR1 = 12, R_DR = 16 };
/* The G0's: CFGR1 at the L4's CFGR, CFGR2 (0x10), SMPR at the L4's SMPR1, CHSELR (0x28). */
enum { R_G0_CFGR2 = 4, R_G0_SMPR = 5, R_G0_CHSELR = 10 };
#define G0_CCRDY (1u << 13)
enum { C_CCR = 2 };

static void log_event(enum fake_adc_event event, uint8_t channel) {
    if (fake_adc.log_len < FAKE_ADC_LOG_MAX) {
        fake_adc.log[fake_adc.log_len++] = (struct fake_adc_log_entry){event, channel};
    }
}

static void violation(const char *what) {
    if (fake_adc.violations++ == 0u) {
        snprintf(fake_adc.first_violation, sizeof fake_adc.first_violation, "%s", what);
    }
}

static void put_half(uint32_t real, uint16_t value) {
    fake_adc.sysmem[real - FAKE_ADC_SYSMEM_REAL] = (uint8_t)value;
    fake_adc.sysmem[real - FAKE_ADC_SYSMEM_REAL + 1u] = (uint8_t)(value >> 8);
}

void fake_adc_reset(uint16_t ts_cal1, uint16_t ts_cal2, uint16_t vrefint_cal) {
    memset(&fake_adc, 0, sizeof fake_adc);
    fake_adc.regs[R_CR] = STM32_ADC_CR_DEEPPWD; /* reset value (§18.6.3) */
    fake_adc.regs[R_CFGR] = STM32_ADC_CFGR_RESET;
    memset(fake_adc.sysmem, 0xFF, sizeof fake_adc.sysmem);
    put_half(0x1FFF75A8u, ts_cal1);
    put_half(0x1FFF75AAu, vrefint_cal);
    put_half(0x1FFF75CAu, ts_cal2);
    fake_adc.cal_reads = 3u;
    fake_adc.ready_reads = 3u;
    fake_adc.eoc_reads = 3u;
    fake_adc.regulator_startup_us = 20u;
    fake_adc.path_startup_us = 120u;
    fake_adc.min_smp_code = 5u;
    fake_adc.ts_channel = 17u;
    fake_adc.vref_channel = 0u;
}

void fake_adc_reset_g0(uint16_t ts_cal1, uint16_t ts_cal2, uint16_t vrefint_cal) {
    fake_adc_reset(ts_cal1, ts_cal2, vrefint_cal);
    fake_adc.g0 = true;
    fake_adc.regs[R_CR] = 0u;   /* no deep power-down on the G0 */
    fake_adc.regs[R_CFGR] = 0u; /* CFGR1's reset value */
    fake_adc.ts_channel = 12u;
    fake_adc.vref_channel = 13u;
}

uintptr_t fake_adc_base(void) {
    return (uintptr_t)fake_adc.regs;
}

uintptr_t fake_adc_common_base(void) {
    return (uintptr_t)fake_adc.common;
}

uintptr_t fake_adc_sysmem(uint32_t real) {
    return (uintptr_t)fake_adc.sysmem + (real - FAKE_ADC_SYSMEM_REAL);
}

static uint32_t smp_code(uint8_t channel) {
    if (fake_adc.g0) {
        const uint32_t smpr = fake_adc.regs[R_G0_SMPR];
        return (smpr & (1u << (8u + channel))) != 0u ? (smpr >> 4) & 7u : smpr & 7u;
    }
    const uint32_t reg = channel < 10u ? fake_adc.regs[R_SMPR1] : fake_adc.regs[R_SMPR2];
    return (reg >> ((channel % 10u) * 3u)) & 7u;
}

static void start_conversion(void) {
    uint32_t *cr = &fake_adc.regs[R_CR];
    uint8_t channel = (uint8_t)((fake_adc.regs[R_SQR1] >> 6) & 0x1Fu);
    if ((*cr & STM32_ADC_CR_ADEN) == 0u || (fake_adc.regs[R_ISR] & STM32_ADC_ISR_ADRDY) == 0u) {
        violation("ADSTART without ADEN and ADRDY");
        return;
    }
    if (fake_adc.g0) {
        const uint32_t mask = fake_adc.regs[R_G0_CHSELR];
        if (mask == 0u || (mask & (mask - 1u)) != 0u || !fake_adc.chsel_applied) {
            violation("ADSTART without one channel applied (CHSELR, CCRDY)");
            return;
        }
        for (channel = 0u; (mask >> channel) != 1u; ++channel) {
        }
    } else if ((fake_adc.regs[R_SQR1] & 0xFu) != 0u) {
        violation("SQR1.L is not one conversion");
        return;
    }
    if (channel == fake_adc.ts_channel || channel == fake_adc.vref_channel) {
        const uint32_t bit =
            channel == fake_adc.ts_channel ? STM32_ADC_CCR_TSEN : STM32_ADC_CCR_VREFEN;
        if ((fake_adc.common[C_CCR] & bit) == 0u || !fake_adc.paths_on ||
            fake.time.now - fake_adc.paths_on_us < fake_adc.path_startup_us) {
            violation("internal channel converted before its path's start-up");
            return;
        }
        if (smp_code(channel) < fake_adc.min_smp_code) {
            violation("sampling time shorter than the sensor needs");
            return;
        }
    }
    *cr |= STM32_ADC_CR_ADSTART;
    fake_adc.converting = channel;
    fake_adc.eoc_pending = true;
    fake_adc.eoc_left = fake_adc.eoc_reads;
    log_event(FA_START, channel);
}

static void write_cr(uint32_t value) {
    uint32_t *cr = &fake_adc.regs[R_CR];
    const uint32_t before = *cr;
    if ((before & STM32_ADC_CR_DEEPPWD) != 0u && (value & STM32_ADC_CR_DEEPPWD) == 0u) {
        *cr &= ~STM32_ADC_CR_DEEPPWD;
    }
    if ((value & STM32_ADC_CR_ADVREGEN) != 0u && (before & STM32_ADC_CR_ADVREGEN) == 0u) {
        if ((before & STM32_ADC_CR_DEEPPWD) != 0u || (value & STM32_ADC_CR_DEEPPWD) != 0u) {
            violation("ADVREGEN in deep power-down");
        } else {
            *cr |= STM32_ADC_CR_ADVREGEN;
            fake_adc.regulator_on = true;
            fake_adc.regulator_on_us = fake.time.now;
            log_event(FA_REGULATOR_ON, 0u);
        }
    }
    if ((value & STM32_ADC_CR_ADVREGEN) == 0u && (before & STM32_ADC_CR_ADVREGEN) != 0u) {
        if ((before & STM32_ADC_CR_ADEN) != 0u) {
            violation("ADVREGEN cleared with ADEN set");
        } else {
            *cr &= ~STM32_ADC_CR_ADVREGEN;
            fake_adc.regulator_on = false;
        }
    }
    if ((value & STM32_ADC_CR_DEEPPWD) != 0u && (before & STM32_ADC_CR_DEEPPWD) == 0u) {
        *cr |= STM32_ADC_CR_DEEPPWD; /* back to deep power-down: the calibration is lost */
        *cr &= ~STM32_ADC_CR_ADVREGEN;
        fake_adc.regulator_on = false;
    }
    if ((value & STM32_ADC_CR_ADCAL) != 0u && (before & STM32_ADC_CR_ADCAL) == 0u) {
        if ((before & STM32_ADC_CR_ADEN) != 0u || !fake_adc.regulator_on ||
            fake.time.now - fake_adc.regulator_on_us < fake_adc.regulator_startup_us ||
            (value & STM32_ADC_CR_ADCALDIF) != 0u) {
            violation("ADCAL with ADEN set, the regulator not started, or differential");
        } else {
            *cr |= STM32_ADC_CR_ADCAL;
            fake_adc.cal_left = fake_adc.cal_reads;
            log_event(FA_CAL_START, 0u);
        }
    }
    if ((value & STM32_ADC_CR_ADEN) != 0u && (before & STM32_ADC_CR_ADEN) == 0u) {
        if ((*cr & STM32_ADC_CR_ADCAL) != 0u || !fake_adc.regulator_on) {
            violation("ADEN during calibration or without the regulator");
        } else {
            *cr |= STM32_ADC_CR_ADEN;
            fake_adc.ready_pending = true;
            fake_adc.ready_left = fake_adc.ready_reads;
            log_event(FA_ENABLE, 0u);
        }
    }
    if ((value & STM32_ADC_CR_ADSTP) != 0u && (before & STM32_ADC_CR_ADSTART) != 0u) {
        *cr &= ~STM32_ADC_CR_ADSTART;
        fake_adc.eoc_pending = false;
    }
    if ((value & STM32_ADC_CR_ADDIS) != 0u) {
        if ((before & STM32_ADC_CR_ADEN) == 0u || (*cr & STM32_ADC_CR_ADSTART) != 0u) {
            violation("ADDIS without ADEN or during a conversion");
        } else {
            *cr &= ~STM32_ADC_CR_ADEN;
            fake_adc.regs[R_ISR] &= ~STM32_ADC_ISR_ADRDY;
            fake_adc.ready_pending = false;
            log_event(FA_DISABLE, 0u);
        }
    }
    if ((value & STM32_ADC_CR_ADSTART) != 0u && (before & STM32_ADC_CR_ADSTART) == 0u) {
        start_conversion();
    }
}

static uint32_t read_isr(void) {
    uint32_t *isr = &fake_adc.regs[R_ISR];
    if (fake_adc.ccrdy_pending) {
        if (fake_adc.ccrdy_left == 0u) {
            *isr |= G0_CCRDY;
            fake_adc.ccrdy_pending = false;
            fake_adc.chsel_applied = true;
        } else if (fake_adc.ccrdy_left != UINT32_MAX) {
            --fake_adc.ccrdy_left;
        }
    }
    if (fake_adc.ready_pending && fake_adc.ready_left != UINT32_MAX) {
        if (fake_adc.ready_left == 0u) {
            *isr |= STM32_ADC_ISR_ADRDY;
            fake_adc.ready_pending = false;
            log_event(FA_READY, 0u);
        } else {
            --fake_adc.ready_left;
        }
    }
    if (fake_adc.eoc_pending && fake_adc.eoc_left != UINT32_MAX) {
        if (fake_adc.eoc_left == 0u) {
            *isr |= STM32_ADC_ISR_EOC | STM32_ADC_ISR_EOS;
            fake_adc.regs[R_DR] = fake_adc.raw[fake_adc.converting % 19u];
            fake_adc.regs[R_CR] &= ~STM32_ADC_CR_ADSTART; /* single conversion ends */
            fake_adc.eoc_pending = false;
            ++fake_adc.conversions;
            log_event(FA_EOC, fake_adc.converting);
        } else {
            --fake_adc.eoc_left;
        }
    }
    return *isr;
}

static uint32_t read_cr(void) {
    uint32_t *cr = &fake_adc.regs[R_CR];
    if ((*cr & STM32_ADC_CR_ADCAL) != 0u && fake_adc.cal_left != UINT32_MAX) {
        if (fake_adc.cal_left == 0u) {
            *cr &= ~STM32_ADC_CR_ADCAL;
            log_event(FA_CAL_DONE, 0u);
        } else {
            --fake_adc.cal_left;
        }
    }
    return *cr;
}

bool fake_adc_read(uintptr_t addr, uint32_t *value) {
    const uintptr_t regs = fake_adc_base(), common = fake_adc_common_base();
    const uintptr_t sysmem = (uintptr_t)fake_adc.sysmem;
    if (addr >= sysmem && addr < sysmem + sizeof fake_adc.sysmem) {
        const uint8_t *p = fake_adc.sysmem + (addr - sysmem);
        *value = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
        return true;
    }
    if (addr >= common && addr < common + sizeof fake_adc.common) {
        *value = fake_adc.common[(addr - common) / 4u];
        return true;
    }
    if (addr < regs || addr >= regs + sizeof fake_adc.regs) {
        return false;
    }
    switch ((addr - regs) / 4u) {
    case R_ISR:
        *value = read_isr();
        break;
    case R_CR:
        *value = read_cr();
        break;
    case R_DR:
        *value = fake_adc.regs[R_DR];
        if ((fake_adc.regs[R_ISR] & STM32_ADC_ISR_EOC) != 0u) {
            fake_adc.regs[R_ISR] &= ~STM32_ADC_ISR_EOC; /* reading DR clears EOC */
            log_event(FA_DR_READ, fake_adc.converting);
        }
        break;
    default:
        *value = fake_adc.regs[(addr - regs) / 4u];
    }
    return true;
}

bool fake_adc_write(uintptr_t addr, uint32_t value) {
    const uintptr_t regs = fake_adc_base(), common = fake_adc_common_base();
    if (addr >= common && addr < common + sizeof fake_adc.common) {
        const uint32_t index = (uint32_t)(addr - common) / 4u;
        if (index == C_CCR) {
            const uint32_t both = STM32_ADC_CCR_TSEN | STM32_ADC_CCR_VREFEN;
            if ((fake_adc.regs[R_CR] & STM32_ADC_CR_ADEN) != 0u &&
                ((value ^ fake_adc.common[C_CCR]) & STM32_ADC_CCR_CKMODE_MASK) != 0u) {
                violation("CKMODE changed with ADEN set");
                return true;
            }
            if ((value & both) == both && !fake_adc.paths_on) {
                fake_adc.paths_on = true;
                fake_adc.paths_on_us = fake.time.now;
                log_event(FA_PATHS_ON, 0u);
            }
            if ((value & both) != both) {
                fake_adc.paths_on = false;
            }
        }
        fake_adc.common[index] = value;
        return true;
    }
    if (addr < regs || addr >= regs + sizeof fake_adc.regs) {
        return false;
    }
    const uint32_t index = (uint32_t)(addr - regs) / 4u;
    switch (index) {
    case R_ISR:
        fake_adc.regs[R_ISR] &= ~value; /* write 1 to clear */
        break;
    case R_CR:
        write_cr(value);
        break;
    case R_CFGR:
    case R_SMPR1:
    case R_SMPR2:
    case R_SQR1:
    case R_G0_CFGR2:
    case R_G0_CHSELR:
        if ((fake_adc.regs[R_CR] & STM32_ADC_CR_ADSTART) != 0u) {
            violation("configuration written during a conversion");
            break;
        }
        if (fake_adc.g0 && index == R_G0_CFGR2 && (fake_adc.regs[R_CR] & STM32_ADC_CR_ADEN) != 0u) {
            violation("CFGR2 (CKMODE) written with ADEN set");
            break;
        }
        if (fake_adc.g0 && index == R_G0_CHSELR) {
            fake_adc.chsel_applied = false;
            fake_adc.ccrdy_pending = true;
            fake_adc.ccrdy_left = fake_adc.ready_reads;
        }
        fake_adc.regs[index] = value;
        break;
    case R_DR:
        violation("write to DR");
        break;
    default:
        fake_adc.regs[index] = value;
    }
    return true;
}
