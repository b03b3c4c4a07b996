/* The twin's core: Unicorn's Cortex-M4 with the memory map, time from retired instructions,
 * and the M-profile exception model (entry, return, faults, reset) Unicorn does not have. */
#include <stdlib.h>
#include <string.h>

#include "twin.h"

/* EXC_RETURN values are 0xFFFFFFE0..0xFFFFFFFF (ARMv7-M ARM B1.5.8); a branch there in
 * thread mode (as Unicorn sees the core) fetches from unmapped memory, which the twin
 * takes as the exception return. */
#define EXC_RETURN_MIN     0xFFFFFFE0u
#define EXC_RETURN_THREAD  0xFFFFFFF9u /* return to thread mode, main stack, basic frame */
#define EXC_RETURN_HANDLER 0xFFFFFFF1u
#define EXC_HARDFAULT      3u
#define EXC_SYSTICK        15u
#define XPSR_ALIGN         (1u << 9) /* stacked xPSR bit 9: the frame was realigned (B1.5.7) */
#define XPSR_T             (1u << 24)
#define XPSR_IT_MASK       0x0600FC00u /* EPSR.ICI/IT: bits 26:25 and 15:10 (B1.4.2) */

/* ---- memory-mapped I/O: every access goes to twin_bus ---- */

struct region {
    struct twin *t;
    uint32_t base;
};
static struct region regions[6]; /* the mmio regions of twin_init */

static uint64_t region_read(uc_engine *uc, uint64_t offset, unsigned size, void *user) {
    struct region *r = user;
    r->t->stats.mmio_reads++;
    const uint32_t v = twin_bus_read(r->t, r->base + (uint32_t)offset, size);
    if (r->t->trace_mmio) {
        uint32_t pc = 0;
        uc_reg_read(uc, UC_ARM_REG_PC, &pc);
        fprintf(r->t->log, "mmio R 0x%08x -> 0x%08x (%u) pc 0x%08x cyc %llu\n",
                r->base + (uint32_t)offset, v, size, pc, (unsigned long long)r->t->cycles);
    }
    return v;
}

static void region_write(uc_engine *uc, uint64_t offset, unsigned size, uint64_t value,
                         void *user) {
    struct region *r = user;
    r->t->stats.mmio_writes++;
    if (r->t->trace_mmio) {
        uint32_t pc = 0;
        uc_reg_read(uc, UC_ARM_REG_PC, &pc);
        fprintf(r->t->log, "mmio W 0x%08x = 0x%08x (%u) pc 0x%08x cyc %llu\n",
                r->base + (uint32_t)offset, (uint32_t)value, size, pc,
                (unsigned long long)r->t->cycles);
    }
    twin_bus_write(r->t, r->base + (uint32_t)offset, size, (uint32_t)value);
}

/* ---- instruction counting (and coverage) per translated block ---- */

/* Thumb-2: a halfword whose top five bits are 0b11101, 0b11110 or 0b11111 starts a 32-bit
 * instruction (ARMv7-M ARM A5.1 "Thumb instruction set encoding"). */
static uint32_t count_insns(const struct twin *t, uint32_t addr, uint32_t size) {
    uint32_t n = 0;
    uint32_t off = addr - TWIN_FLASH_BASE;
    const uint32_t end = off + size;
    while (off < end && off + 1u < TWIN_FLASH_SIZE) {
        const uint16_t hw = (uint16_t)(t->flash[off] | (t->flash[off + 1u] << 8));
        const unsigned top = hw >> 11;
        off += (top == 0x1Du || top == 0x1Eu || top == 0x1Fu) ? 4u : 2u;
        ++n;
    }
    return n;
}

static void hook_block(uc_engine *uc, uint64_t address, uint32_t size, void *user) {
    struct twin *t = user;
    uint32_t n;
    const uint32_t a = (uint32_t)address;
    if (a >= TWIN_FLASH_BASE && a - TWIN_FLASH_BASE < TWIN_FLASH_SIZE && size < 0xFFFFu) {
        const uint32_t idx = (a - TWIN_FLASH_BASE) / 2u;
        const uint32_t c = t->block_cache[idx];
        if (c != 0u && (c >> 16) == size) {
            n = c & 0xFFFFu;
        } else {
            n = count_insns(t, a, size);
            t->block_cache[idx] = (size << 16) | n;
            memset(&t->covered[idx], 1, (size + 1u) / 2u);
        }
    } else {
        n = (size + 1u) / 2u; /* code outside flash (RAM): halfwords, a bound */
    }
    t->cycles += n;
    t->stats.instructions += n;
    if (t->trace_blocks) {
        fprintf(t->log, "block 0x%08x +%u\n", a, size);
    }
    t->stats.blocks++;
    if (t->cycles >= t->next_event || t->stop != TWIN_RUNNING) {
        uc_emu_stop(uc);
    } else if (t->irq_wait && t->nactive == 0u) {
        uint32_t primask = 1;
        uc_reg_read(uc, UC_ARM_REG_PRIMASK, &primask);
        if ((primask & 1u) == 0u) {
            uc_emu_stop(uc);
        }
    }
}

