/*
 * NUCLEO-G071RB board HAL: clocks, SysTick time, USART2 log, sensor GPIOs,
 * I2C1 and the independent watchdog (docs/boards.md has the pin map, clock
 * choice, I2C timing and watchdog figures). Same structure as
 * boards/nucleo-l476rg/board_hal.c; only addresses, clock enables and
 * alternate-function numbers differ.
 *
 * Clock: SYSCLK = HSISYS = HSI16 / 1 = 16 MHz, the reset configuration
 * (RM0444 §5.2), made explicit here; flash stays at 0 wait states (RM0444 "Embedded
 * flash memory", "Read access latency" table: 0 WS up to 24 MHz). Same core clock, SysTick
 * reload, USART BRR and I2C TIMINGR as the L476 board; I2C1 takes HSI16 as
 * its kernel clock.
 */
#include "board_hal.h"

#include "hal/hal_err.h"
#include "stm32_gpio.h"
#include "stm32_gpio_regs.h"
#include "stm32_i2c.h"
#include "stm32_i2c_regs.h"
#include "stm32_iwdg.h"
#include "stm32_reg.h"
#include "stm32_systick_time.h"
#include "stm32_usart.h"
#include "stm32g071_regs.h"

#define CORE_HZ  16000000u
#define LOG_BAUD 115200u
/* HSI16 runs from reset; the switch to HSISYS completes within a few cycles. */
#define CLOCK_READY_POLLS 10000u
/* IWDG update flags clear within ~5 LSI periods (~160 us); 10 ms is generous. */
#define IWDG_UPDATE_BUDGET_US 10000u

void SysTick_Handler(void);

static struct stm32_systick_time board_time;

static const struct hal_time board_time_handle = {&stm32_systick_time_ops, &board_time};

/* Numbered pins (board_hal.h): Arduino D2..D9 of the NUCLEO-G071RB (UM2324
 * "Arduino connectors"; same mapping in Zephyr
 * boards/arm/nucleo_g071rb/arduino_r3_connector.dtsi). D6 is PB14 on this
 * board (PB10 on the L476). SWD (PA13/PA14) is untouched. */
