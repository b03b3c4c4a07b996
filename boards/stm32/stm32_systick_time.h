/*
 * hal_time on the Cortex-M SysTick: a 1 ms tick interrupt advances a
 * microsecond base, and reading the counter gives the microseconds within the
 * current millisecond. The result wraps as a uint32 after ~71.6 minutes, like
 * every hal_time; compare with hal_time_elapsed_us().
 */
#ifndef BOARDS_STM32_SYSTICK_TIME_H
#define BOARDS_STM32_SYSTICK_TIME_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_time.h"

struct stm32_systick_time {
    uint32_t reload;                /* SysTick reload value: core cycles per ms - 1 */
    uint32_t cycles_per_us;         /* core clock in MHz */
    volatile uint32_t tick_base_us; /* microseconds at the latest counted tick (ISR-owned) */
};

/*
 * Start SysTick from the processor clock `core_hz` with a 1 ms tick and the
 * interrupt enabled; the time base starts at 0. HAL_OK, or HAL_ERR_INVALID for
 * a clock that is not a whole number of MHz or needs more than 24 reload bits.
 */
int stm32_systick_time_init(struct stm32_systick_time *time, uint32_t core_hz);

/* Call from SysTick_Handler: one millisecond has passed. */
void stm32_systick_time_tick(struct stm32_systick_time *time);

/* hal_time now_us: monotonic microseconds (wrapping), safe with interrupts on or off. */
uint32_t stm32_systick_time_now_us(void *ctx);

/* hal_time delay_us: busy-wait at least `us` microseconds; bounded even if SysTick stops. */
void stm32_systick_time_delay_us(void *ctx, uint32_t us);

extern const struct hal_time_ops stm32_systick_time_ops;

/*
 * The microsecond time from one consistent snapshot taken with interrupts
 * masked: the counted base, the counter value read before the pending flag,
 * the SysTick pending flag, and the counter value read after it. The counter
 * counts reload..0; it reaches 0 at each tick (the event counted by the ISR)
 * and reloads one cycle later. If a tick is pending it has not been counted
 * yet and `val_after` is certainly past it; otherwise `val_before` is
 * certainly before the next one. Cycles since the tick: 0 at VAL = 0,
 * reload + 1 - VAL otherwise (at most reload, so under 1000 us).
 */
static inline uint32_t stm32_systick_compose_us(uint32_t base_us, uint32_t val_before, bool pending,
                                                uint32_t val_after, uint32_t reload,
                                                uint32_t cycles_per_us) {
    if (pending) {
        const uint32_t since = val_after == 0u ? 0u : reload + 1u - val_after;
        return base_us + 1000u + since / cycles_per_us;
    }
    const uint32_t since = val_before == 0u ? 0u : reload + 1u - val_before;
    return base_us + since / cycles_per_us;
}

#endif /* BOARDS_STM32_SYSTICK_TIME_H */