/* A data access to an address nothing is mapped at: a precise bus fault at that address
 * (the run loop takes the HardFault); BFAR keeps the address as on the M4 (B3.2.18). */
static bool hook_unmapped(uc_engine *uc, uc_mem_type type, uint64_t address, int size,
                          int64_t value, void *user) {
    (void)uc;
    (void)type;
    (void)size;
    (void)value;
    struct twin *t = user;
    t->fault_addr = (uint32_t)address;
    t->scs.bfar = (uint32_t)address;
    return false;
}

static void hook_intr(uc_engine *uc, uint32_t intno, void *user) {
    struct twin *t = user;
    t->intr_no = (int)intno;
    uc_emu_stop(uc);
}

int twin_init(struct twin *t, bool strict, FILE *log) {
    memset(t, 0, sizeof *t);
    t->svc = twin_core_services(t);
    t->strict = strict;
    t->log = log;
    t->intr_no = -1;
    t->trace_mmio = getenv("TOF_TWIN_TRACE_MMIO") != NULL;
    t->trace_blocks = getenv("TOF_TWIN_TRACE_BLOCKS") != NULL;
    t->flash = malloc(TWIN_FLASH_SIZE);
    t->sram = calloc(1, TWIN_SRAM_SIZE);
    t->block_cache = calloc(TWIN_FLASH_SIZE / 2u, sizeof *t->block_cache);
    t->covered = calloc(TWIN_FLASH_SIZE / 2u, 1);
    if (t->flash == NULL || t->sram == NULL || t->block_cache == NULL || t->covered == NULL) {
        fprintf(log, "tof_twin: out of memory\n");
        return -1;
    }
    memset(t->flash, 0xFF, TWIN_FLASH_SIZE); /* erased flash reads 0xFF */
    t->flash_pe.cut_after = TWIN_FLASH_NO_CUT;
    uc_err err = uc_open(UC_ARCH_ARM, UC_MODE_THUMB | UC_MODE_MCLASS, &t->uc);
    if (err != UC_ERR_OK) {
        fprintf(log, "tof_twin: unicorn: %s\n", uc_strerror(err));
        return -1;
    }
    uc_ctl_set_cpu_model(t->uc, UC_CPU_ARM_CORTEX_M4);
    /* Flash at its address and at 0 (boot alias), read/execute only: a write is a fault. */
    /* ... but the record pages at its end: I/O, so the flash model sees their programming. */
    err = uc_mem_map_ptr(t->uc, TWIN_FLASH_BASE, TWIN_RECORDS_BASE - TWIN_FLASH_BASE,
                         UC_PROT_READ | UC_PROT_EXEC, t->flash);
    if (err == UC_ERR_OK) {
        err = uc_mem_map_ptr(t->uc, 0x00000000u, TWIN_FLASH_SIZE, UC_PROT_READ | UC_PROT_EXEC,
                             t->flash);
    }
    if (err == UC_ERR_OK) {
        err = uc_mem_map_ptr(t->uc, TWIN_SRAM1_BASE, TWIN_SRAM_SIZE, UC_PROT_ALL, t->sram);
    }
    if (err == UC_ERR_OK) {
        err = uc_mem_map_ptr(t->uc, TWIN_SRAM2_BASE, TWIN_SRAM2_SIZE, UC_PROT_ALL,
                             t->sram + TWIN_SRAM1_SIZE);
    }
    /* Peripherals: APB1/APB2/AHB1 (0x40000000..0x4002FFFF), AHB2 GPIO (0x48000000..),
     * the private peripheral bus (0xE0000000..0xE00FFFFF). */
    /* ... and AHB2's ADC (0x50040000..0x500403FF, mapped as its 4 KiB page: Unicorn maps whole
     * pages; the rest is reserved, twin_bus.c), the system-memory page with the factory
     * calibration (0x1FFF7000..0x1FFF7FFF). */
    static const uint32_t bases[6] = {0x40000000u,       0x48000000u,   0xE0000000u,
                                      TWIN_RECORDS_BASE, TWIN_ADC_BASE, TWIN_SYSMEM_CAL_PAGE};
    static const uint32_t sizes[6] = {0x30000u,          0x2000u, 0x100000u,
                                      TWIN_RECORDS_SIZE, 0x400u,  0x1000u};
    for (unsigned i = 0; i < 6u && err == UC_ERR_OK; ++i) {
        regions[i] = (struct region){t, bases[i]};
        err = uc_mmio_map(t->uc, bases[i], sizes[i], region_read, &regions[i], region_write,
                          &regions[i]);
    }
    uc_hook h;
    if (err == UC_ERR_OK) {
        err = uc_hook_add(t->uc, &h, UC_HOOK_BLOCK, (void *)hook_block, t, 1, 0);
    }
    if (err == UC_ERR_OK) {
        err = uc_hook_add(t->uc, &h, UC_HOOK_INTR, (void *)hook_intr, t, 1, 0);
    }
    if (err == UC_ERR_OK) {
        err = uc_hook_add(t->uc, &h, UC_HOOK_MEM_READ_UNMAPPED | UC_HOOK_MEM_WRITE_UNMAPPED,
                          (void *)hook_unmapped, t, 1, 0);
    }
    if (err != UC_ERR_OK) {
        fprintf(log, "tof_twin: unicorn set-up: %s\n", uc_strerror(err));
        return -1;
    }
    t->sysclk_hz = TWIN_MSI_HZ;
    return 0;
}

