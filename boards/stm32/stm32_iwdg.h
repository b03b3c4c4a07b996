/*
 * hal_watchdog on the STM32 independent watchdog (IWDG), clocked by the LSI
 * RC (32 kHz nominal). Timeout = 4 x 2^PR x (RLR + 1) / f_LSI: with PR = 3
 * (divide by 32) one count is 1 ms at 32 kHz and the timeout is RLR + 1 ms.
 * Once started it cannot be stopped until reset.
 */
#ifndef BOARDS_STM32_IWDG_H
#define BOARDS_STM32_IWDG_H

#include <stdint.h>

#include "hal/hal_time.h"
#include "hal/hal_watchdog.h"

struct stm32_iwdg_config {
    uintptr_t base;          /* IWDG base address */
    uint32_t prescaler_code; /* PR value 0..6: LSI divided by 4 << code */
    uint32_t reload;         /* RLR value 0..0xFFF */
};

struct stm32_iwdg {
    const struct stm32_iwdg_config *cfg;
};

/*
 * Start the watchdog with `cfg` (key sequence of the reference manuals'
 * "Configuring the IWDG when the window option is disabled"), wait for the
 * prescaler/reload update to land (bounded by `budget_us` on `time`), then
 * reload. HAL_OK, HAL_ERR_INVALID (bad config), or HAL_ERR_TIMEOUT if the
 * update never completed (the watchdog then runs with its previous timeout).
 */
int stm32_iwdg_start(struct stm32_iwdg *wdg, const struct stm32_iwdg_config *cfg,
                     const struct hal_time *time, uint32_t budget_us);

/* hal_watchdog kick: reload the counter. */
void stm32_iwdg_kick(void *ctx);

extern const struct hal_watchdog_ops stm32_iwdg_ops;

#endif /* BOARDS_STM32_IWDG_H */
