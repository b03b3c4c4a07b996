/*
 * STM32G071 addresses and bits used by board_desc.c. Base addresses: RM0444
 * §2.2 Table 6 "STM32G0x1 peripheral register boundary addresses"; RCC bits:
 * RM0444 §5.4 "RCC registers" (register named at each group); DBG: RM0444
 * chapter "Debug support (DBG)", "DBG APB freeze register 1". Values as in
 * ST's STM32G071xx CMSIS header.
 */
#ifndef BOARDS_NUCLEO_G071RB_STM32G071_REGS_H
#define BOARDS_NUCLEO_G071RB_STM32G071_REGS_H

#define G071_RCC_BASE    0x40021000u
#define G071_GPIOA_BASE  0x50000000u
#define G071_GPIOB_BASE  0x50000400u
#define G071_GPIOC_BASE  0x50000800u
#define G071_USART2_BASE 0x40004400u
#define G071_I2C1_BASE   0x40005400u
#define G071_IWDG_BASE   0x40003000u
#define G071_DBG_BASE    0x40015800u
/* The ADC and its common register (CCR at 0x40012708): RM0444 Table 6, APB "ADC"
 * 0x4001 2400 - 0x4001 27FF. */
#define G071_ADC_BASE        0x40012400u
#define G071_ADC_COMMON_BASE 0x40012700u

/* RCC_CR: HSI16 on/ready; HSIDIV[13:11] divides HSI16 into HSISYS (000 = /1). */
#define G071_RCC_CR             (G071_RCC_BASE + 0x00u)
#define G071_RCC_CR_HSION       (1u << 8)
#define G071_RCC_CR_HSIRDY      (1u << 10)
#define G071_RCC_CR_HSIDIV_MASK (7u << 11)
/* RCC_CFGR: SW[2:0] / SWS[5:3]; 000 = HSISYS. */
#define G071_RCC_CFGR          (G071_RCC_BASE + 0x08u)
#define G071_RCC_CFGR_SW_MASK  (7u << 0)
#define G071_RCC_CFGR_SWS_MASK (7u << 3)
/* RCC_IOPENR: GPIO port clocks. */
#define G071_RCC_IOPENR         (G071_RCC_BASE + 0x34u)
#define G071_RCC_IOPENR_GPIOAEN (1u << 0)
#define G071_RCC_IOPENR_GPIOBEN (1u << 1)
#define G071_RCC_IOPENR_GPIOCEN (1u << 2)
/* RCC_APBENR1. */
#define G071_RCC_APBENR1          (G071_RCC_BASE + 0x3Cu)
#define G071_RCC_APBENR1_USART2EN (1u << 17)
#define G071_RCC_APBENR1_I2C1EN   (1u << 21)
#define G071_RCC_APBENR1_DBGEN    (1u << 27)
/* RCC_APBENR2: ADCEN. */
#define G071_RCC_APBENR2       (G071_RCC_BASE + 0x40u)
#define G071_RCC_APBENR2_ADCEN (1u << 20)
/* RCC_CCIPR: I2C1SEL[13:12] = 10 -> HSI16; USART2SEL[3:2] = 00 -> PCLK. */
#define G071_RCC_CCIPR               (G071_RCC_BASE + 0x54u)
#define G071_RCC_CCIPR_I2C1SEL_MASK  (3u << 12)
#define G071_RCC_CCIPR_I2C1SEL_HSI16 (2u << 12)

/* DBG_APB_FZ1: DBG_IWDG_STOP freezes the IWDG while the core is halted. */
#define G071_DBG_APB_FZ1               (G071_DBG_BASE + 0x08u)
#define G071_DBG_APB_FZ1_DBG_IWDG_STOP (1u << 12)

/* The ADC's internal channels and the factory calibration in system memory (RM0444 §15
 * "ADC connectivity": the sensor on ADC_IN12, VREFINT on ADC_IN13; the STM32G071x8/xB
 * datasheet DS12232 "Temperature sensor calibration values", "Internal voltage reference
 * calibration values"): raw 12-bit conversions at Vref+ = 3.0 V, TS_CAL2 at 130 °C (the L476
 * takes it at 110 °C: stm32l476_regs.h). */
#define G071_TS_CAL1_ADDR      0x1FFF75A8u /* 30 °C */
#define G071_TS_CAL2_ADDR      0x1FFF75CAu /* 130 °C */
#define G071_VREFINT_CAL_ADDR  0x1FFF75AAu
#define G071_TS_CAL1_CDEG      3000
#define G071_TS_CAL2_CDEG      13000
#define G071_ADC_CH_TEMPSENSOR 12u
#define G071_ADC_CH_VREFINT    13u

/* Alternate functions: STM32G071x8/xB datasheet (DS12232) port A/B alternate
 * function tables (Table 13/14), cross-checked with ST's pin data as exported
 * in zephyrproject-rtos/hal_stm32 dts/st/g0/stm32g071r(6-8-b)tx-pinctrl.dtsi
 * (i2c1_scl_pb8 and i2c1_sda_pb9 are AF6). */
#define G071_AF1_USART2_TX_PA2 1u
#define G071_AF6_I2C1_PB8_PB9  6u

#endif /* BOARDS_NUCLEO_G071RB_STM32G071_REGS_H */
