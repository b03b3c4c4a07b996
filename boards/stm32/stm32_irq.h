/*
 * Interrupts masked around a short critical section on the Cortex-M the STM32 drivers run
 * on (PRIMASK: "mrs/cpsid i" to save and mask, "msr" to restore, Armv7-M ARM B5.2), so a
 * section nested in a caller's own stays masked. On the host (the drivers' register-fake
 * tests) there are no interrupts: both are no-ops.
 */
#ifndef STM32_IRQ_H
#define STM32_IRQ_H

#include <stdint.h>

static inline uint32_t irq_save(void) {
#if defined(__arm__)
    uint32_t primask;
    __asm__ volatile("mrs %0, primask\n cpsid i" : "=r"(primask)::"memory");
    return primask;
#else
    return 0u;
#endif
}

static inline void irq_restore(uint32_t primask) {
#if defined(__arm__)
    __asm__ volatile("msr primask, %0" ::"r"(primask) : "memory");
#else
    (void)primask;
#endif
}

#endif /* STM32_IRQ_H */
