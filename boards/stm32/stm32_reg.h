/*
 * 32-bit memory-mapped register access for the STM32 board code. Every
 * peripheral driver in boards/stm32/ goes through these two functions, with
 * the peripheral base address taken from its per-instance config, so the host
 * tests (tests/boards/) can compile the same driver source with
 * STM32_REG_HOOKS defined and route each access to a register-level fake of
 * the peripheral (flag sequences, write-1-to-clear, read side effects).
 * On the target the functions are plain volatile loads and stores.
 */
#ifndef BOARDS_STM32_REG_H
#define BOARDS_STM32_REG_H

#include <stdint.h>

#if defined(STM32_REG_HOOKS)
/* Host tests only: the fake peripheral model behind every access. */
uint32_t stm32_reg_hook_read(uintptr_t addr);
void stm32_reg_hook_write(uintptr_t addr, uint32_t value);

/* Write a 32-bit peripheral register (host test: the fake sees the write). */
static inline void stm32_reg_write(uintptr_t addr, uint32_t value) {
    stm32_reg_hook_write(addr, value);
}

/* Read a 32-bit peripheral register (host test: the fake supplies the value). */
static inline uint32_t stm32_reg_read(uintptr_t addr) {
    return stm32_reg_hook_read(addr);
}
#else
/* Write a 32-bit peripheral register. */
static inline void stm32_reg_write(uintptr_t addr, uint32_t value) {
    *(volatile uint32_t *)addr = value;
}

/* Read a 32-bit peripheral register. */
static inline uint32_t stm32_reg_read(uintptr_t addr) {
    return *(volatile uint32_t *)addr;
}
#endif

/* Read-modify-write: clear the bits in `clear`, then set the bits in `set`. */
static inline void stm32_reg_modify(uintptr_t addr, uint32_t clear, uint32_t set) {
    stm32_reg_write(addr, (stm32_reg_read(addr) & ~clear) | set);
}

#endif /* BOARDS_STM32_REG_H */
