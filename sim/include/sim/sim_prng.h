/*
 * The simulator's own seeded integer PRNG: xorshift64* (S. Vigna, "An experimental
 * exploration of Marsaglia's xorshift generators, scrambled", ACM TOMS 42(4), 2016:
 * shifts 12/25/27, multiplier 0x2545F4914F6CDD1D, high 32 bits out). Small, no float,
 * the same sequence on every host and core.
 */
#ifndef SIM_PRNG_H
#define SIM_PRNG_H

#include <stdbool.h>
#include <stdint.h>

struct sim_prng {
    uint64_t state;
};

/* Seed the generator; any seed is valid. */
void sim_prng_seed(struct sim_prng *prng, uint32_t seed);

/* Next 32 random bits. (Inline, like the two below: the bus draws eight per transfer when
 * faults are on.) */
static inline uint32_t sim_prng_next(struct sim_prng *prng) {
    uint64_t x = prng->state;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    prng->state = x;
    return (uint32_t)((x * 0x2545F4914F6CDD1Du) >> 32);
}

/* Uniform in 0..bound-1 (bound > 0), by multiply-shift (bias < bound / 2^32). */
static inline uint32_t sim_prng_below(struct sim_prng *prng, uint32_t bound) {
    return (uint32_t)(((uint64_t)sim_prng_next(prng) * bound) >> 32);
}

/* True with probability ppm / 1 000 000. Always draws one number, so the stream of
 * draws does not depend on the probabilities. */
static inline bool sim_prng_chance_ppm(struct sim_prng *prng, uint32_t ppm) {
    return sim_prng_below(prng, 1000000u) < ppm;
}

#endif /* SIM_PRNG_H */