void twin_free(struct twin *t) {
    if (t->uc != NULL) {
        uc_close(t->uc);
    }
    free(t->flash);
    free(t->sram);
    free(t->block_cache);
    free(t->covered);
}

void twin_load_flash(struct twin *t, const uint8_t *image) {
    memcpy(t->flash, image, TWIN_FLASH_SIZE);
    memset(t->block_cache, 0, (TWIN_FLASH_SIZE / 2u) * sizeof *t->block_cache);
}

static uint32_t flash_word(const struct twin *t, uint32_t off) {
    uint32_t v;
    memcpy(&v, &t->flash[off], 4);
    return v;
}

void twin_reset(struct twin *t, bool power_on) {
    twin_set_sysclk(t, TWIN_MSI_HZ);
    twin_rcc_reset(t, power_on);
    t->flash_if.acr = 0x00000600u; /* RM0351 §3.7.1: DCEN | ICEN, LATENCY 0 */
    twin_flash_reset(t);
    twin_gpio_reset(t);
    twin_i2c_reset(t);
    twin_usart_reset(t);
    twin_iwdg_reset(t);
    twin_scs_reset(t);
    twin_adc_reset(t);
    t->nactive = 0;
    t->irq_wait = false;
    t->reset_pending = false;
    t->watchdog_reset = false;
    /* Reset behaviour, ARMv7-M ARM B1.5.5: SP_main from vector 0, PC from vector 1,
     * thread mode, PRIMASK clear, CONTROL 0. */
    const uint32_t sp = flash_word(t, 0u);
    const uint32_t pc = flash_word(t, 4u);
    uint32_t zero = 0;
    uc_reg_write(t->uc, UC_ARM_REG_CONTROL, &zero);
    uc_reg_write(t->uc, UC_ARM_REG_PRIMASK, &zero);
    uc_reg_write(t->uc, UC_ARM_REG_SP, &sp);
    uint32_t pcv = pc & ~1u;
    uc_reg_write(t->uc, UC_ARM_REG_PC, &pcv);
    uint32_t lr = 0xFFFFFFFFu; /* reset value of LR (B1.5.5: UNKNOWN; all ones on M4) */
    uc_reg_write(t->uc, UC_ARM_REG_LR, &lr);
    if ((pc & 1u) == 0u) {
        twin_violation(t, "vector[1] (Reset_Handler)", pc, "a vector must have bit 0 set (Thumb)");
    }
    t->stats.resets++;
}

/* ---- exception entry and return (ARMv7-M ARM B1.5.6, B1.5.8) ---- */

static bool write_word(struct twin *t, uint32_t addr, uint32_t v) {
    return uc_mem_write(t->uc, addr, &v, 4) == UC_ERR_OK &&
           ((addr >= TWIN_SRAM1_BASE && addr - TWIN_SRAM1_BASE < TWIN_SRAM_SIZE) ||
            (addr >= TWIN_SRAM2_BASE && addr - TWIN_SRAM2_BASE < TWIN_SRAM2_SIZE));
}

