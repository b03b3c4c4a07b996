/*
 * NUCLEO-L476RG (STM32L476RG, Cortex-M4F): the interface MCU board.
 * After reset the core runs from MSI at 4 MHz (RM0351 §6.2.3); the log goes to
 * USART2 on PA2, which the board routes to the ST-LINK virtual COM port
 * (UM1724 §6.8). Register addresses: RM0351 Table 1 and §6.4, §8.5.
 */
#include "board.h"
#include "firmware/app.h"
#include "stm32_usart.h"

#define RCC_BASE       0x40021000u
#define RCC_AHB2ENR    (RCC_BASE + 0x4Cu) /* bit 0: GPIOAEN */
#define RCC_APB1ENR1   (RCC_BASE + 0x58u) /* bit 17: USART2EN */
#define GPIOA_BASE     0x48000000u
#define GPIO_MODER     0x00u
#define GPIO_AFRL      0x20u
#define USART2_BASE    0x40004400u
#define MSI_CLOCK_HZ   4000000u
#define LOG_BAUD       115200u
#define PA2_AF7_USART2 7u /* STM32L476 datasheet, Table 17: PA2 AF7 = USART2_TX */

static struct stm32_usart log_usart = {
    .base = USART2_BASE,
    .brr = (MSI_CLOCK_HZ + LOG_BAUD / 2u) / LOG_BAUD,
    .spin_max = 10000u, /* one byte takes 87 us at 115200 Bd: >> 350 polls at 4 MHz */
};

static const struct hal_log_ops usart_log_ops = {.write = stm32_usart_log_write};

static void board_init(void) {
    stm32_reg_write(RCC_AHB2ENR, stm32_reg_read(RCC_AHB2ENR) | (1u << 0));
    stm32_reg_write(RCC_APB1ENR1, stm32_reg_read(RCC_APB1ENR1) | (1u << 17));
    (void)stm32_reg_read(RCC_APB1ENR1); /* read back: clock enable takes effect */
    uint32_t moder = stm32_reg_read(GPIOA_BASE + GPIO_MODER);
    moder = (moder & ~(3u << 4)) | (2u << 4); /* PA2: alternate function */
    stm32_reg_write(GPIOA_BASE + GPIO_MODER, moder);
    uint32_t afrl = stm32_reg_read(GPIOA_BASE + GPIO_AFRL);
    afrl = (afrl & ~(0xFu << 8)) | (PA2_AF7_USART2 << 8);
    stm32_reg_write(GPIOA_BASE + GPIO_AFRL, afrl);
    stm32_usart_init(&log_usart);
}

/* The application's state: static, so its size shows in the map file, not on the stack. */
static struct tof_app app;

int main(void) {
    board_init();
    static const struct tof_platform platform = {
        .board_name = "nucleo-l476rg",
        .log = {.ops = &usart_log_ops, .ctx = &log_usart},
    };
    return tof_app_main(&platform, &tof_app_default_config, &app, NULL, 0);
}

void board_exit(int status) {
    (void)status;
    cortex_m_system_reset(); /* an MCU has nowhere to return to */
}

void board_fault(const char *what) {
    static const char prefix[] = "FAULT: ";
    stm32_usart_log_write(&log_usart, prefix, sizeof prefix - 1u);
    for (unsigned n = 0; what[n] != '\0' && n < 64u; ++n) {
        stm32_usart_log_write(&log_usart, &what[n], 1u);
    }
    cortex_m_system_reset();
}
