/*
 * Simulated monotonic clock in microseconds, and a hal_time implementation on it.
 * Nothing advances it but delays (hal_time delay_us, sim_clock_advance) and the
 * simulated bus (each transfer takes its wire time), so every run is deterministic.
 * Device models read it to run their own state (boot, measurements) up to "now".
 */
#ifndef SIM_CLOCK_H
#define SIM_CLOCK_H

#include <stdint.h>

#include "hal/hal_time.h"

#define SIM_CLOCK_MAX_LISTENERS 16u

/* Called after every advance of the clock: device models run their state up to "now". */
struct sim_clock_listener {
    void (*on_advance)(void *ctx);
    void *ctx;
};

struct sim_clock {
    uint64_t now_us;
    struct sim_clock_listener listeners[SIM_CLOCK_MAX_LISTENERS];
    uint32_t listener_count;
    uint32_t delay_calls; /* statistics: hal_time delay_us calls */
    uint64_t delayed_us;  /* statistics: total time spent in delays */
};

/* Start at `start_us` (0 is fine; a value near 2^32 exercises the hal_time wrap); no listeners. */
void sim_clock_init(struct sim_clock *clock, uint64_t start_us);

/* Run `on_advance(ctx)` after every advance (a second registration of the same pair is
 * ignored). 0, or -1 when SIM_CLOCK_MAX_LISTENERS are registered already. */
int sim_clock_listen(struct sim_clock *clock, void (*on_advance)(void *ctx), void *ctx);

/* Current simulated time. */
uint64_t sim_clock_now(const struct sim_clock *clock);

/* Move time forward by `us`, then run the listeners. */
void sim_clock_advance(struct sim_clock *clock, uint64_t us);

/* hal_time over a sim_clock: ctx is the struct sim_clock *. now_us is the low 32 bits. */
extern const struct hal_time_ops sim_clock_time_ops;

/* A hal_time handle for `clock`. */
struct hal_time sim_clock_hal(struct sim_clock *clock);

#endif /* SIM_CLOCK_H */
