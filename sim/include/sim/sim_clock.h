/*
 * Simulated monotonic clock in microseconds, and a hal_time implementation on it.
 * Nothing advances it but delays (hal_time delay_us, sim_clock_advance) and the
 * simulated bus (each transfer takes its wire time), so every run is deterministic.
 * Device models read it to run their own state (boot, measurements) up to "now".
 * Listeners are event driven: each says when it next has something to do, and an
 * advance that does not reach the earliest of those times calls nobody (a replay
 * advances the clock about fourteen times per sample; the models act on one or two).
 */
#ifndef SIM_CLOCK_H
#define SIM_CLOCK_H

#include <stdint.h>

#include "hal/hal_time.h"

#define SIM_CLOCK_MAX_LISTENERS 16u
#define SIM_CLOCK_NEVER         UINT64_MAX /* a wake time: nothing pending */

/* Called after an advance that reaches the clock's wake time: the listener runs its state
 * up to "now" and returns the time of its next own state change (SIM_CLOCK_NEVER: none;
 * anything <= now: call it after every advance). */
struct sim_clock_listener {
    uint64_t (*on_advance)(void *ctx);
    void *ctx;
};

struct sim_clock {
    uint64_t now_us;
    uint64_t wake_us; /* earliest time a listener asked to run at (<= each one's next event) */
    struct sim_clock_listener listeners[SIM_CLOCK_MAX_LISTENERS];
    uint32_t listener_count;
    uint32_t delay_calls; /* statistics: hal_time delay_us calls */
    uint64_t delayed_us;  /* statistics: total time spent in delays */
};

/* Start at `start_us` (0 is fine; a value near 2^32 exercises the hal_time wrap); no listeners. */
void sim_clock_init(struct sim_clock *clock, uint64_t start_us);

/* Run `on_advance(ctx)` after the next advance, and after every later one that reaches
 * the time it returned or a sim_clock_wake_at() time (a second registration of the same
 * pair is ignored). 0, or -1 when SIM_CLOCK_MAX_LISTENERS are registered already. */
int sim_clock_listen(struct sim_clock *clock, uint64_t (*on_advance)(void *ctx), void *ctx);

/* Current simulated time (inline: device models and the bus read it several times per
 * transfer). */
static inline uint64_t sim_clock_now(const struct sim_clock *clock) {
    return clock->now_us;
}

/* A listener's next state change moved earlier (a device started ranging, rebooted):
 * make sure the listeners run after the first advance reaching `at_us`. */
static inline void sim_clock_wake_at(struct sim_clock *clock, uint64_t at_us) {
    if (at_us < clock->wake_us) {
        clock->wake_us = at_us;
    }
}

/* Move time forward by `us`, then run the listeners if the wake time is reached. */
void sim_clock_advance(struct sim_clock *clock, uint64_t us);

/* hal_time over a sim_clock: ctx is the struct sim_clock *. now_us is the low 32 bits. */
extern const struct hal_time_ops sim_clock_time_ops;

/* A hal_time handle for `clock`. */
struct hal_time sim_clock_hal(struct sim_clock *clock);

#endif /* SIM_CLOCK_H */
