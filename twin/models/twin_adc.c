/*
 * ADC1 of the twin's STM32L476 as the internal temperature sensor uses it, strictly: only the
 * reference manual's sequence gives a conversion (RM0351 §18.4.6 deep power-down and
 * regulator, §18.4.8 calibration, §18.4.9 enable, §18.4.18 single conversion, §18.4.32
 * temperature sensor). Every step out of order is a violation (the run stops in strict mode)
 * and does nothing, as a conversion that never comes on the part. The die's temperature is
 * the trace's temp_c at the conversion (twin_world_temp_at_us); the factory words in system
 * memory and the supply are TWIN_TS_CAL1/2, TWIN_VREFINT_CAL and TWIN_VDDA_MV (one plausible
 * part, not a measured one). A row without temp_c converts the sensor as 0: an implausible
 * reading the firmware refuses, so that sample has no temperature, as in host_sim.
 */
#include <math.h>

#include "twin.h"
#include "twin_world.h"

/* Offsets (RM0351 §18.6 "ADC register map"; the common block at + 0x300, §18.7). */
#define ADC_ISR   0x00u
#define ADC_IER   0x04u
#define ADC_CR    0x08u
#define ADC_CFGR  0x0Cu
#define ADC_CFGR2 0x10u
#define ADC_SMPR1 0x14u
#define ADC_SMPR2 0x18u
#define ADC_SQR1  0x30u
#define ADC_DR    0x40u
#define ADC_CSR   0x300u
#define ADC_CCR   0x308u

#define ISR_ADRDY   (1u << 0)
#define ISR_EOC     (1u << 2)
#define ISR_EOS     (1u << 3)
#define CR_ADEN     (1u << 0)
#define CR_ADDIS    (1u << 1)
#define CR_ADSTART  (1u << 2)
#define CR_ADSTP    (1u << 4)
#define CR_ADVREGEN (1u << 28)
#define CR_DEEPPWD  (1u << 29)
#define CR_ADCALDIF (1u << 30)
#define CR_ADCAL    (1u << 31)
#define CCR_CKMODE  (3u << 16)
#define CCR_VREFEN  (1u << 22)
#define CCR_TSEN    (1u << 23)

#define PS_PER_US 1000000ull
/* DS10198 "ADC characteristics": tADCVREG_STUP <= 20 us; tCAL = 116 ADC clocks (RM0351
 * §18.4.8); ADRDY a few ADC clocks after ADEN (modelled: 2 us). */
#define REGULATOR_STARTUP_PS (20u * PS_PER_US)
#define CAL_CYCLES           116u
#define READY_PS             (2u * PS_PER_US)
/* The sensor's and VREFINT buffer's start-up before a sample (DS10198 "Temperature sensor
 * characteristics" tSTART, "Embedded internal voltage reference" tstart_vrefint), taken as
 * 120 us; their least sampling times: tS_temp 5 us, tS_vrefint 4 us. */
#define PATHS_STARTUP_PS   (120u * PS_PER_US)
#define TS_SAMPLE_MIN_PS   (5u * PS_PER_US)
#define VREF_SAMPLE_MIN_PS (4u * PS_PER_US)
#define CH_VREFINT         0u
#define CH_TS              17u

/* Sampling time codes in half ADC clocks (RM0351 §18.6.6): 2.5 .. 640.5 cycles. */
static const uint32_t smp_half_cycles[8] = {5u, 13u, 25u, 49u, 95u, 185u, 495u, 1281u};

static void violation(struct twin *t, const char *what, uint32_t value, const char *rule) {
    twin_svc_violation(&t->svc, what, value, rule);
}

void twin_adc_reset(struct twin *t) {
    t->adc = (struct twin_adc){
        .cr = CR_DEEPPWD, /* reset value 0x2000 0000 */
        .cfgr = 0x80000000u,
        .regulator_ps = UINT64_MAX,
        .paths_ps = UINT64_MAX,
        .cal_done_ps = UINT64_MAX,
        .ready_ps = UINT64_MAX,
        .eoc_ps = UINT64_MAX,
        .conversions = t->adc.conversions,
        .sensor_conversions = t->adc.sensor_conversions,
        .unknown_temperature = t->adc.unknown_temperature,
        .first_cdeg = t->adc.first_cdeg,
        .last_cdeg = t->adc.last_cdeg,
    };
}

