/* The simulator's seeded xorshift64* generator (sim/sim_prng.h). */
#include "sim/sim_prng.h"

void sim_prng_seed(struct sim_prng *prng, uint32_t seed) {
    /* Spread the seed over 64 bits (a Weyl step); the low bit forced to 1 keeps the state
     * non-zero, which xorshift requires. Nearby seeds diverge after the first draw. */
    prng->state = ((uint64_t)seed * 0x9E3779B97F4A7C15u + 0x6A09E667F3BCC909u) | 1u;
    (void)sim_prng_next(prng);
}
