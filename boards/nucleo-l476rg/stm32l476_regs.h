/*
 * STM32L476 addresses and bits used by board_desc.c. Base addresses: RM0351
 * §2.2.2 Table 1 "STM32L4x6 memory map and peripheral register boundary
 * addresses"; RCC bits: RM0351 §6.4 "RCC registers" (register named at each
 * group); DBGMCU: RM0351 chapter "Debug support (DBG)", "DBGMCU APB1
 * peripheral freeze register 1". Values as in ST's STM32L476xx CMSIS header.
 */
#ifndef BOARDS_NUCLEO_L476RG_STM32L476_REGS_H
#define BOARDS_NUCLEO_L476RG_STM32L476_REGS_H

#define L476_RCC_BASE    0x40021000u
#define L476_GPIOA_BASE  0x48000000u
#define L476_GPIOB_BASE  0x48000400u
#define L476_GPIOC_BASE  0x48000800u
#define L476_USART2_BASE 0x40004400u
#define L476_I2C1_BASE   0x40005400u
#define L476_IWDG_BASE   0x40003000u
/* ADC1 and the ADC common registers (ADC1 + 0x300): RM0351 Table 1, AHB2 "ADC"
 * 0x5004 0000 - 0x5004 03FF, and §18.7 "ADC common registers". */
#define L476_ADC1_BASE       0x50040000u
#define L476_ADC_COMMON_BASE 0x50040300u

/* RCC_CR: HSI16 and the main PLL on / ready. */
#define L476_RCC_CR        (L476_RCC_BASE + 0x00u)
#define L476_RCC_CR_HSION  (1u << 8)
#define L476_RCC_CR_HSIRDY (1u << 10)
#define L476_RCC_CR_PLLON  (1u << 24)
#define L476_RCC_CR_PLLRDY (1u << 25)
/* RCC_CFGR: SW[1:0] selects SYSCLK, SWS[3:2] reports it; 01 = HSI16, 11 = PLL. */
#define L476_RCC_CFGR           (L476_RCC_BASE + 0x08u)
#define L476_RCC_CFGR_SW_MASK   (3u << 0)
#define L476_RCC_CFGR_SW_HSI16  (1u << 0)
#define L476_RCC_CFGR_SW_PLL    (3u << 0)
#define L476_RCC_CFGR_SWS_MASK  (3u << 2)
#define L476_RCC_CFGR_SWS_HSI16 (1u << 2)
#define L476_RCC_CFGR_SWS_PLL   (3u << 2)
/* RCC_PLLCFGR (RM0351 §6.4.4): PLLSRC[1:0] (10 = HSI16), PLLM[6:4] (/ PLLM + 1), PLLN[14:8],
 * PLLREN (24) enables PLLCLK, PLLR[26:25] (00 /2, 01 /4, 10 /6, 11 /8). */
#define L476_RCC_PLLCFGR              (L476_RCC_BASE + 0x0Cu)
#define L476_RCC_PLLCFGR_PLLSRC_HSI16 (2u << 0)
#define L476_RCC_PLLCFGR_PLLN_SHIFT   8u
#define L476_RCC_PLLCFGR_PLLREN       (1u << 24)
#define L476_RCC_PLLCFGR_PLLR_SHIFT   25u
/* FLASH_ACR (RM0351 §3.7.1): LATENCY[2:0], the flash wait states. */
#define L476_FLASH_ACR              0x40022000u
#define L476_FLASH_ACR_LATENCY_MASK 7u
/* RCC_AHB2ENR: GPIO port clocks. */
#define L476_RCC_AHB2ENR         (L476_RCC_BASE + 0x4Cu)
#define L476_RCC_AHB2ENR_GPIOAEN (1u << 0)
#define L476_RCC_AHB2ENR_GPIOBEN (1u << 1)
#define L476_RCC_AHB2ENR_GPIOCEN (1u << 2)
#define L476_RCC_AHB2ENR_ADCEN   (1u << 13)
/* RCC_APB1ENR1. */
#define L476_RCC_APB1ENR1          (L476_RCC_BASE + 0x58u)
#define L476_RCC_APB1ENR1_USART2EN (1u << 17)
#define L476_RCC_APB1ENR1_I2C1EN   (1u << 21)
/* RCC_CCIPR: I2C1SEL[13:12] = 10 -> HSI16 kernel clock; USART2SEL
 * [3:2] stays 00 -> PCLK1 (= SYSCLK = 16 MHz with the reset prescalers). */
#define L476_RCC_CCIPR               (L476_RCC_BASE + 0x88u)
#define L476_RCC_CCIPR_I2C1SEL_MASK  (3u << 12)
#define L476_RCC_CCIPR_I2C1SEL_HSI16 (2u << 12)

/* DBGMCU_APB1FZR1: DBG_IWDG_STOP freezes the IWDG while the core is halted. */
#define L476_DBGMCU_APB1FZR1               0xE0042008u
#define L476_DBGMCU_APB1FZR1_DBG_IWDG_STOP (1u << 12)

/* The ADC's internal channels and the factory calibration in system memory (RM0351 §18.2
 * "ADC implementation" / §18.4.32 "Temperature sensor"; the STM32L476xx datasheet DS10198
 * §3.15.1 "Temperature sensor", Table "Temperature sensor calibration values", and
 * "Internal voltage reference calibration values"): raw 12-bit conversions at Vref+ = 3.0 V.
 * TS_CAL2 is taken at 110 °C on the STM32L471/475/476/485/486 (other L4 parts: 130 °C;
 * ST's LL ADC header TEMPSENSOR_CAL2_TEMP agrees for the L476). VREFINT is ADC1_IN0, the
 * sensor ADC1_IN17. */
#define L476_TS_CAL1_ADDR      0x1FFF75A8u /* 30 °C */
#define L476_TS_CAL2_ADDR      0x1FFF75CAu /* 110 °C */
#define L476_VREFINT_CAL_ADDR  0x1FFF75AAu /* 30 °C */
#define L476_TS_CAL1_CDEG      3000
#define L476_TS_CAL2_CDEG      11000
#define L476_ADC_CH_VREFINT    0u
#define L476_ADC_CH_TEMPSENSOR 17u

/* Alternate functions: STM32L476xx datasheet (DS10198) Table 17 "Alternate
 * function AF0 to AF7", cross-checked with ST's pin data as exported in
 * zephyrproject-rtos/hal_stm32 dts/st/l4/stm32l476r(c-e-g)tx-pinctrl.dtsi. */
#define L476_AF7_USART2_TX_PA2 7u
#define L476_AF4_I2C1_PB8_PB9  4u

#endif /* BOARDS_NUCLEO_L476RG_STM32L476_REGS_H */
