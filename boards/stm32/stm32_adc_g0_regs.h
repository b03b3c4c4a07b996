/*
 * Register map of the STM32G0 ADC as the internal temperature sensor uses it: RM0444
 * (STM32G0x1 reference manual) §15 "Analog-to-digital converter (ADC)", "ADC registers";
 * offsets and bits as in ST's STM32G071xx CMSIS header (ADC_TypeDef: ISR 0x00 .. DR 0x40,
 * CCR at 0x308 from the ADC's base). Its layout differs from the L4's (stm32_adc_regs.h): one
 * sampling-time register with two codes and a per-channel selector, channels chosen by a bit
 * mask (CHSELR) that is applied once CCRDY rises, the clock mode in CFGR2, no deep power-down.
 */
#ifndef BOARDS_STM32_ADC_G0_REGS_H
#define BOARDS_STM32_ADC_G0_REGS_H

#define STM32_ADC_G0_ISR    0x00u
#define STM32_ADC_G0_CR     0x08u
#define STM32_ADC_G0_CFGR1  0x0Cu
#define STM32_ADC_G0_CFGR2  0x10u
#define STM32_ADC_G0_SMPR   0x14u
#define STM32_ADC_G0_CHSELR 0x28u
#define STM32_ADC_G0_DR     0x40u
/* CCR from the common base (the ADC's base + 0x300), as on the L4: STM32_ADC_COMMON_CCR. */

/* ADC_ISR: write 1 to clear. CCRDY: the channel configuration written is applied. */
#define STM32_ADC_G0_ISR_ADRDY (1u << 0)
#define STM32_ADC_G0_ISR_EOC   (1u << 2)
#define STM32_ADC_G0_ISR_EOS   (1u << 3)
#define STM32_ADC_G0_ISR_OVR   (1u << 4)
#define STM32_ADC_G0_ISR_CCRDY (1u << 13)

/* ADC_CR (reset value 0). */
#define STM32_ADC_G0_CR_ADEN     (1u << 0)
#define STM32_ADC_G0_CR_ADDIS    (1u << 1)
#define STM32_ADC_G0_CR_ADSTART  (1u << 2)
#define STM32_ADC_G0_CR_ADSTP    (1u << 4)
#define STM32_ADC_G0_CR_ADVREGEN (1u << 28)
#define STM32_ADC_G0_CR_ADCAL    (1u << 31)

/* ADC_CFGR1 (reset 0: 12-bit, right-aligned, single conversion, software trigger, CHSELR as a
 * bit mask): OVRMOD lets a new result overwrite an unread one. */
#define STM32_ADC_G0_CFGR1_OVRMOD (1u << 12)

/* ADC_CFGR2: CKMODE[31:30] (01: PCLK/2), written with ADEN = 0 only. */
#define STM32_ADC_G0_CFGR2_CKMODE_PCLK2 (1u << 30)

/* ADC_SMPR: SMP1[2:0] is every channel's sampling time while its SMPSELx (bit 8 + x) is 0;
 * code 111: 160.5 ADC clock cycles. */
#define STM32_ADC_G0_SMP_160_5 7u

#endif /* BOARDS_STM32_ADC_G0_REGS_H */