static bool read_word(struct twin *t, uint32_t addr, uint32_t *v) {
    return uc_mem_read(t->uc, addr, v, 4) == UC_ERR_OK;
}

/* Take exception `exc` with return address `ret_pc`. False: lockup. */
static bool exception_entry(struct twin *t, unsigned exc, uint32_t ret_pc) {
    static const int regs[6] = {UC_ARM_REG_R0, UC_ARM_REG_R1,  UC_ARM_REG_R2,
                                UC_ARM_REG_R3, UC_ARM_REG_R12, UC_ARM_REG_LR};
    uint32_t frame[8];
    for (unsigned i = 0; i < 6u; ++i) {
        uc_reg_read(t->uc, regs[i], &frame[i]);
    }
    uint32_t xpsr = 0, sp = 0;
    uc_reg_read(t->uc, UC_ARM_REG_XPSR, &xpsr);
    uc_reg_read(t->uc, UC_ARM_REG_SP, &sp);
    xpsr = (xpsr & ~0x1FFu) | (t->nactive > 0u ? t->active[t->nactive - 1u] : 0u);
    /* CCR.STKALIGN = 1 (reset value on the M4): the frame is 8-byte aligned. */
    if ((sp & 4u) != 0u) {
        sp -= 4u;
        xpsr |= XPSR_ALIGN;
    }
    frame[6] = ret_pc & ~1u;
    frame[7] = xpsr | XPSR_T;
    sp -= 32u;
    bool stacked = true;
    for (unsigned i = 0; i < 8u; ++i) {
        stacked = write_word(t, sp + 4u * i, frame[i]) && stacked;
    }
    if (!stacked) {
        /* B1.5.6: a fault on stacking (BFSR.STKERR) is taken as a derived exception; in
         * HardFault or with the stack gone it becomes a HardFault with nothing stacked. */
        t->scs.cfsr |= 1u << 12; /* STKERR */
        t->scs.hfsr |= 1u << 30; /* FORCED */
        if (exc == EXC_HARDFAULT && t->nactive > 0u &&
            t->active[t->nactive - 1u] == EXC_HARDFAULT) {
            return false;
        }
        exc = EXC_HARDFAULT;
    }
    if (t->nactive >= sizeof t->active) {
        return false;
    }
    const uint32_t lr = t->nactive == 0u ? EXC_RETURN_THREAD : EXC_RETURN_HANDLER;
    t->active[t->nactive++] = (uint8_t)exc;
    const uint32_t vec_addr = t->scs.vtor + 4u * exc;
    uint32_t handler = 0;
    if (!read_word(t, vec_addr, &handler)) {
        return false;
    }
    if ((handler & 1u) == 0u) {
        /* A zero (or ARM-state) vector faults with INVSTATE on the M4 (B1.5.6): the same
         * frame is then taken by the HardFault handler. */
        twin_violation(t, "vector table entry", handler,
                       "exception vector without the Thumb bit (zero vector?)");
        if (exc == EXC_HARDFAULT || !read_word(t, t->scs.vtor + 4u * EXC_HARDFAULT, &handler) ||
            (handler & 1u) == 0u) {
            return false;
        }
        exc = EXC_HARDFAULT;
        t->active[t->nactive - 1u] = (uint8_t)exc;
    }
    uc_reg_write(t->uc, UC_ARM_REG_SP, &sp);
    uc_reg_write(t->uc, UC_ARM_REG_LR, &lr);
    /* The handler starts outside any IT block (B1.5.6: EPSR.IT cleared on entry); the
     * interrupted block's IT state is in the stacked xPSR and comes back on return. Found by
     * the twin: a SysTick taken between ITE and its instructions ran the handler with the
     * leftover condition and skipped its BX LR. */
    uint32_t handler_xpsr = (frame[7] & ~XPSR_IT_MASK & ~0x1FFu) | XPSR_T | exc;
    uc_reg_write(t->uc, UC_ARM_REG_XPSR, &handler_xpsr);
    uint32_t pc = handler & ~1u;
    uc_reg_write(t->uc, UC_ARM_REG_PC, &pc);
    if (exc < 16u) {
        t->stats.exceptions[exc]++;
    } else {
        t->stats.irqs++;
    }
    if (t->trace_mmio) {
        fprintf(t->log, "exc entry %u ret 0x%08x sp 0x%08x nactive %u t %llu\n", exc, ret_pc, sp,
                t->nactive, (unsigned long long)twin_now_us(t));
    }
    return true;
}

