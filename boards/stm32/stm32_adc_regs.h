/*
 * Register map of the STM32L4 ADC as the internal temperature sensor uses it: RM0351
 * (STM32L4x5/L4x6 reference manual) §18 "Analog-to-digital converters (ADC)", §18.6 "ADC
 * registers (for each ADC)" and §18.7 "ADC common registers"; offsets and bits as in ST's
 * STM32L476xx CMSIS header (ADC_TypeDef: ISR 0x00 .. DR 0x40; ADC_Common_TypeDef: CSR 0x00,
 * CCR 0x08). The STM32G0's ADC (RM0444 §15) has another layout (CHSELR, one SMPR, no
 * DEEPPWD) and is not described here.
 */
#ifndef BOARDS_STM32_ADC_REGS_H
#define BOARDS_STM32_ADC_REGS_H

/* Offsets from the ADC's base (§18.6, "ADC register map"). */
#define STM32_ADC_ISR   0x00u
#define STM32_ADC_CR    0x08u
#define STM32_ADC_CFGR  0x0Cu
#define STM32_ADC_SMPR1 0x14u /* SMP0..SMP9, 3 bits each from bit 0 */
#define STM32_ADC_SMPR2 0x18u /* SMP10..SMP18, 3 bits each from bit 0 */
#define STM32_ADC_SQR1  0x30u
#define STM32_ADC_DR    0x40u
/* Offset of the common block's CCR from the common base (ADC1 base + 0x300, §18.7). */
#define STM32_ADC_COMMON_CCR 0x08u

/* ADC_ISR (§18.6.1): write 1 to clear. */
#define STM32_ADC_ISR_ADRDY (1u << 0)
#define STM32_ADC_ISR_EOC   (1u << 2)
#define STM32_ADC_ISR_EOS   (1u << 3)
#define STM32_ADC_ISR_OVR   (1u << 4)

/* ADC_CR (§18.6.3). Reset value 0x2000 0000: in deep power-down. */
#define STM32_ADC_CR_ADEN     (1u << 0)
#define STM32_ADC_CR_ADDIS    (1u << 1)
#define STM32_ADC_CR_ADSTART  (1u << 2)
#define STM32_ADC_CR_ADSTP    (1u << 4)
#define STM32_ADC_CR_ADVREGEN (1u << 28)
#define STM32_ADC_CR_DEEPPWD  (1u << 29)
#define STM32_ADC_CR_ADCALDIF (1u << 30)
#define STM32_ADC_CR_ADCAL    (1u << 31)

/* ADC_CFGR (§18.6.4): reset value 0x8000 0000 (JQDIS): 12-bit, right-aligned, single
 * conversion, software trigger; OVRMOD = 1 lets a new result overwrite an unread one. */
#define STM32_ADC_CFGR_RESET  0x80000000u
#define STM32_ADC_CFGR_OVRMOD (1u << 12)

/* ADC_SMPRx field of channel `ch` (3 bits) and the longest sampling time, 640.5 ADC clock
 * cycles (code 111, §18.6.6). */
#define STM32_ADC_SMP_BITS  3u
#define STM32_ADC_SMP_640_5 7u

/* ADC_SQR1 (§18.6.11): L[3:0] = conversions - 1, SQ1[10:6] the first channel. */
#define STM32_ADC_SQR1_SQ1_SHIFT 6u

/* ADC_CCR (§18.7.2): CKMODE[17:16] (01: HCLK/1, 10: HCLK/2), VREFEN (22), TSEN (23). */
#define STM32_ADC_CCR_CKMODE_MASK  (3u << 16)
#define STM32_ADC_CCR_CKMODE_HCLK2 (2u << 16)
#define STM32_ADC_CCR_VREFEN       (1u << 22)
#define STM32_ADC_CCR_TSEN         (1u << 23)

#endif /* BOARDS_STM32_ADC_REGS_H */
