/* The system control space of the twin's Cortex-M4 (ARMv7-M ARM B3.2, B3.3, B3.4): SysTick
 * counting core cycles, SCB (ICSR, VTOR, AIRCR reset request, fault status), NVIC and MPU
 * storage. */
#include "twin.h"

#define SYST_CSR   0xE000E010u
#define SYST_RVR   0xE000E014u
#define SYST_CVR   0xE000E018u
#define SYST_CALIB 0xE000E01Cu
#define ICSR       0xE000ED04u
#define VTOR       0xE000ED08u
#define AIRCR      0xE000ED0Cu
#define SCR        0xE000ED10u
#define CCR        0xE000ED14u
#define SHPR1      0xE000ED18u
#define SHCSR      0xE000ED24u
#define CFSR       0xE000ED28u
#define HFSR       0xE000ED2Cu
#define MMFAR      0xE000ED34u
#define BFAR       0xE000ED38u
#define CPUID      0xE000ED00u
#define CPACR      0xE000ED88u
#define MPU_TYPE   0xE000ED90u
#define MPU_CTRL   0xE000ED94u
#define MPU_RNR    0xE000ED98u
#define MPU_RBAR   0xE000ED9Cu
#define MPU_RASR   0xE000EDA0u
#define FPCCR      0xE000EF34u
#define FPCAR      0xE000EF38u
#define FPDSCR     0xE000EF3Cu

#define CSR_ENABLE     (1u << 0)
#define CSR_TICKINT    (1u << 1)
#define CSR_CLKSOURCE  (1u << 2)
#define CSR_COUNTFLAG  (1u << 16)
#define ICSR_PENDSTSET (1u << 26)
#define ICSR_PENDSTCLR (1u << 25)
#define ICSR_PENDSVSET (1u << 28)
#define EXC_PENDSV     14u
#define EXC_SYSTICK    15u
/* Idle acceleration (docs/explanation/boards.md "Digital twin"): time polls closer than this in
 * cycles with no other I/O between them are a wait loop, and each one then lasts IDLE_WARP_US. */
#define IDLE_POLL_CYCLES 400u
#define IDLE_WARP_US     50u

void twin_scs_reset(struct twin *t) {
    t->scs = (struct twin_scs){0};
    t->scs.syst_next = UINT64_MAX;
    t->scs.syst_enabled_ps = UINT64_MAX;
    t->scs.ccr = 0x00000200u;   /* STKALIGN (B3.2.8; reset value on the M4) */
    t->scs.aircr = 0xFA050000u; /* VECTKEYSTAT */
    t->scs.fpccr = 0xC0000000u; /* ASPEN | LSPEN */
}

/* SysTick (B3.3): with the processor clock (CLKSOURCE = 1) the counter goes from RVR to 0
 * once per cycle; reaching 0 sets COUNTFLAG and, with TICKINT, pends the exception; the next
 * cycle reloads RVR. A write to CVR clears it to 0 (B3.3.5). Period: RVR + 1 cycles. */
static uint32_t period(const struct twin_scs *s) {
    return (s->syst_rvr & 0xFFFFFFu) + 1u;
}

void twin_systick_update(struct twin *t) {
    struct twin_scs *s = &t->scs;
    if (s->syst_next == UINT64_MAX || t->cycles < s->syst_next) {
        return;
    }
    const uint64_t p = period(s);
    const uint64_t wraps = (t->cycles - s->syst_next) / p + 1u;
    s->syst_next += wraps * p;
    s->countflag = true;
    if ((s->syst_csr & CSR_TICKINT) != 0u) {
        twin_svc_set_pending(&t->svc, EXC_SYSTICK, true);
        if (wraps > 1u) {
            /* The core could not take a tick in time (interrupts masked for > 1 ms): on
             * hardware a tick is lost the same way. */
            fprintf(t->log, "tof_twin: %llu SysTick wraps merged at t = %llu us\n",
                    (unsigned long long)wraps, (unsigned long long)twin_svc_now_us(&t->svc));
        }
    }
}

static uint32_t cvr(struct twin *t) {
    struct twin_scs *s = &t->scs;
    if ((s->syst_csr & CSR_ENABLE) == 0u) {
        return 0u;
    }
    twin_systick_update(t);
    const uint64_t left = s->syst_next - t->cycles; /* 1..period cycles to the next 0 */
    return (uint32_t)(left % period(s));
}

static void restart(struct twin *t) {
    struct twin_scs *s = &t->scs;
    if ((s->syst_csr & CSR_ENABLE) != 0u) {
        /* From 0: the reload comes on the next cycle, the next 0 after RVR more. */
        s->syst_next = t->cycles + period(s);
        if (t->next_event > s->syst_next) {
            t->next_event = s->syst_next;
        }
    } else {
        s->syst_next = UINT64_MAX;
    }
}

