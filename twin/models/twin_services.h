/*
 * What the emulated core gives its peripheral models: simulated time, the poll-loop warp, the
 * core's events (SYSCLK switch, a pending exception, a stop at the next block) and the
 * violation hook. A const ops table plus a context pointer (docs/explanation/architecture.md),
 * filled by the core (twin_core_services.c) and passed down in struct twin, so a model calls down
 * into it and never up into the CPU's file.
 */
#ifndef TWIN_TWIN_SERVICES_H
#define TWIN_TWIN_SERVICES_H

#include <stdbool.h>
#include <stdint.h>

struct twin_services_ops {
    /* Simulated time since power-on, picoseconds. */
    uint64_t (*now_ps)(void *ctx);
    /* A poll of a register whose next change is at `ps`: move time there at once, but never
     * across the next SysTick wrap or watchdog expiry. */
    void (*warp_to)(void *ctx, uint64_t ps);
    /* An access the manual forbids: stop the run (strict mode) or warn once per rule. */
    void (*violation)(void *ctx, const char *reg, uint32_t value, const char *rule);
    /* The core clock now runs at `hz` (the RCC model's clock switch). */
    void (*set_sysclk)(void *ctx, uint32_t hz);
    /* Stop the core at the next block: an event is due now. */
    void (*kick)(void *ctx);
    /* Mark system exception `exc` pending (and stop at the next block) or not. */
    void (*set_pending)(void *ctx, unsigned exc, bool pending);
};

struct twin_services {
    const struct twin_services_ops *ops;
    void *ctx;
};

static inline uint64_t twin_svc_now_ps(const struct twin_services *s) {
    return s->ops->now_ps(s->ctx);
}
static inline uint64_t twin_svc_now_us(const struct twin_services *s) {
    return twin_svc_now_ps(s) / 1000000u;
}
static inline void twin_svc_warp_to(const struct twin_services *s, uint64_t ps) {
    s->ops->warp_to(s->ctx, ps);
}
static inline void twin_svc_violation(const struct twin_services *s, const char *reg,
                                      uint32_t value, const char *rule) {
    s->ops->violation(s->ctx, reg, value, rule);
}
static inline void twin_svc_set_sysclk(const struct twin_services *s, uint32_t hz) {
    s->ops->set_sysclk(s->ctx, hz);
}
static inline void twin_svc_kick(const struct twin_services *s) {
    s->ops->kick(s->ctx);
}
static inline void twin_svc_set_pending(const struct twin_services *s, unsigned exc, bool pending) {
    s->ops->set_pending(s->ctx, exc, pending);
}

#endif /* TWIN_TWIN_SERVICES_H */
