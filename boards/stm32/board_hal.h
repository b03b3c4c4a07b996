/*
 * What an STM32 NUCLEO board (nucleo-l476rg, nucleo-g071rb) hands its main():
 * one init call, then the HAL implementations for struct tof_platform. Each
 * board folder describes itself in board_desc.c; boards/stm32/stm32_board.c implements this
 * header once for all of them.
 *
 * Numbered GPIO pins (both boards, Arduino connector, docs/explanation/boards.md):
 *   0..3  XSHUT of sensors A..D  (D2..D5, open-drain outputs, start low)
 *   4..7  GPIO1 of sensors A..D  (D6..D9, inputs with pull-up)
 */
#ifndef BOARDS_STM32_BOARD_HAL_H
#define BOARDS_STM32_BOARD_HAL_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_gpio.h"
#include "hal/hal_i2c.h"
#include "hal/hal_log.h"
#include "hal/hal_records.h"
#include "hal/hal_serial.h"
#include "hal/hal_temp.h"
#include "hal/hal_time.h"
#include "hal/hal_watchdog.h"
#include "stm32_i2c.h"

#define BOARD_HAL_SENSOR_COUNT 4u
/* Numbered pin of sensor `s` (0 = A .. 3 = D). */
#define BOARD_HAL_XSHUT_PIN(s) ((uint16_t)(s))
#define BOARD_HAL_GPIO1_PIN(s) ((uint16_t)(4u + (s)))

/*
 * Bring the board up: system clock 16 MHz from HSI16, SysTick 1 ms, USART2
 * log at 115200 Bd (ST-LINK virtual COM port), the eight sensor pins, I2C1 at
 * 400 kHz on D15/D14, and the independent watchdog started (~400 ms: kick it
 * from then on, bring-up included). Call once, first thing in main().
 * HAL_OK, or the first error (HAL_ERR_TIMEOUT: a clock or watchdog update did
 * not complete); on a clock error nothing else is set up.
 */
int board_hal_init(void);

/* The HAL implementations (valid after board_hal_init). */
struct hal_i2c board_hal_i2c(void);
struct hal_gpio board_hal_gpio(void);
struct hal_time board_hal_time(void);
struct hal_watchdog board_hal_watchdog(void);
struct hal_log board_hal_log(void);

/* Record storage: the pages the board's linker script reserves for records (ops NULL on a
 * board without; docs/explanation/boards.md "Records"). */
struct hal_records board_hal_records(void);

/* The temperature sensor the board reads with every sample (ops NULL on a board without;
 * docs/explanation/boards.md "Temperature"). */
struct hal_temp board_hal_temp(void);

/* Error counters of the I2C bus, for status telemetry. */
const struct stm32_i2c_stats *board_hal_i2c_stats(void);

/* Write text to the log UART from a fault handler: a direct call, so the fault path's
 * stack depth is known exactly (no function pointer). */
void board_hal_fault_write(const char *text, size_t len);

/* Wait until what board_hal_fault_write() wrote has left the UART (bounded), so a reset
 * that follows does not cut the fault message off. */
void board_hal_fault_flush(void);

/* The telemetry byte stream: USART2 (ST-LINK virtual COM port), shared with the log. */
struct hal_serial board_hal_serial(void);

/* Log bytes dropped because the USART transmitter never became ready. */
uint32_t board_hal_log_dropped(void);

#endif /* BOARDS_STM32_BOARD_HAL_H */
