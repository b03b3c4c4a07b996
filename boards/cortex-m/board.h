/*
 * What each board provides to the shared startup code and to its main().
 * BOARD_IRQ_COUNT comes from the board's CMake definition.
 */
#ifndef BOARDS_CORTEX_M_BOARD_H
#define BOARDS_CORTEX_M_BOARD_H

#include <stdint.h>

#ifndef BOARD_IRQ_COUNT
#error "BOARD_IRQ_COUNT must be defined by the board's build"
#endif

/* Called with main()'s return value: exit (QEMU) or reset (MCU). Never returns. */
__attribute__((noreturn)) void board_exit(int status);

/* Exception number of the HardFault or unexpected exception/IRQ being reported (0: the
 * fault is not an exception), and the last one, kept in .noinit across the reset. */
extern volatile uint32_t cortex_m_fault_vector;
extern volatile uint32_t cortex_m_last_fault_vector;

/* Called on a fault or unexpected exception: report `what` if possible, then stop. */
__attribute__((noreturn)) void board_fault(const char *what);

#endif /* BOARDS_CORTEX_M_BOARD_H */