/* A read of SYST_CVR, which also spots delay and idle loops (twin_scs_read). */
static uint32_t cvr_read(struct twin *t) {
    if (t->scs_only_since_cvr && t->scs_prev[0] == SYST_CVR && t->scs_prev[1] == ICSR &&
        t->cycles - t->last_cvr_cycles < IDLE_POLL_CYCLES) {
        /* A whole time reading (CVR, ICSR, CVR: the before/pending/after of a wrap-safe
         * read) just ended, and a new one starts with no other peripheral access since:
         * a delay or idle loop. Let this iteration take IDLE_WARP_US, so the loop ends
         * after fewer iterations at the same time (never across a SysTick wrap, never
         * inside one reading). */
        twin_svc_warp_to(&t->svc, twin_svc_now_ps(&t->svc) + IDLE_WARP_US * 1000000ull);
    }
    t->scs_only_since_cvr = true;
    t->last_cvr_cycles = t->cycles;
    t->scs_prev[1] = t->scs_prev[0];
    t->scs_prev[0] = SYST_CVR;
    return cvr(t);
}

/* The SCB, MPU and FPU registers the twin only stores: their value into *v, or false if
 * `addr` is none of them. */
static bool stored_read(const struct twin_scs *s, uint32_t addr, uint32_t *v) {
    switch (addr) {
    case VTOR:
        *v = s->vtor;
        return true;
    case AIRCR:
        *v = (s->aircr & 0xFFFFu) | 0xFA050000u;
        return true;
    case SCR:
        *v = s->scr;
        return true;
    case CCR:
        *v = s->ccr;
        return true;
    case SHPR1:
    case SHPR1 + 4u:
    case SHPR1 + 8u:
        *v = s->shpr[(addr - SHPR1) / 4u];
        return true;
    case SHCSR:
        *v = s->shcsr;
        return true;
    case CFSR:
        *v = s->cfsr;
        return true;
    case HFSR:
        *v = s->hfsr;
        return true;
    case MMFAR:
        *v = s->mmfar;
        return true;
    case BFAR:
        *v = s->bfar;
        return true;
    case CPACR:
        *v = s->cpacr;
        return true;
    case MPU_TYPE:
        *v = 8u << 8; /* 8 regions (Cortex-M4 TRM §4.5) */
        return true;
    case MPU_CTRL:
        *v = s->mpu_ctrl;
        return true;
    case MPU_RNR:
        *v = s->mpu_rnr;
        return true;
    case MPU_RBAR:
        *v = s->mpu_rbar[s->mpu_rnr & 7u];
        return true;
    case MPU_RASR:
        *v = s->mpu_rasr[s->mpu_rnr & 7u];
        return true;
    case FPCCR:
        *v = s->fpccr;
        return true;
    case FPCAR:
        *v = s->fpcar;
        return true;
    case FPDSCR:
        *v = s->fpdscr;
        return true;
    default:
        return false;
    }
}

uint32_t twin_scs_read(struct twin *t, uint32_t addr) {
    struct twin_scs *s = &t->scs;
    if (addr >= 0xE000E100u && addr < 0xE000E120u) {
        return s->nvic_iser[(addr - 0xE000E100u) / 4u];
    }
    if (addr >= 0xE000E400u && addr < 0xE000E400u + 4u * 64u) {
        return s->nvic_ipr[(addr - 0xE000E400u) / 4u];
    }
    switch (addr) {
    case SYST_CSR: {
        twin_systick_update(t);
        const uint32_t v = s->syst_csr | (s->countflag ? CSR_COUNTFLAG : 0u);
        s->countflag = false; /* COUNTFLAG clears on read (B3.3.3) */
        return v;
    }
    case SYST_RVR:
        return s->syst_rvr;
    case SYST_CVR:
        return cvr_read(t);
    case SYST_CALIB:
        return 0x40000000u | (TWIN_HSI16_HZ / 8000u - 1u); /* NOREF; not exact */
    case CPUID:
        return 0x410FC241u; /* Cortex-M4 r0p1 (Cortex-M4 TRM §4.3.1) */
    case ICSR:
        twin_systick_update(t);
        t->scs_prev[1] = t->scs_prev[0];
        t->scs_prev[0] = ICSR;
        return ((s->pending >> EXC_SYSTICK) & 1u ? ICSR_PENDSTSET : 0u) |
               ((s->pending >> EXC_PENDSV) & 1u ? ICSR_PENDSVSET : 0u) |
               (t->nactive > 0u ? t->active[t->nactive - 1u] : 0u);
    default: {
        uint32_t v = 0u;
        if (stored_read(s, addr, &v)) {
            return v;
        }
        twin_svc_violation(&t->svc, "system control space", addr,
                           "SCS register the twin does not model");
        return 0u;
    }
    }
}

/* The SCB, MPU and FPU registers the twin only stores (no side effect but the write), or
 * false if `addr` is none of them. */
