/* Exact instruction counts under QEMU -icount from CMSDK timer 0 (insn_counter.h). */
#include "insn_counter.h"

#define TIMER0_BASE   0x40000000u /* AN385/AN386 memory map: CMSDK timer 0 */
#define TIMER_CTRL    (TIMER0_BASE + 0x00u)
#define TIMER_VALUE   (TIMER0_BASE + 0x04u)
#define TIMER_RELOAD  (TIMER0_BASE + 0x08u)
#define TIMER_CTRL_EN 1u

static void reg_write(uint32_t addr, uint32_t value) {
    *(volatile uint32_t *)addr = value;
}

uint32_t insn_counter_ticks(void) {
    return *(volatile const uint32_t *)TIMER_VALUE;
}

void insn_counter_start(void) {
    reg_write(TIMER_CTRL, 0u);
    reg_write(TIMER_RELOAD, 0xFFFFFFFFu);
    reg_write(TIMER_VALUE, 0xFFFFFFFFu);
    reg_write(TIMER_CTRL, TIMER_CTRL_EN);
}

uint64_t insn_counter_between(uint32_t before, uint32_t after) {
    const uint64_t ticks = (uint64_t)(uint32_t)(before - after); /* down-counter, wrap-safe */
    return (ticks * 5u + 8u) / 16u;
}
