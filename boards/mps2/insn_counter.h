/*
 * Exact instruction counts under QEMU: run with `-icount shift=7`, so every
 * instruction advances virtual time by 2^7 = 128 ns, and read CMSDK APB timer 0,
 * which QEMU clocks at 25 MHz (40 ns per tick): 128/40 = 3.2 ticks per
 * instruction, i.e. instructions = ticks * 5 / 16. QEMU does not emulate the
 * DWT cycle counter. Timer registers: Arm CMSDK TRM (DDI 0479), "APB timer".
 */
#ifndef BOARDS_MPS2_INSN_COUNTER_H
#define BOARDS_MPS2_INSN_COUNTER_H

#include <stdint.h>

/* Start timer 0 free-running from 0xFFFFFFFF (it counts down). */
void insn_counter_start(void);

/* Current raw tick value (decreasing). */
uint32_t insn_counter_ticks(void);

/* Instructions executed between two tick readings `before` and `after` (ticks * 5 / 16). */
uint64_t insn_counter_between(uint32_t before, uint32_t after);

#endif /* BOARDS_MPS2_INSN_COUNTER_H */