/* The ADC clock (RM0351 §18.4.3): CKMODE 01 HCLK/1, 10 HCLK/2, 11 HCLK/4 (AHB prescaler 1,
 * as the firmware leaves it); 00 takes the RCC's kernel clock, which the twin does not model:
 * 0, and the caller says so. */
static uint32_t adc_hz(const struct twin *t) {
    const uint32_t mode = (t->adc.ccr & CCR_CKMODE) >> 16;
    return mode == 0u ? 0u : t->sysclk_hz >> (mode - 1u);
}

static uint64_t cycles_ps(const struct twin *t, uint64_t half_cycles) {
    const uint32_t hz = adc_hz(t);
    return hz == 0u ? UINT64_MAX : half_cycles * 500000000000ull / hz;
}

/* Bring the flags up to now. */
static void update(struct twin *t) {
    struct twin_adc *a = &t->adc;
    const uint64_t now = twin_svc_now_ps(&t->svc);
    if (a->cal_done_ps != UINT64_MAX && now >= a->cal_done_ps) {
        a->cr &= ~CR_ADCAL;
        a->cal_done_ps = UINT64_MAX;
        a->calibrated = true;
    }
    if (a->ready_ps != UINT64_MAX && now >= a->ready_ps) {
        a->isr |= ISR_ADRDY;
        a->ready_ps = UINT64_MAX;
    }
    if (a->eoc_ps != UINT64_MAX && now >= a->eoc_ps) {
        a->dr = a->result;
        a->isr |= ISR_EOC | ISR_EOS;
        a->cr &= ~CR_ADSTART;
        a->eoc_ps = UINT64_MAX;
        a->conversions++;
    }
}

/* What the channel converts to now: the die at the trace's temperature, VREFINT, both at
 * VDDA = TWIN_VDDA_MV, rounded to 12 bits. */
static uint16_t sample(struct twin *t, uint8_t channel, uint64_t now_ps) {
    const double scale = 3000.0 / TWIN_VDDA_MV;
    if (channel == CH_VREFINT) {
        return (uint16_t)lround(TWIN_VREFINT_CAL * scale);
    }
    int16_t cdeg = 0;
    if (t->world == NULL || !twin_world_temp_at_us(t->world, now_ps / PS_PER_US, &cdeg)) {
        t->adc.unknown_temperature++;
        return 0u;
    }
    if (t->adc.sensor_conversions++ == 0u) {
        t->adc.first_cdeg = cdeg;
    }
    t->adc.last_cdeg = cdeg;
    const double at_3v0 =
        TWIN_TS_CAL1 + (cdeg / 100.0 - 30.0) * (double)(TWIN_TS_CAL2 - TWIN_TS_CAL1) / 80.0;
    const long raw = lround(at_3v0 * scale);
    return (uint16_t)(raw < 0 ? 0 : raw > 4095 ? 4095 : raw);
}

static void start_conversion(struct twin *t) {
    struct twin_adc *a = &t->adc;
    const uint64_t now = twin_svc_now_ps(&t->svc);
    const uint8_t channel = (uint8_t)((a->sqr1 >> 6) & 0x1Fu);
    if ((a->isr & ISR_ADRDY) == 0u || (a->cr & CR_ADEN) == 0u) {
        violation(t, "ADC_CR.ADSTART", a->cr, "ADSTART before ADRDY (RM0351 §18.4.9, §18.6.3)");
        return;
    }
    if ((a->sqr1 & 0xFu) != 0u) {
        violation(t, "ADC_SQR1", a->sqr1, "the twin models one conversion a start (L = 0)");
        return;
    }
    if (channel != CH_TS && channel != CH_VREFINT) {
        violation(t, "ADC_SQR1.SQ1", channel, "channel not modelled (the internal ones: 0, 17)");
        return;
    }
    const uint32_t path = channel == CH_TS ? CCR_TSEN : CCR_VREFEN;
    if ((a->ccr & path) == 0u || a->paths_ps == UINT64_MAX ||
        now < a->paths_ps + PATHS_STARTUP_PS) {
        violation(t, "ADC_CR.ADSTART", channel,
                  "internal channel converted before its path's start-up (TSEN / VREFEN, "
                  "DS10198 tSTART)");
        return;
    }
    const uint32_t reg = channel < 10u ? a->smpr1 : a->smpr2;
    const uint32_t code = (reg >> ((channel % 10u) * 3u)) & 7u;
    const uint64_t sample_ps = cycles_ps(t, smp_half_cycles[code]);
    const uint64_t least = channel == CH_TS ? TS_SAMPLE_MIN_PS : VREF_SAMPLE_MIN_PS;
    if (sample_ps < least) {
        violation(t, "ADC_SMPRx", code,
                  "sampling time shorter than the datasheet's (DS10198 tS_temp 5 us, "
                  "tS_vrefint 4 us)");
        return;
    }
    a->cr |= CR_ADSTART;
    a->isr &= ~(ISR_EOC | ISR_EOS);
    a->channel = channel;
    a->result = sample(t, channel, now);
    a->eoc_ps = now + sample_ps + cycles_ps(t, 25u); /* + 12.5 clocks of conversion (§18.4.16) */
}