static const struct stm32_pin sensor_pins[8] = {
    {G071_GPIOA_BASE, 10u, STM32_PIN_OUTPUT_OPEN_DRAIN}, /* 0: XSHUT A, D2 */
    {G071_GPIOB_BASE, 3u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 1: XSHUT B, D3 */
    {G071_GPIOB_BASE, 5u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 2: XSHUT C, D4 */
    {G071_GPIOB_BASE, 4u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 3: XSHUT D, D5 */
    {G071_GPIOB_BASE, 14u, STM32_PIN_INPUT_PULL_UP},     /* 4: GPIO1 A, D6 */
    {G071_GPIOA_BASE, 8u, STM32_PIN_INPUT_PULL_UP},      /* 5: GPIO1 B, D7 */
    {G071_GPIOA_BASE, 9u, STM32_PIN_INPUT_PULL_UP},      /* 6: GPIO1 C, D8 */
    {G071_GPIOC_BASE, 7u, STM32_PIN_INPUT_PULL_UP},      /* 7: GPIO1 D, D9 */
};

static struct stm32_gpio board_gpio = {sensor_pins, 8u};

/* I2C1 on D15 = PB8 (SCL) and D14 = PB9 (SDA), AF6, 400 kHz. */
static const struct stm32_i2c_config i2c_config = {
    .base = G071_I2C1_BASE,
    .timingr = STM32_I2C_TIMINGR_400KHZ_AT_16MHZ,
    .byte_time_us = 23u, /* 9 bits x 2.5 us = 22.5 us */
    .core_cycles_per_us = CORE_HZ / 1000000u,
    .recovery_half_period_us = 5u,
    .scl = {G071_GPIOB_BASE, 8u, G071_AF6_I2C1_PB8_PB9},
    .sda = {G071_GPIOB_BASE, 9u, G071_AF6_I2C1_PB8_PB9},
    .time = {&stm32_systick_time_ops, &board_time},
};

static struct stm32_i2c board_i2c;

/* IWDG: LSI / 32 (PR = 3) = 1 ms per count at the nominal 32 kHz; RLR = 399
 * -> 400 ms. The LSI RC tolerance (datasheet "LSI oscillator characteristics")
 * scales the timeout by the same fraction. */
static const struct stm32_iwdg_config iwdg_config = {G071_IWDG_BASE, 3u, 399u};

static struct stm32_iwdg board_iwdg;

/* USART2 TX on PA2 -> ST-LINK virtual COM port; kernel clock PCLK = 16 MHz. */
static struct stm32_usart log_usart = {
    .base = G071_USART2_BASE,
    .brr = (CORE_HZ + LOG_BAUD / 2u) / LOG_BAUD, /* 139: 115108 Bd, -0.08 % */
    .spin_max = 40000u, /* one byte is 87 us = 1390 cycles: >> the polls it needs */
};

static const struct hal_log_ops log_ops = {.write = stm32_usart_log_write};

void SysTick_Handler(void) {
    stm32_systick_time_tick(&board_time);
}

/* Poll `addr` until (value & mask) == want, at most `polls` reads. */
static bool poll_bits(uintptr_t addr, uint32_t mask, uint32_t want, uint32_t polls) {
    for (uint32_t i = 0; i < polls; ++i) {
        if ((stm32_reg_read(addr) & mask) == want) {
            return true;
        }
    }
    return false;
}

/* SYSCLK = HSISYS with HSIDIV = /1: the reset state, asserted so that a
 * bootloader or debugger that changed it cannot leave the timing wrong. */
static int clock_init(void) {
    stm32_reg_modify(G071_RCC_CR, G071_RCC_CR_HSIDIV_MASK, G071_RCC_CR_HSION);
    if (!poll_bits(G071_RCC_CR, G071_RCC_CR_HSIRDY, G071_RCC_CR_HSIRDY, CLOCK_READY_POLLS)) {
        return HAL_ERR_TIMEOUT;
    }
    stm32_reg_modify(G071_RCC_CFGR, G071_RCC_CFGR_SW_MASK, 0u);
    if (!poll_bits(G071_RCC_CFGR, G071_RCC_CFGR_SWS_MASK, 0u, CLOCK_READY_POLLS)) {
        return HAL_ERR_TIMEOUT;
    }
    return HAL_OK;
}

static void peripheral_clocks_init(void) {
    stm32_reg_modify(G071_RCC_IOPENR, 0u,
                     G071_RCC_IOPENR_GPIOAEN | G071_RCC_IOPENR_GPIOBEN | G071_RCC_IOPENR_GPIOCEN);
    stm32_reg_modify(G071_RCC_CCIPR, G071_RCC_CCIPR_I2C1SEL_MASK, G071_RCC_CCIPR_I2C1SEL_HSI16);
    stm32_reg_modify(G071_RCC_APBENR1, 0u,
                     G071_RCC_APBENR1_USART2EN | G071_RCC_APBENR1_I2C1EN | G071_RCC_APBENR1_DBGEN);
    (void)stm32_reg_read(G071_RCC_APBENR1); /* read back: the enables have taken effect */
}

int board_hal_init(void) {
    int err = clock_init();
    if (err != HAL_OK) {
        return err;
    }
    peripheral_clocks_init();

    stm32_gpio_set_af(G071_GPIOA_BASE, 2u, G071_AF1_USART2_TX_PA2);
    /* PA3 = USART2_RX, the same AF as TX on this part (datasheet alternate-function table):
     * telemetry commands come in from the ST-LINK virtual COM port. */
    stm32_gpio_set_af(G071_GPIOA_BASE, 3u, G071_AF1_USART2_TX_PA2);
    stm32_gpio_set_mode(G071_GPIOA_BASE, 3u, STM32_GPIO_MODE_AF);
    stm32_gpio_set_mode(G071_GPIOA_BASE, 2u, STM32_GPIO_MODE_AF);
    stm32_usart_init(&log_usart);

    err = stm32_systick_time_init(&board_time, CORE_HZ);
    if (err == HAL_OK) {
        err = stm32_gpio_configure(&board_gpio);
    }
    if (err == HAL_OK) {
        err = stm32_i2c_init(&board_i2c, &i2c_config);
    }
    if (err == HAL_OK) {
        /* A debugger halt must not reset the board. */
        stm32_reg_modify(G071_DBG_APB_FZ1, 0u, G071_DBG_APB_FZ1_DBG_IWDG_STOP);
        err =
            stm32_iwdg_start(&board_iwdg, &iwdg_config, &board_time_handle, IWDG_UPDATE_BUDGET_US);
    }
    return err;
}

struct hal_i2c board_hal_i2c(void) {
    return stm32_i2c_hal(&board_i2c);
}

struct hal_gpio board_hal_gpio(void) {
    struct hal_gpio gpio = {&stm32_gpio_hal_ops, &board_gpio};
    return gpio;
}

struct hal_time board_hal_time(void) {
    return board_time_handle;
}

struct hal_watchdog board_hal_watchdog(void) {
    struct hal_watchdog wdg = {&stm32_iwdg_ops, &board_iwdg};
    return wdg;
}

struct hal_log board_hal_log(void) {
    struct hal_log log = {&log_ops, &log_usart};
    return log;
}

const struct stm32_i2c_stats *board_hal_i2c_stats(void) {
    return &board_i2c.stats;
}

void board_hal_fault_write(const char *text, size_t len) {
    stm32_usart_log_write(&log_usart, text, len); /* direct: no function pointer on the fault path */
}

struct hal_serial board_hal_serial(void) {
    struct hal_serial serial = {&stm32_usart_serial_ops, &log_usart};
    return serial;
}

uint32_t board_hal_log_dropped(void) {
    return log_usart.dropped;
}
