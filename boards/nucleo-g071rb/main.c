/*
 * NUCLEO-G071RB (STM32G071RB, Cortex-M0+): the same firmware on a core with no
 * FPU and no divide instruction. After reset SYSCLK is HSI16 = 16 MHz
 * (RM0444 §5.2); the log goes to USART2 on PA2 (ST-LINK VCP, UM2324 §6.9).
 * Register addresses: RM0444 Table 6, §5.4, §6.4.
 */
#include "board.h"
#include "firmware/app.h"
#include "stm32_usart.h"

#define RCC_BASE       0x40021000u
#define RCC_IOPENR     (RCC_BASE + 0x34u) /* bit 0: GPIOAEN */
#define RCC_APBENR1    (RCC_BASE + 0x3Cu) /* bit 17: USART2EN */
#define GPIOA_BASE     0x50000000u
#define GPIO_MODER     0x00u
#define GPIO_AFRL      0x20u
#define USART2_BASE    0x40004400u
#define HSI16_HZ       16000000u
#define LOG_BAUD       115200u
#define PA2_AF1_USART2 1u /* STM32G071 datasheet, Table 13: PA2 AF1 = USART2_TX */

static struct stm32_usart log_usart = {
    .base = USART2_BASE,
    .brr = (HSI16_HZ + LOG_BAUD / 2u) / LOG_BAUD,
    .spin_max = 40000u,
};

static const struct hal_log_ops usart_log_ops = {.write = stm32_usart_log_write};

static void board_init(void) {
    stm32_reg_write(RCC_IOPENR, stm32_reg_read(RCC_IOPENR) | (1u << 0));
    stm32_reg_write(RCC_APBENR1, stm32_reg_read(RCC_APBENR1) | (1u << 17));
    (void)stm32_reg_read(RCC_APBENR1);
    uint32_t moder = stm32_reg_read(GPIOA_BASE + GPIO_MODER);
    moder = (moder & ~(3u << 4)) | (2u << 4);
    stm32_reg_write(GPIOA_BASE + GPIO_MODER, moder);
    uint32_t afrl = stm32_reg_read(GPIOA_BASE + GPIO_AFRL);
    afrl = (afrl & ~(0xFu << 8)) | (PA2_AF1_USART2 << 8);
    stm32_reg_write(GPIOA_BASE + GPIO_AFRL, afrl);
    stm32_usart_init(&log_usart);
}

/* The application's state: static, so its size shows in the map file, not on the stack. */
static struct tof_app app;

int main(void) {
    board_init();
    static const struct tof_platform platform = {
        .board_name = "nucleo-g071rb",
        .log = {.ops = &usart_log_ops, .ctx = &log_usart},
    };
    return tof_app_main(&platform, &tof_app_default_config, &app, NULL, 0);
}

void board_exit(int status) {
    (void)status;
    cortex_m_system_reset();
}

void board_fault(const char *what) {
    static const char prefix[] = "FAULT: ";
    stm32_usart_log_write(&log_usart, prefix, sizeof prefix - 1u);
    for (unsigned n = 0; what[n] != '\0' && n < 64u; ++n) {
        stm32_usart_log_write(&log_usart, &what[n], 1u);
    }
    cortex_m_system_reset();
}
