#include "sim/sim_clock.h"

void sim_clock_init(struct sim_clock *clock, uint64_t start_us) {
    clock->now_us = start_us;
    clock->delay_calls = 0u;
    clock->delayed_us = 0u;
}

uint64_t sim_clock_now(const struct sim_clock *clock) {
    return clock->now_us;
}

void sim_clock_advance(struct sim_clock *clock, uint64_t us) {
    clock->now_us += us;
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