static bool stored_write(struct twin_scs *s, uint32_t addr, uint32_t v) {
    switch (addr) {
    case VTOR:
        s->vtor = v & 0xFFFFFF80u;
        break;
    case SCR:
        s->scr = v;
        break;
    case CCR:
        s->ccr = v;
        break;
    case SHPR1:
    case SHPR1 + 4u:
    case SHPR1 + 8u:
        s->shpr[(addr - SHPR1) / 4u] = v;
        break;
    case SHCSR:
        s->shcsr = v;
        break;
    case CFSR:
        s->cfsr &= ~v;
        break; /* write 1 to clear */
    case HFSR:
        s->hfsr &= ~v;
        break;
    case MMFAR:
        s->mmfar = v;
        break;
    case BFAR:
        s->bfar = v;
        break;
    case CPACR:
        s->cpacr = v;
        break;
    case MPU_RNR:
        s->mpu_rnr = v & 7u;
        break;
    case MPU_RBAR:
        s->mpu_rbar[s->mpu_rnr & 7u] = v;
        break;
    case MPU_RASR:
        s->mpu_rasr[s->mpu_rnr & 7u] = v;
        break;
    case FPCCR:
        s->fpccr = v;
        break;
    case FPCAR:
        s->fpcar = v;
        break;
    case FPDSCR:
        s->fpdscr = v;
        break;
    default:
        return false;
    }
    return true;
}

/* A write of SYST_CSR: enabling the counter starts it (and the board's clock) now. */
static void syst_csr_write(struct twin *t, uint32_t v) {
    struct twin_scs *s = &t->scs;
    twin_systick_update(t);
    if ((v & CSR_CLKSOURCE) == 0u && (v & CSR_ENABLE) != 0u) {
        twin_svc_violation(&t->svc, "SYST_CSR", v,
                           "SysTick from the external reference (HCLK/8) is not modelled");
    }
    const bool was = (s->syst_csr & CSR_ENABLE) != 0u;
    s->syst_csr = v & (CSR_ENABLE | CSR_TICKINT | CSR_CLKSOURCE);
    if (!was && (v & CSR_ENABLE) != 0u) {
        restart(t); /* counts from the current value, 0 after a CVR write */
        s->syst_enabled_ps = twin_svc_now_ps(&t->svc);
    } else if ((v & CSR_ENABLE) == 0u) {
        s->syst_next = UINT64_MAX;
    }
}

void twin_scs_write(struct twin *t, uint32_t addr, uint32_t v) {
    struct twin_scs *s = &t->scs;
    if (addr >= 0xE000E100u && addr < 0xE000E120u) {
        const uint32_t n = (addr - 0xE000E100u) / 4u;
        const uint32_t modelled = n == TWIN_USART2_IRQ / 32u ? 1u << (TWIN_USART2_IRQ % 32u) : 0u;
        if ((v & ~modelled) != 0u) {
            twin_svc_violation(&t->svc, "NVIC_ISER", v,
                               "external interrupt enabled whose source the twin does not "
                               "model (only USART2, IRQ 38)");
        }
        s->nvic_iser[(addr - 0xE000E100u) / 4u] |= v;
        return;
    }
    if (addr >= 0xE000E180u && addr < 0xE000E1A0u) {
        s->nvic_iser[(addr - 0xE000E180u) / 4u] &= ~v;
        return;
    }
    if (addr >= 0xE000E400u && addr < 0xE000E400u + 4u * 64u) {
        s->nvic_ipr[(addr - 0xE000E400u) / 4u] = v;
        return;
    }
    switch (addr) {
    case SYST_CSR:
        syst_csr_write(t, v);
        break;
    case SYST_RVR:
        s->syst_rvr = v & 0xFFFFFFu;
        break;
    case SYST_CVR:
        s->countflag = false;
        restart(t);
        break;
    case ICSR:
        if ((v & ICSR_PENDSTSET) != 0u) {
            twin_svc_set_pending(&t->svc, EXC_SYSTICK, true);
        }
        if ((v & ICSR_PENDSTCLR) != 0u) {
            twin_svc_set_pending(&t->svc, EXC_SYSTICK, false);
        }
        if ((v & ICSR_PENDSVSET) != 0u) {
            twin_svc_set_pending(&t->svc, EXC_PENDSV, true);
        }
        break;
    case AIRCR:
        if ((v >> 16) != 0x05FAu) {
            twin_svc_violation(&t->svc, "SCB_AIRCR", v,
                               "write without VECTKEY 0x05FA is ignored (B3.2.6)");
            break;
        }
        s->aircr = v & 0x0700u;
        if ((v & (1u << 2)) != 0u) { /* SYSRESETREQ */
            t->reset_pending = true;
            t->watchdog_reset = false;
            twin_svc_kick(&t->svc);
        }
        break;
    case MPU_CTRL:
        s->mpu_ctrl = v;
        if ((v & 1u) != 0u) {
            twin_svc_violation(&t->svc, "MPU_CTRL", v,
                               "MPU enabled: region checks are not modelled");
        }
        break;
    default:
        if (!stored_write(s, addr, v)) {
            twin_svc_violation(&t->svc, "system control space", addr,
                               "SCS register the twin does not model");
        }
        break;
    }
}
