/*
 * Private to the VL53L1X device model: the big-endian register helpers both of its files
 * use, and the ranging engine's entry points (sim_vl53_ranging.c) that the register and
 * bus side (sim_vl53.c) calls. Nothing outside sim/src includes this header.
 */
#ifndef SIM_VL53_MODEL_H
#define SIM_VL53_MODEL_H

#include <stdbool.h>
#include <stdint.h>

#include "sim/sim_clock.h"
#include "sim/sim_vl53.h"

/* The 16-bit register at reg and reg + 1, most significant byte first ([DS]). */
static inline uint16_t be16_at(const uint8_t *regs, uint16_t reg) {
    return (uint16_t)(((uint16_t)regs[reg] << 8) | regs[reg + 1u]);
}

static inline void put_be16_at(uint8_t *regs, uint16_t reg, uint16_t value) {
    regs[reg] = (uint8_t)(value >> 8);
    regs[reg + 1u] = (uint8_t)(value & 0xFFu);
}

static inline uint64_t now(const struct sim_vl53 *dev) {
    return sim_clock_now(dev->clock);
}

/* A write of "start timed ranging": checks ST's block and decodes the timing; ranges from
 * now on, or records why the part would not (dev->refusal). */
void sim_vl53_start_ranging(struct sim_vl53 *dev);

/* When the model next changes state by itself (boot completes, a measurement is due);
 * SIM_CLOCK_NEVER while neither is pending. */
uint64_t sim_vl53_next_event_us(const struct sim_vl53 *dev);

/* After a change from outside (a register write, XSHUT, an injected fault): recompute the
 * next event and wake the clock for it. */
void sim_vl53_reschedule(struct sim_vl53 *dev);

/* The NVM-read registers (sim_vl53_nvm.c): whether `reg` is one (0x0683, 0x0780..0x0795); a
 * write or read of one, HAL_OK or HAL_ERR_DATA_NACK out of ST's sequence; power-up state. */
bool sim_vl53_nvm_reg(uint16_t reg);
int sim_vl53_nvm_write(struct sim_vl53 *dev, uint16_t reg, uint8_t value);
int sim_vl53_nvm_read(struct sim_vl53 *dev, uint16_t reg, uint8_t *value);
void sim_vl53_nvm_reset(struct sim_vl53 *dev);
/* Before a write of 0x0083 / 0x0085 in the register file: notes when power force went on;
 * HAL_ERR_DATA_NACK (not written) for firmware on or power force off under a powered NVM. */
int sim_vl53_nvm_guard(struct sim_vl53 *dev, uint16_t reg, uint8_t value);

#endif /* SIM_VL53_MODEL_H */