static void write_cr(struct twin *t, uint32_t v) {
    struct twin_adc *a = &t->adc;
    const uint64_t now = twin_svc_now_ps(&t->svc);
    update(t);
    const uint32_t before = a->cr;
    /* DEEPPWD and ADVREGEN are plain bits, writable with ADEN = 0 only (§18.6.3). */
    if (((v ^ before) & (CR_DEEPPWD | CR_ADVREGEN)) != 0u) {
        if ((before & CR_ADEN) != 0u) {
            violation(t, "ADC_CR", v, "DEEPPWD / ADVREGEN changed with ADEN = 1 (RM0351 §18.6.3)");
            return;
        }
        if ((v & CR_ADVREGEN) != 0u && (before & CR_ADVREGEN) == 0u &&
            ((v | before) & CR_DEEPPWD) != 0u) {
            violation(t, "ADC_CR", v,
                      "ADVREGEN in deep power-down: DEEPPWD is cleared first, by its own write "
                      "(§18.4.6)");
            return;
        }
        a->cr = (a->cr & ~(CR_DEEPPWD | CR_ADVREGEN)) | (v & (CR_DEEPPWD | CR_ADVREGEN));
        if ((v & CR_ADVREGEN) == 0u) {
            a->regulator_ps = UINT64_MAX;
            a->calibrated = false; /* the calibration is lost with the regulator (§18.4.8) */
        } else if ((before & CR_ADVREGEN) == 0u) {
            a->regulator_ps = now;
        }
    }
    if ((v & CR_ADCAL) != 0u && (before & CR_ADCAL) == 0u) {
        if ((before & CR_ADEN) != 0u || a->regulator_ps == UINT64_MAX ||
            now < a->regulator_ps + REGULATOR_STARTUP_PS || adc_hz(t) == 0u) {
            violation(t, "ADC_CR.ADCAL", v,
                      "calibration needs ADEN = 0, the regulator started (tADCVREG_STUP) and "
                      "an ADC clock (§18.4.8, §18.4.3)");
            return;
        }
        a->cr = (a->cr & ~CR_ADCALDIF) | (v & CR_ADCALDIF) | CR_ADCAL;
        a->cal_done_ps = now + cycles_ps(t, 2u * CAL_CYCLES);
        return;
    }
    if ((v & CR_ADEN) != 0u && (before & CR_ADEN) == 0u) {
        if ((before & CR_ADCAL) != 0u || !a->calibrated || a->regulator_ps == UINT64_MAX) {
            violation(t, "ADC_CR.ADEN", v,
                      "ADEN during or without a calibration, or without the regulator "
                      "(§18.4.8, §18.4.9)");
            return;
        }
        a->cr |= CR_ADEN;
        a->ready_ps = now + READY_PS;
    }
    if ((v & CR_ADSTP) != 0u && (before & CR_ADSTART) != 0u) {
        a->cr &= ~CR_ADSTART;
        a->eoc_ps = UINT64_MAX;
    }
    if ((v & CR_ADDIS) != 0u) {
        if ((a->cr & CR_ADEN) == 0u || (a->cr & CR_ADSTART) != 0u) {
            violation(t, "ADC_CR.ADDIS", v, "ADDIS needs ADEN = 1 and no conversion (§18.4.9)");
            return;
        }
        a->cr &= ~CR_ADEN;
        a->isr &= ~ISR_ADRDY;
        a->ready_ps = UINT64_MAX;
    }
    if ((v & CR_ADSTART) != 0u && (before & CR_ADSTART) == 0u) {
        start_conversion(t);
    }
}

