/* hal_watchdog on the STM32 independent watchdog (stm32_iwdg.h). */
#include "stm32_iwdg.h"

#include <stddef.h>

#include "hal/hal_err.h"
#include "stm32_iwdg_regs.h"
#include "stm32_reg.h"

int stm32_iwdg_start(struct stm32_iwdg *wdg, const struct stm32_iwdg_config *cfg,
                     const struct hal_time *time, uint32_t budget_us) {
    if (wdg == NULL || cfg == NULL || time == NULL || time->ops == NULL ||
        time->ops->now_us == NULL || cfg->prescaler_code > STM32_IWDG_PR_MAX ||
        cfg->reload > STM32_IWDG_RLR_MAX) {
        return HAL_ERR_INVALID;
    }
    wdg->cfg = cfg;
    stm32_reg_write(cfg->base + STM32_IWDG_KR, STM32_IWDG_KEY_START);
    stm32_reg_write(cfg->base + STM32_IWDG_KR, STM32_IWDG_KEY_UNLOCK);
    stm32_reg_write(cfg->base + STM32_IWDG_PR, cfg->prescaler_code);
    stm32_reg_write(cfg->base + STM32_IWDG_RLR, cfg->reload);
    /* PVU/RVU stay set for a few LSI periods while the values cross into the
     * LSI domain; the refresh below must use the new reload value. */
    const uint32_t start = time->ops->now_us(time->ctx);
    /* Backstop on reads in case the time source is stopped: one read per
     * microsecond of budget at least, plus one. */
    uint32_t reads_left = budget_us == UINT32_MAX ? UINT32_MAX : budget_us + 1u;
    int err = HAL_ERR_TIMEOUT;
    while (reads_left > 0u) {
        --reads_left;
        if ((stm32_reg_read(cfg->base + STM32_IWDG_SR) & STM32_IWDG_SR_UPDATES) == 0u) {
            err = HAL_OK;
            break;
        }
        if (hal_time_elapsed_us(time->ops->now_us(time->ctx), start) > budget_us) {
            break;
        }
    }
    stm32_reg_write(cfg->base + STM32_IWDG_KR, STM32_IWDG_KEY_RELOAD);
    return err;
}

void stm32_iwdg_kick(void *ctx) {
    const struct stm32_iwdg *wdg = ctx;
    if (wdg != NULL && wdg->cfg != NULL) {
        stm32_reg_write(wdg->cfg->base + STM32_IWDG_KR, STM32_IWDG_KEY_RELOAD);
    }
}

const struct hal_watchdog_ops stm32_iwdg_ops = {
    .kick = stm32_iwdg_kick,
};
