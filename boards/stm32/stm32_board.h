/*
 * What distinguishes one STM32 NUCLEO board from another for the shared board
 * HAL (stm32_board.c implements board_hal.h once for all of them): addresses,
 * pins and alternate functions in a const descriptor, and the two steps that
 * differ in kind (system clock switch, peripheral clock enables) as functions.
 * Each board folder provides `stm32_board_desc` and the two functions.
 */
#ifndef BOARDS_STM32_BOARD_H
#define BOARDS_STM32_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "stm32_gpio.h"
#include "hal/hal_records.h"
#include "hal/hal_temp.h"
#include "hal/hal_time.h"
#include "stm32_i2c.h"

/* The boards' I2C kernel clock is HSI16 (one TIMINGR for all); the core clock is each
 * board's (stm32_board_sysclk_hz; docs/explanation/boards.md "Clock"). */
#define STM32_BOARD_LOG_BAUD 115200u

struct stm32_board_desc {
    const struct stm32_pin *sensor_pins; /* numbered pins 0..7: XSHUT A..D, GPIO1 A..D */
    uintptr_t i2c_base;
    struct stm32_i2c_pin i2c_scl, i2c_sda;
    uintptr_t usart_base;
    uintptr_t usart_port; /* GPIO port of the USART pins */
    uint8_t usart_tx_pin, usart_rx_pin, usart_af;
    uintptr_t iwdg_base;
    uintptr_t dbg_freeze_reg; /* register whose bit stops the IWDG while the core is halted */
    uint32_t dbg_freeze_bit;
};

extern const struct stm32_board_desc stm32_board_desc;

/* Switch SYSCLK to the board's core clock (docs/explanation/boards.md "Clock"). HAL_OK or
 * HAL_ERR_TIMEOUT (bounded polls). */
int stm32_board_clock_init(void);

/* The core clock now (reset clock before a successful stm32_board_clock_init), from the
 * RCC's switch status: what a fault report sets the UART divisor from. */
uint32_t stm32_board_sysclk_hz(void);

/* Clock the GPIO ports, I2C1 (kernel clock HSI16), USART2 and the debug unit. */
void stm32_board_peripheral_clocks_init(void);

/* The board's record storage (its linker script reserves the pages), with `time` for the
 * flash's bounded waits; ops NULL on a board that has none. Each board_desc.c defines it. */
struct hal_records stm32_board_records(struct hal_time time);

/* The board's temperature sensor (docs/explanation/boards.md "Temperature"), with `time` for
 * its bounded waits; ops NULL on a board that has none. Each board_desc.c defines it. */
struct hal_temp stm32_board_temp(struct hal_time time);

/* Poll `addr` until (value & mask) == want, at most `polls` reads; true if it did. */
bool stm32_board_poll_bits(uintptr_t addr, uint32_t mask, uint32_t want, uint32_t polls);

/* Upper bound on the polls of a clock switch: > 2 ms even at the 4 MHz reset clock. */
#define STM32_BOARD_CLOCK_READY_POLLS 10000u

#endif /* BOARDS_STM32_BOARD_H */