static void exception_return(struct twin *t, uint32_t exc_return) {
    if (t->nactive == 0u) {
        twin_stop(t, TWIN_STOP_LOCKUP, "branch to EXC_RETURN 0x%08x in thread mode", exc_return);
        return;
    }
    if (exc_return != EXC_RETURN_THREAD && exc_return != EXC_RETURN_HANDLER) {
        twin_stop(t, TWIN_STOP_LOCKUP, "EXC_RETURN 0x%08x not modelled (process stack or FP)",
                  exc_return);
        return;
    }
    t->nactive--;
    uint32_t sp = 0;
    uc_reg_read(t->uc, UC_ARM_REG_SP, &sp);
    uint32_t frame[8];
    for (unsigned i = 0; i < 8u; ++i) {
        if (!read_word(t, sp + 4u * i, &frame[i])) {
            twin_stop(t, TWIN_STOP_LOCKUP, "unstacking from 0x%08x failed", sp);
            return;
        }
    }
    static const int regs[6] = {UC_ARM_REG_R0, UC_ARM_REG_R1,  UC_ARM_REG_R2,
                                UC_ARM_REG_R3, UC_ARM_REG_R12, UC_ARM_REG_LR};
    for (unsigned i = 0; i < 6u; ++i) {
        uc_reg_write(t->uc, regs[i], &frame[i]);
    }
    sp += 32u + ((frame[7] & XPSR_ALIGN) != 0u ? 4u : 0u);
    uc_reg_write(t->uc, UC_ARM_REG_SP, &sp);
    uint32_t xpsr = frame[7] & ~0x1FFu;
    uc_reg_write(t->uc, UC_ARM_REG_XPSR, &xpsr);
    uint32_t pc = frame[6] & ~1u;
    uc_reg_write(t->uc, UC_ARM_REG_PC, &pc);
    if (t->trace_mmio) {
        fprintf(t->log, "exc return to 0x%08x sp 0x%08x nactive %u\n", pc, sp, t->nactive);
    }
}

static void take_fault(struct twin *t, uint32_t pc, const char *what) {
    t->stats.hardfaults++;
    t->fault_pc = pc;
    t->fault_what = what;
    fprintf(t->log, "tof_twin: HardFault at pc 0x%08x (data address 0x%08x), t = %llu us: %s\n", pc,
            t->fault_addr, (unsigned long long)twin_now_us(t), what);
    if (t->nactive > 0u && t->active[t->nactive - 1u] == EXC_HARDFAULT) {
        twin_stop(t, TWIN_STOP_LOCKUP, "fault inside the HardFault handler at 0x%08x (%s)", pc,
                  what);
        return;
    }
    t->scs.hfsr |= 1u << 30; /* FORCED: escalated from a configurable fault */
    if (!exception_entry(t, EXC_HARDFAULT, pc)) {
        twin_stop(t, TWIN_STOP_LOCKUP, "lockup: HardFault entry failed at 0x%08x (%s)", pc, what);
    }
}

/* The external interrupt pending at the NVIC, as an exception number (0: none). The twin
 * models one source, USART2 (IRQ 38): its line, level-sensitive, with its ISER bit set. */
static unsigned external_pending(const struct twin *t) {
    const uint32_t bit = 1u << (TWIN_USART2_IRQ % 32u);
    if ((t->scs.nvic_iser[TWIN_USART2_IRQ / 32u] & bit) != 0u && twin_usart_irq(t)) {
        return 16u + TWIN_USART2_IRQ;
    }
    return 0u;
}

static void deliver_pending(struct twin *t) {
    const unsigned ext = external_pending(t);
    if (t->scs.pending == 0u && ext == 0u) {
        t->irq_wait = false;
        return;
    }
    uint32_t primask = 0;
    uc_reg_read(t->uc, UC_ARM_REG_PRIMASK, &primask);
    if ((primask & 1u) != 0u || t->nactive > 0u) {
        /* Masked, or a handler of the same (default 0) priority runs: the block hook stops
         * the core at the first block that starts unmasked and outside the handler. */
        t->irq_wait = true;
        return;
    }
    t->irq_wait = false;
    /* Every priority is the reset value 0: the lowest exception number goes first
     * (B1.5.4), so a system exception before the external interrupt. */
    unsigned exc = ext;
    for (unsigned e = 2; e < 16u; ++e) {
        if ((t->scs.pending & (1u << e)) != 0u) {
            t->scs.pending &= ~(1u << e);
            exc = e;
            break;
        }
    }
    if (exc == 0u) {
        return;
    }
    uint32_t pc = 0;
    uc_reg_read(t->uc, UC_ARM_REG_PC, &pc);
    if (!exception_entry(t, exc, pc)) {
        twin_stop(t, TWIN_STOP_LOCKUP, "exception %u entry failed", exc);
    }
}

