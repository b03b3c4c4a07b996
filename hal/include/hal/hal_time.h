/*
 * Monotonic time and delays. Microsecond counter wraps after ~71 minutes;
 * compare with unsigned subtraction (hal_time_elapsed_us) so wraps are harmless.
 */
#ifndef HAL_TIME_H
#define HAL_TIME_H

#include <stdint.h>

struct hal_time_ops {
    /* Monotonic microseconds since an arbitrary origin (wrapping uint32). */
    uint32_t (*now_us)(void *ctx);
    /* Busy-wait or sleep at least `us` microseconds (a simulated clock just advances). */
    void (*delay_us)(void *ctx, uint32_t us);
};

struct hal_time {
    const struct hal_time_ops *ops;
    void *ctx;
};

/* Microseconds from `since` to `now`, correct across one wrap of the counter. */
static inline uint32_t hal_time_elapsed_us(uint32_t now, uint32_t since) {
    return now - since;
}

#endif /* HAL_TIME_H */