uint32_t twin_adc_read(struct twin *t, uint32_t off) {
    struct twin_adc *a = &t->adc;
    update(t);
    switch (off) {
    case ADC_ISR: {
        /* A poll of a flag that is coming: time moves to it (twin_svc_warp_to). */
        const uint64_t next = a->eoc_ps < a->ready_ps ? a->eoc_ps : a->ready_ps;
        if (next != UINT64_MAX) {
            twin_svc_warp_to(&t->svc, next);
            update(t);
        }
        return a->isr;
    }
    case ADC_CR:
        if (a->cal_done_ps != UINT64_MAX) {
            twin_svc_warp_to(&t->svc, a->cal_done_ps);
            update(t);
        }
        return a->cr;
    case ADC_CFGR:
        return a->cfgr;
    case ADC_SMPR1:
        return a->smpr1;
    case ADC_SMPR2:
        return a->smpr2;
    case ADC_SQR1:
        return a->sqr1;
    case ADC_DR:
        a->isr &= ~ISR_EOC; /* reading DR clears EOC (§18.6.1) */
        return a->dr;
    case ADC_CCR:
        return a->ccr;
    case ADC_IER:
    case ADC_CFGR2:
    case ADC_CSR:
        return 0u;
    default:
        violation(t, "ADC register", off, "ADC offset the twin does not model (RM0351 §18.6)");
        return 0u;
    }
}

void twin_adc_write(struct twin *t, uint32_t off, uint32_t v) {
    struct twin_adc *a = &t->adc;
    update(t);
    const bool converting = (a->cr & CR_ADSTART) != 0u;
    switch (off) {
    case ADC_ISR:
        a->isr &= ~v; /* write 1 to clear */
        break;
    case ADC_CR:
        write_cr(t, v);
        break;
    case ADC_CFGR:
    case ADC_SMPR1:
    case ADC_SMPR2:
    case ADC_SQR1:
        if (converting) {
            violation(t, "ADC configuration", v,
                      "CFGR / SMPRx / SQR1 written during a conversion (§18.6.4)");
            break;
        }
        *(off == ADC_CFGR    ? &a->cfgr
          : off == ADC_SMPR1 ? &a->smpr1
          : off == ADC_SMPR2 ? &a->smpr2
                             : &a->sqr1) = v;
        break;
    case ADC_CCR: {
        if ((a->cr & CR_ADEN) != 0u && ((v ^ a->ccr) & CCR_CKMODE) != 0u) {
            violation(t, "ADC_CCR.CKMODE", v, "CKMODE changed with the ADC enabled (§18.7.2)");
            break;
        }
        const uint32_t both = CCR_TSEN | CCR_VREFEN;
        if ((v & both) == both && (a->ccr & both) != both) {
            a->paths_ps = twin_svc_now_ps(&t->svc);
        } else if ((v & both) != both) {
            a->paths_ps = UINT64_MAX;
        }
        a->ccr = v;
        break;
    }
    case ADC_IER:
    case ADC_CFGR2:
        if (v != 0u) {
            violation(t, "ADC register", off, "interrupts and oversampling are not modelled");
        }
        break;
    default:
        violation(t, "ADC register", off, "ADC offset the twin does not model (RM0351 §18.6)");
    }
}

/* System memory 0x1FFF7000..0x1FFF7FFF: the calibration half-words at 0x1FFF75A8 (TS_CAL1),
 * 0x1FFF75AA (VREFINT_CAL) and 0x1FFF75CA (TS_CAL2) (DS10198 "Temperature sensor calibration
 * values", "Internal voltage reference calibration values"); the rest of the page is not
 * modelled. */
uint32_t twin_adc_sysmem_read(struct twin *t, uint32_t off) {
    switch (off & ~3u) {
    case 0x5A8u:
        return TWIN_TS_CAL1 | (TWIN_VREFINT_CAL << 16);
    case 0x5C8u:
        return 0xFFFFu | (TWIN_TS_CAL2 << 16); /* 0x1FFF75C8 is not modelled: erased */
    default:
        violation(t, "system memory", TWIN_SYSMEM_CAL_PAGE + off,
                  "system memory the twin does not model (only the ADC's calibration)");
        return 0xFFFFFFFFu;
    }
}
