#include "sim/sim_prng.h"

void sim_prng_seed(struct sim_prng *prng, uint32_t seed) {
    /* Spread the seed over 64 bits (a Weyl step); the low bit forced to 1 keeps the state
     * non-zero, which xorshift requires. Nearby seeds diverge after the first draw. */
    prng->state = ((uint64_t)seed * 0x9E3779B97F4A7C15u + 0x6A09E667F3BCC909u) | 1u;
    (void)sim_prng_next(prng);
}

uint32_t sim_prng_next(struct sim_prng *prng) {
    uint64_t x = prng->state;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    prng->state = x;
    return (uint32_t)((x * 0x2545F4914F6CDD1Du) >> 32);
}

uint32_t sim_prng_below(struct sim_prng *prng, uint32_t bound) {
    return (uint32_t)(((uint64_t)sim_prng_next(prng) * bound) >> 32);
}

bool sim_prng_chance_ppm(struct sim_prng *prng, uint32_t ppm) {
    return sim_prng_below(prng, 1000000u) < ppm;
}