/* A pending reset (watchdog or SYSRESETREQ): its flag in RCC_CSR, a note, then the reset. */
static void system_reset(struct twin *t) {
    if (t->watchdog_reset) {
        t->stats.watchdog_resets++;
        t->rcc.csr |= 1u << 29; /* IWDGRSTF (RM0351 §6.4.29) */
        uint32_t wpc = 0, wlr = 0;
        uc_reg_read(t->uc, UC_ARM_REG_PC, &wpc);
        uc_reg_read(t->uc, UC_ARM_REG_LR, &wlr);
        fprintf(t->log,
                "tof_twin: watchdog reset at t = %llu us (pc 0x%08x, lr 0x%08x, "
                "%u exceptions active)\n",
                (unsigned long long)twin_now_us(t), wpc, wlr, t->nactive);
    } else {
        t->stats.software_resets++;
        t->rcc.csr |= 1u << 28; /* SFTRSTF */
        if (t->trace_mmio) {
            fprintf(t->log, "tof_twin: software reset at t = %llu us\n",
                    (unsigned long long)twin_now_us(t));
        }
    }
    twin_reset(t, false);
}

void twin_run(struct twin *t) {
    while (t->stop == TWIN_RUNNING) {
        if (t->reset_pending) {
            system_reset(t);
        }
        twin_systick_update(t);
        twin_usart_update(t);
        if (t->host_poll != NULL) {
            t->host_poll(t->host_ctx);
        }
        if (twin_iwdg_expiry(t) <= twin_now_ps(t)) {
            t->reset_pending = true;
            t->watchdog_reset = true;
            continue;
        }
        if (t->limit_ps != 0u && twin_now_ps(t) >= t->limit_ps) {
            twin_stop(t, TWIN_STOP_LIMIT, "simulated time limit reached");
            break;
        }
        deliver_pending(t);
        if (t->stop != TWIN_RUNNING) {
            break;
        }
        const uint64_t e = twin_earliest_event(t);
        if (t->next_event <= t->cycles || t->next_event > e) {
            t->next_event = e;
        }
        uint32_t pc = 0;
        uc_reg_read(t->uc, UC_ARM_REG_PC, &pc);
        t->intr_no = -1;
        t->stats.emu_restarts++;
        const uc_err err = uc_emu_start(t->uc, pc | 1u, 0u, 0, 0);
        uc_reg_read(t->uc, UC_ARM_REG_PC, &pc);
        if (t->trace_mmio && (err != UC_ERR_OK || t->intr_no >= 0)) {
            fprintf(t->log, "emu stop: err %d (%s) intr %d pc 0x%08x nactive %u\n", (int)err,
                    uc_strerror(err), t->intr_no, pc, t->nactive);
        }
        if (t->stop != TWIN_RUNNING) {
            break;
        }
        if (err == UC_ERR_FETCH_UNMAPPED || err == UC_ERR_FETCH_PROT ||
            (t->intr_no == 3 /* EXCP_PREFETCH_ABORT */ && pc >= EXC_RETURN_MIN - 1u)) {
            if (pc >= EXC_RETURN_MIN - 1u) {
                exception_return(t, pc | 1u);
            } else {
                take_fault(t, pc, "instruction fetch from unmapped or non-executable memory");
            }
            continue;
        }
        if (err == UC_ERR_READ_UNMAPPED || err == UC_ERR_WRITE_UNMAPPED ||
            err == UC_ERR_WRITE_PROT || err == UC_ERR_READ_PROT) {
            t->scs.cfsr |= (1u << 9) | (1u << 15); /* PRECISERR, BFARVALID */
            take_fault(t, pc, uc_strerror(err));
            continue;
        }
        if (err != UC_ERR_OK) {
            take_fault(t, pc, uc_strerror(err));
            continue;
        }
        if (t->intr_no >= 0) {
            const int no = t->intr_no;
            if (no == 8 /* EXCP_EXCEPTION_EXIT */) {
                exception_return(t, pc | 1u);
            } else {
                take_fault(t, pc, no == 1 ? "undefined instruction" : "core exception");
            }
        }
    }
}
