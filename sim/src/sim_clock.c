/* The simulated monotonic clock and its hal_time implementation (sim/sim_clock.h). */
#include "sim/sim_clock.h"

void sim_clock_init(struct sim_clock *clock, uint64_t start_us) {
    clock->now_us = start_us;
    clock->wake_us = 0u; /* the first advance runs whoever listens by then */
    clock->listener_count = 0u;
    clock->delay_calls = 0u;
    clock->delayed_us = 0u;
}

int sim_clock_listen(struct sim_clock *clock, uint64_t (*on_advance)(void *ctx), void *ctx) {
    for (uint32_t i = 0; i < clock->listener_count; ++i) {
        if (clock->listeners[i].on_advance == on_advance && clock->listeners[i].ctx == ctx) {
            return 0;
        }
    }
    if (clock->listener_count >= SIM_CLOCK_MAX_LISTENERS) {
        return -1;
    }
    clock->listeners[clock->listener_count].on_advance = on_advance;
    clock->listeners[clock->listener_count].ctx = ctx;
    clock->listener_count++;
    clock->wake_us = 0u; /* run it after the next advance */
    return 0;
}

void sim_clock_advance(struct sim_clock *clock, uint64_t us) {
    clock->now_us += us;
    if (clock->now_us < clock->wake_us) {
        return; /* no listener has anything due: the common case */
    }
    /* Every listener runs (in registration order, as when all ran on every advance) and
     * the wake time becomes the earliest next event; a listener calling
     * sim_clock_wake_at() meanwhile lowers it further. */
    clock->wake_us = SIM_CLOCK_NEVER;
    for (uint32_t i = 0; i < clock->listener_count; ++i) {
        sim_clock_wake_at(clock, clock->listeners[i].on_advance(clock->listeners[i].ctx));
    }
}

static uint32_t sim_time_now_us(void *ctx) {
    const struct sim_clock *clock = ctx;
    return (uint32_t)(clock->now_us & 0xFFFFFFFFu);
}

static void sim_time_delay_us(void *ctx, uint32_t us) {
    struct sim_clock *clock = ctx;
    clock->delay_calls++;
    clock->delayed_us += us;
    sim_clock_advance(clock, us);
}

const struct hal_time_ops sim_clock_time_ops = {
    .now_us = sim_time_now_us,
    .delay_us = sim_time_delay_us,
};

struct hal_time sim_clock_hal(struct sim_clock *clock) {
    struct hal_time time = {&sim_clock_time_ops, clock};
    return time;
}
