/* hal_time on the Cortex-M SysTick (stm32_systick_time.h). */
#include "stm32_systick_time.h"

#include <stddef.h>

#include "cortex_m_regs.h"
#include "hal/hal_err.h"
#include "stm32_irq.h"
#include "stm32_reg.h"

int stm32_systick_time_init(struct stm32_systick_time *time, uint32_t core_hz) {
    if (time == NULL || core_hz == 0u || core_hz % 1000000u != 0u ||
        core_hz / 1000u - 1u > CORTEX_M_SYST_RELOAD_MAX) {
        return HAL_ERR_INVALID;
    }
    time->cycles_per_us = core_hz / 1000000u;
    time->reload = core_hz / 1000u - 1u; /* period reload + 1 cycles = 1 ms (B3.3.4) */
    time->tick_base_us = 0u;
    stm32_reg_write(CORTEX_M_SYST_CSR, 0u);
    stm32_reg_write(CORTEX_M_SYST_RVR, time->reload);
    stm32_reg_write(CORTEX_M_SYST_CVR, 0u);
    stm32_reg_write(CORTEX_M_SYST_CSR, CORTEX_M_SYST_CSR_CLKSOURCE | CORTEX_M_SYST_CSR_TICKINT |
                                           CORTEX_M_SYST_CSR_ENABLE);
    return HAL_OK;
}

void stm32_systick_time_tick(struct stm32_systick_time *time) {
    time->tick_base_us += 1000u; /* wraps with the uint32 microsecond counter */
}

uint32_t stm32_systick_time_now_us(void *ctx) {
    struct stm32_systick_time *time = ctx;
    /* masked: the tick ISR must not move the base between the reads (stm32_irq.h) */
    const uint32_t primask = irq_save();
    const uint32_t base = time->tick_base_us;
    const uint32_t before = stm32_reg_read(CORTEX_M_SYST_CVR) & CORTEX_M_SYST_CVR_MASK;
    const bool pending = (stm32_reg_read(CORTEX_M_ICSR) & CORTEX_M_ICSR_PENDSTSET) != 0u;
    const uint32_t after = stm32_reg_read(CORTEX_M_SYST_CVR) & CORTEX_M_SYST_CVR_MASK;
    irq_restore(primask);
    return stm32_systick_compose_us(base, before, pending, after, time->reload,
                                    time->cycles_per_us);
}

void stm32_systick_time_delay_us(void *ctx, uint32_t us) {
    struct stm32_systick_time *time = ctx;
    const uint32_t start = stm32_systick_time_now_us(time);
    /* Backstop if SysTick were stopped: one iteration takes far more than one
     * core cycle, so us x cycles-per-us iterations outlast `us` microseconds. */
    uint32_t polls = UINT32_MAX;
    if (time->cycles_per_us != 0u && us <= UINT32_MAX / time->cycles_per_us) {
        polls = us * time->cycles_per_us;
    }
    /* `<= us`: the start reading is floored to whole microseconds. */
    while (us != 0u && polls > 0u &&
           hal_time_elapsed_us(stm32_systick_time_now_us(time), start) <= us) {
        --polls;
    }
}

const struct hal_time_ops stm32_systick_time_ops = {
    .now_us = stm32_systick_time_now_us,
    .delay_us = stm32_systick_time_delay_us,
};
