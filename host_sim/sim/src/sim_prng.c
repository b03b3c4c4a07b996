#include "sim/sim_prng.h"

void sim_prng_seed(struct sim_prng *prng, uint32_t seed) {
    /* Mix the seed (a Weyl step, then one xorshift) so nearby seeds diverge at once. */
    uint32_t state = seed * 0x9E3779B9u + 0x6A09E667u;
    prng->state = state != 0u ? state : 0x6A09E667u;
    (void)sim_prng_next(prng);
}

uint32_t sim_prng_next(struct sim_prng *prng) {
    uint32_t x = prng->state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    prng->state = x;
    return x;
}

uint32_t sim_prng_below(struct sim_prng *prng, uint32_t bound) {
    return (uint32_t)(((uint64_t)sim_prng_next(prng) * bound) >> 32);
}

bool sim_prng_chance_ppm(struct sim_prng *prng, uint32_t ppm) {
    return sim_prng_below(prng, 1000000u) < ppm;
}
