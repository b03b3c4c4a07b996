/*
 * The flight image's digital twin: one emulated STM32L476RG (Unicorn's Cortex-M4 core with
 * the exception model, memory map and peripheral models of this folder) whose I2C1 bus and
 * sensor GPIOs are wired to the simulated world of sim/ (sim_rig). Everything a model needs
 * is in struct twin; each peripheral's registers live in its own struct (twin_periph.h).
 *
 * Time: the core retires one instruction per SYSCLK cycle (a documented approximation: no
 * pipeline, wait-state or bus timing), so simulated time follows the firmware's own clock
 * set-up (MSI 4 MHz from reset, HSI16 after the switch).
 */
#ifndef TWIN_TWIN_H
#define TWIN_TWIN_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include <unicorn/unicorn.h>

#include "twin_periph.h"
#include "twin_services.h"

/* Memory map: RM0351 §2.2.2 Table 1 and "Embedded SRAM" (SRAM2 is also seen at
 * 0x20018000, right after SRAM1, on the STM32L476); boot from main flash aliases it at 0
 * (RM0351 §2.6 "Boot configuration", BOOT0 = 0). */
#define TWIN_FLASH_BASE 0x08000000u
#define TWIN_FLASH_SIZE 0x100000u /* 1 MiB */
#define TWIN_SRAM1_BASE 0x20000000u
#define TWIN_SRAM1_SIZE 0x18000u /* 96 KiB */
#define TWIN_SRAM2_BASE 0x10000000u
#define TWIN_SRAM2_SIZE 0x8000u /* 32 KiB */
#define TWIN_SRAM_SIZE  (TWIN_SRAM1_SIZE + TWIN_SRAM2_SIZE)
#define TWIN_MSI_HZ     4000000u  /* MSI range 6 after reset (RM0351 §6.2.3) */
#define TWIN_HSI16_HZ   16000000u /* HSI16 (RM0351 §6.2.2) */
#define TWIN_MAX_ERRLEN 512u

struct twin_world; /* twin_world.h */

/* Why a run stopped. */
enum twin_stop {
    TWIN_RUNNING = 0,
    TWIN_STOP_DONE,      /* the world said the run is over */
    TWIN_STOP_VIOLATION, /* strict mode: an access the manual forbids */
    TWIN_STOP_LOCKUP,    /* a fault the core cannot take (ARMv7-M B1.5.15) */
    TWIN_STOP_EMULATOR,  /* Unicorn failed in a way the twin does not model */
    TWIN_STOP_LIMIT,     /* simulated-time limit reached */
};

struct twin_stats {
    uint64_t instructions;
    uint64_t blocks;
    uint64_t mmio_reads, mmio_writes;
    uint64_t warps, warped_cycles; /* poll loops skipped (twin_warp_to) */
    uint32_t resets, watchdog_resets, software_resets;
    uint32_t exceptions[16]; /* entries per system exception number */
    uint64_t irqs;           /* entries of external interrupts (USART2) */
    uint32_t hardfaults;
    uint32_t emu_restarts;
};

struct twin {
    uc_engine *uc;
    uint8_t *flash;        /* TWIN_FLASH_SIZE, erased 0xFF where the image has nothing */
    uint8_t *sram;         /* SRAM1 then SRAM2 */
    uint32_t *block_cache; /* per flash halfword: (size << 16) | instructions, 0 unknown */
    uint8_t *covered;      /* per flash halfword: 1 if executed (coverage) */
    bool strict;
    bool trace_blocks; /* TOF_TWIN_TRACE_BLOCKS set: print every translated block run */
    bool trace_mmio;   /* TOF_TWIN_TRACE_MMIO set: print every peripheral access */
    FILE *log;         /* twin diagnostics (stderr) */

    /* Time. */
    uint64_t cycles;      /* core clock cycles since power-on (= instructions, plus warps) */
    uint64_t base_cycles; /* cycles at the last SYSCLK change ... */
    uint64_t base_ps;     /* ... and the time then, picoseconds */
    uint32_t sysclk_hz;
    uint64_t next_event; /* cycles at which the block hook stops the core */
    uint64_t limit_ps;   /* run limit (0: none) */

