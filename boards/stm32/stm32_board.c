/*
 * The board HAL (board_hal.h) of the STM32 NUCLEO boards, once for all of them:
 * SysTick time, USART2 log and telemetry, the sensor GPIOs, I2C1 at 400 kHz and
 * the independent watchdog. What differs per board is in its descriptor and its
 * clock functions (stm32_board.h; boards/nucleo-<board>/board_desc.c). Pin map, clock
 * choice, I2C timing and watchdog figures: docs/explanation/boards.md.
 */
#include "board_hal.h"

#include "hal/hal_err.h"
#include "stm32_board.h"
#include "stm32_gpio_regs.h"
#include "stm32_i2c_regs.h"
#include "stm32_iwdg.h"
#include "stm32_reg.h"
#include "stm32_systick_time.h"
#include "stm32_usart.h"

/* IWDG update flags clear within ~5 LSI periods (~160 us); 10 ms is generous. */
#define IWDG_UPDATE_BUDGET_US 10000u

void SysTick_Handler(void);
void Uart_IRQHandler(void);

static struct stm32_systick_time board_time;
static const struct hal_time board_time_handle = {&stm32_systick_time_ops, &board_time};
static struct stm32_gpio board_gpio;
static struct stm32_i2c_config i2c_config; /* filled from the descriptor at init */
static struct stm32_i2c board_i2c;
static struct stm32_iwdg_config iwdg_config;
static struct stm32_iwdg board_iwdg;
static struct stm32_usart log_usart;
static const struct hal_log_ops log_ops = {.write = stm32_usart_log_write};

void SysTick_Handler(void) {
    stm32_systick_time_tick(&board_time);
}

/* USART2's interrupt (the board's vector table entry, boards/cortex-m/startup.c). */
void Uart_IRQHandler(void) {
    stm32_usart_irq(&log_usart);
}

bool stm32_board_poll_bits(uintptr_t addr, uint32_t mask, uint32_t want, uint32_t polls) {
    for (uint32_t i = 0; i < polls; ++i) {
        if ((stm32_reg_read(addr) & mask) == want) {
            return true;
        }
    }
    return false;
}

/* USART2 TX/RX -> ST-LINK virtual COM port (log text and telemetry frames) at 115200 Bd
 * from a core clock of `core_hz`. */
static void log_uart_init(uint32_t core_hz) {
    const struct stm32_board_desc *d = &stm32_board_desc;
    log_usart = (struct stm32_usart){
        .base = d->usart_base,
        .brr = (core_hz + STM32_BOARD_LOG_BAUD / 2u) / STM32_BOARD_LOG_BAUD,
        .spin_max = 20000u,    /* one byte is 87 us = 6950 cycles at 80 MHz: >> the polls */
        .irq = BOARD_UART_IRQ, /* from the build: the vector table has the same entry */
    };
    stm32_gpio_set_af(d->usart_port, d->usart_tx_pin, d->usart_af);
    stm32_gpio_set_af(d->usart_port, d->usart_rx_pin, d->usart_af);
    stm32_gpio_set_mode(d->usart_port, d->usart_rx_pin, STM32_GPIO_MODE_AF);
    stm32_gpio_set_mode(d->usart_port, d->usart_tx_pin, STM32_GPIO_MODE_AF);
    stm32_usart_init(&log_usart);
}

int board_hal_init(void) {
    const struct stm32_board_desc *d = &stm32_board_desc;
    int err = stm32_board_clock_init();
    if (err != HAL_OK) {
        return err; /* the UART comes up at the reset clock if board_fault() reports this */
    }
    stm32_board_peripheral_clocks_init();
    const uint32_t core_hz =
        stm32_board_sysclk_hz(); /* the board's clock (docs/explanation/boards.md) */
    log_uart_init(core_hz);

    board_gpio = (struct stm32_gpio){d->sensor_pins, 2u * BOARD_HAL_SENSOR_COUNT};
    i2c_config = (struct stm32_i2c_config) {
        .base = d->i2c_base,
#if TOF_I2C_KHZ == 100
        .timingr = STM32_I2C_TIMINGR_100KHZ_AT_16MHZ, /* the build option TOF_I2C_KHZ */
            .byte_time_us = 90u,                      /* 9 bits x 10 us */
#else
        .timingr = STM32_I2C_TIMINGR_400KHZ_AT_16MHZ,
        .byte_time_us = 23u, /* 9 bits x 2.5 us = 22.5 us */
#endif
            .core_cycles_per_us = core_hz / 1000000u, .recovery_half_period_us = 5u,
        .scl = d->i2c_scl, .sda = d->i2c_sda, .time = board_time_handle,
    };
    /* IWDG: LSI / 32 (PR = 3) = 1 ms per count at the nominal 32 kHz; RLR = 399 -> 400 ms.
     * The LSI RC tolerance (datasheet "LSI oscillator characteristics") scales it. */
    iwdg_config = (struct stm32_iwdg_config){d->iwdg_base, 3u, 399u};

    err = stm32_systick_time_init(&board_time, core_hz);
    if (err == HAL_OK) {
        err = stm32_gpio_configure(&board_gpio);
    }
    if (err == HAL_OK) {
        err = stm32_i2c_init(&board_i2c, &i2c_config);
    }
    if (err == HAL_OK) {
        stm32_reg_modify(d->dbg_freeze_reg, 0u, d->dbg_freeze_bit); /* a halt must not reset */
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

struct hal_records board_hal_records(void) {
    return stm32_board_records(board_time_handle);
}

struct hal_temp board_hal_temp(void) {
    return stm32_board_temp(board_time_handle);
}

const struct stm32_i2c_stats *board_hal_i2c_stats(void) {
    return &board_i2c.stats;
}

void board_hal_fault_write(const char *text, size_t len) {
    if (log_usart.base == 0u) {
        /* A fault before the UART was up (a failed clock switch): bring it up at whatever
         * clock the core runs at now, so the fault is printed, not lost. */
        stm32_board_peripheral_clocks_init();
        log_uart_init(stm32_board_sysclk_hz());
    }
    stm32_usart_fault_write(&log_usart, text, len); /* direct: no function pointer */
}

struct hal_serial board_hal_serial(void) {
    struct hal_serial serial = {&stm32_usart_serial_ops, &log_usart};
    return serial;
}

void board_hal_fault_flush(void) {
    if (log_usart.base != 0u) {
        stm32_usart_flush(&log_usart);
    }
}

uint32_t board_hal_log_dropped(void) {
    return log_usart.dropped;
}
