/* The core's services to the peripheral models (twin_services.h): simulated time from retired
 * instructions, poll-loop warps, pending exceptions, stops and the violation hook. */
#include <stdarg.h>

#include "twin.h"

uint64_t twin_now_ps(const struct twin *t) {
    return t->base_ps + (t->cycles - t->base_cycles) * (1000000000000ull / t->sysclk_hz);
}

uint64_t twin_ps_to_cycles(const struct twin *t, uint64_t ps) {
    const uint64_t per = 1000000000000ull / t->sysclk_hz;
    return (ps + per - 1u) / per;
}

void twin_set_sysclk(struct twin *t, uint32_t hz) {
    t->base_ps = twin_now_ps(t);
    t->base_cycles = t->cycles;
    t->sysclk_hz = hz;
}

/* Never uc_emu_stop() from a memory callback: Unicorn then restarts from the block's first
 * instruction (measured: the block's earlier stores ran twice). The block hook stops the core
 * at the next block boundary instead, where the state is exact. */
void twin_kick(struct twin *t) {
    t->next_event = t->cycles;
}

uint64_t twin_earliest_event(struct twin *t) {
    uint64_t e = t->scs.syst_next;
    const uint64_t w = twin_iwdg_expiry(t);
    if (w != UINT64_MAX) {
        const uint64_t now = twin_now_ps(t);
        const uint64_t wc = t->cycles + (w > now ? twin_ps_to_cycles(t, w - now) : 0u);
        e = wc < e ? wc : e;
    }
    const uint64_t u = twin_usart_next_event_ps(t);
    if (u != UINT64_MAX) {
        const uint64_t now = twin_now_ps(t);
        const uint64_t uc = t->cycles + (u > now ? twin_ps_to_cycles(t, u - now) : 0u);
        e = uc < e ? uc : e;
    }
    if (t->limit_ps != 0u) {
        const uint64_t now = twin_now_ps(t);
        const uint64_t lc =
            t->cycles + (t->limit_ps > now ? twin_ps_to_cycles(t, t->limit_ps - now) : 0u);
        e = lc < e ? lc : e;
    }
    return e;
}

void twin_warp_to(struct twin *t, uint64_t ps) {
    const uint64_t now = twin_now_ps(t);
    if (ps <= now) {
        return;
    }
    uint64_t target = t->cycles + twin_ps_to_cycles(t, ps - now);
    const uint64_t e = twin_earliest_event(t);
    if (target > e) {
        target = e;
    }
    if (target > t->cycles) {
        t->stats.warps++;
        t->stats.warped_cycles += target - t->cycles;
        t->cycles = target;
    }
    if (t->cycles >= t->next_event) {
        twin_kick(t);
    }
}

void twin_violation(struct twin *t, const char *reg, uint32_t value, const char *rule) {
    if (t->stop != TWIN_RUNNING) {
        return;
    }
    uint32_t pc = 0;
    uc_reg_read(t->uc, UC_ARM_REG_PC, &pc);
    if (t->strict) {
        twin_stop(t, TWIN_STOP_VIOLATION, "strict: %s = 0x%08x at pc 0x%08x, t = %llu us: %s", reg,
                  value, pc, (unsigned long long)twin_now_us(t), rule);
    } else {
        fprintf(t->log, "tof_twin: warning: %s = 0x%08x at pc 0x%08x: %s\n", reg, value, pc, rule);
    }
}

void twin_stop(struct twin *t, enum twin_stop why, const char *fmt, ...) {
    if (t->stop != TWIN_RUNNING) {
        return;
    }
    t->stop = why;
    va_list ap;
    va_start(ap, fmt);
    /* NOLINTNEXTLINE(clang-analyzer-valist.Uninitialized): va_start just above */
    vsnprintf(t->stop_msg, sizeof t->stop_msg, fmt, ap);
    va_end(ap);
    twin_kick(t);
}

void twin_set_pending(struct twin *t, unsigned exc, bool pending) {
    if (pending) {
        t->scs.pending |= 1u << exc;
        twin_kick(t);
    } else {
        t->scs.pending &= ~(1u << exc);
    }
}

/* ---- the ops table the models see (twin_services.h): each entry is the function above ---- */

static uint64_t svc_now_ps(void *ctx) {
    return twin_now_ps(ctx);
}
static void svc_warp_to(void *ctx, uint64_t ps) {
    twin_warp_to(ctx, ps);
}
static void svc_violation(void *ctx, const char *reg, uint32_t value, const char *rule) {
    twin_violation(ctx, reg, value, rule);
}
static void svc_set_sysclk(void *ctx, uint32_t hz) {
    twin_set_sysclk(ctx, hz);
}
static void svc_kick(void *ctx) {
    twin_kick(ctx);
}
static void svc_set_pending(void *ctx, unsigned exc, bool pending) {
    twin_set_pending(ctx, exc, pending);
}

static const struct twin_services_ops core_services = {
    .now_ps = svc_now_ps,
    .warp_to = svc_warp_to,
    .violation = svc_violation,
    .set_sysclk = svc_set_sysclk,
    .kick = svc_kick,
    .set_pending = svc_set_pending,
};

struct twin_services twin_core_services(struct twin *t) {
    return (struct twin_services){.ops = &core_services, .ctx = t};
}