    /* Exceptions (the twin's model: Unicorn has no NVIC). */
    uint8_t active[8]; /* exception numbers being handled, innermost last */
    unsigned nactive;
    bool scs_only_since_cvr; /* idle detection: no non-SCS access since the last CVR read */
    uint64_t last_cvr_cycles;
    uint32_t scs_prev[2]; /* the last two SCS registers read, newest first */
    bool irq_wait;        /* an exception waits for PRIMASK = 0 or the handler's return */
    bool reset_pending;   /* SYSRESETREQ or a watchdog reset */
    bool watchdog_reset;
    uint32_t fault_pc; /* last HardFault: where, and why */
    uint32_t fault_addr;
    const char *fault_what;
    int intr_no; /* Unicorn interrupt number seen by the hook (-1 none) */

    enum twin_stop stop;
    char stop_msg[TWIN_MAX_ERRLEN];

    struct twin_rcc rcc;
    struct twin_flash_if flash_if;
    struct twin_flash flash_pe; /* program/erase of the record pages (twin_flash.c) */
    struct twin_gpio gpio[TWIN_GPIO_PORTS];
    struct twin_i2c i2c;
    struct twin_usart usart;
    struct twin_iwdg iwdg;
    struct twin_scs scs;
    struct twin_adc adc;
    uint32_t dbgmcu_apb1fzr1;

    /* Time, warps, pending exceptions and violations for the peripheral models: the core's
     * (twin_core_services), set by twin_init. Models use only this, never the functions below. */
    struct twin_services svc;

    struct twin_world *world;
    /* Called between emulation slices (at least every SysTick period): the host side's
     * own timers (command retries). May be NULL. */
    void (*host_poll)(void *ctx);
    void *host_ctx;
    struct twin_stats stats;
};

/* Create the core, map memory and peripherals, load nothing yet. 0 or -1 (message on log). */
int twin_init(struct twin *t, bool strict, FILE *log);
void twin_free(struct twin *t);

/* Program `flash` (TWIN_FLASH_SIZE bytes as `flash` programs it) into the twin. */
void twin_load_flash(struct twin *t, const uint8_t *image);

/* Power-on (or system) reset: peripherals to their reset values, SP and PC from the vector
 * table at 0 (the flash alias). `power_on` also clears the reset flags. */
void twin_reset(struct twin *t, bool power_on);

/* Run until something stops it (t->stop set) or until `limit_ps` of simulated time. */
void twin_run(struct twin *t);

/* ---- twin_core_services.c: time, warps, stops; the models reach them through t->svc ---- */

/* The services of core `t` as the models see them (twin_services.h). */
struct twin_services twin_core_services(struct twin *t);

/* Current simulated time. */
uint64_t twin_now_ps(const struct twin *t);
static inline uint64_t twin_now_us(const struct twin *t) {
    return twin_now_ps(t) / 1000000u;
}

/* Cycles of the core clock in `ps` picoseconds (rounded up). */
uint64_t twin_ps_to_cycles(const struct twin *t, uint64_t ps);

/* The core cycle count of the next event the core must stop at: SysTick's next wrap, the
 * watchdog's expiry, a USART byte that raises its interrupt or the run limit, whichever comes
 * first. */
uint64_t twin_earliest_event(struct twin *t);

/* A poll of a register whose next change is at `ps`: move time there at once (as if the
 * poll loop had run that long), but never across a SysTick wrap or the watchdog's expiry,
 * so no exception is late by more than one block. */
void twin_warp_to(struct twin *t, uint64_t ps);

/* SYSCLK changed (the RCC model's clock switch). */
void twin_set_sysclk(struct twin *t, uint32_t hz);

/* Ask the core to stop at the next block (an event is due now). */
void twin_kick(struct twin *t);

/* Strict mode: stop the run naming the register, the value and the rule. Outside strict
 * mode the same text is printed once per rule as a warning and the run goes on. */
void twin_violation(struct twin *t, const char *reg, uint32_t value, const char *rule);

/* Stop the run for a reason other than a violation. */
void twin_stop(struct twin *t, enum twin_stop why, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Raise a system exception as pending (SysTick, PendSV) or take a fault now. */
void twin_set_pending(struct twin *t, unsigned exc, bool pending);

/* The peripheral dispatch (twin_bus.c): one 32-bit access, called by the MMIO callbacks. */
uint32_t twin_bus_read(struct twin *t, uint32_t addr, unsigned size);
void twin_bus_write(struct twin *t, uint32_t addr, unsigned size, uint32_t value);

#endif /* TWIN_TWIN_H */
