/*
 * Seeded deterministic PRNG for scenes: xoshiro256** (Blackman and Vigna,
 * "Scrambled linear pseudorandom number generators", ACM TOMS 2021), seeded by
 * SplitMix64, our own implementation of the published algorithms. Integer
 * state, uniform doubles from the top 53 bits, and normal deviates by
 * Marsaglia's polar method with our own log (scene_det_log) so that the output
 * depends only on IEEE-754 +,−,×,÷ and sqrt: the same bits on every machine
 * (the build is ISO C, so no FMA contraction).
 */
#ifndef SCENE_RNG_H
#define SCENE_RNG_H

#include <stdbool.h>
#include <stdint.h>

struct scene_rng {
    uint64_t s[4];
    double spare; /* second deviate of the last polar pair */
    bool has_spare;
};

/* Seeds stream `stream` of `seed`: different (seed, stream) pairs give
 * independent-looking sequences; the same pair always gives the same one. */
void scene_rng_seed(struct scene_rng *rng, uint64_t seed, uint64_t stream);

/* Next 64 random bits. */
uint64_t scene_rng_u64(struct scene_rng *rng);

/* Uniform double in [0, 1) with 53 random bits. */
double scene_rng_uniform(struct scene_rng *rng);

/* Uniform double in [lo, hi). */
double scene_rng_range(struct scene_rng *rng, double lo, double hi);

/* Uniform integer in [0, n) (n > 0), without modulo bias. */
uint32_t scene_rng_below(struct scene_rng *rng, uint32_t n);

/* Standard normal deviate N(0, 1). */
double scene_rng_normal(struct scene_rng *rng);

/* Natural logarithm of x > 0 (finite) from frexp and an atanh series: exact
 * to about 1 ulp and bit-identical across IEEE-754 machines, unlike libm. */
double scene_det_log(double x);

#endif /* SCENE_RNG_H */
