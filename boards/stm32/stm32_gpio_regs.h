/*
 * GPIO port register map shared by STM32L476 (RM0351 §8.5 "GPIO registers")
 * and STM32G071 (RM0444 §6.4 "GPIO registers"); the layout is the same on
 * both (ST CMSIS GPIO_TypeDef: MODER 0x00 ... BRR 0x28).
 */
#ifndef BOARDS_STM32_GPIO_REGS_H
#define BOARDS_STM32_GPIO_REGS_H

#define STM32_GPIO_MODER   0x00u /* 2 bits per pin */
#define STM32_GPIO_OTYPER  0x04u /* 1 bit per pin: 1 = open-drain */
#define STM32_GPIO_OSPEEDR 0x08u /* 2 bits per pin */
#define STM32_GPIO_PUPDR   0x0Cu /* 2 bits per pin */
#define STM32_GPIO_IDR     0x10u /* input level of each pin, also readable in AF mode */
#define STM32_GPIO_ODR     0x14u /* */
#define STM32_GPIO_BSRR    0x18u /* bits 0-15 set, bits 16-31 reset, atomic */
#define STM32_GPIO_AFRL    0x20u /* 4 bits per pin 0-7 */
#define STM32_GPIO_AFRH    0x24u /* 4 bits per pin 8-15 */

/* MODER values (2 bits). Reset state of most pins is analog (11). */
#define STM32_GPIO_MODE_INPUT  0u
#define STM32_GPIO_MODE_OUTPUT 1u
#define STM32_GPIO_MODE_AF     2u
#define STM32_GPIO_MODE_ANALOG 3u

/* PUPDR values (2 bits). */
#define STM32_GPIO_PULL_NONE 0u
#define STM32_GPIO_PULL_UP   1u
#define STM32_GPIO_PULL_DOWN 2u

#endif /* BOARDS_STM32_GPIO_REGS_H */
