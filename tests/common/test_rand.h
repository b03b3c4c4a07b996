/*
 * Deterministic pseudo-random numbers for the host tests, written once: the
 * generators the estimator's tests each carried a copy of. Same sequences as those
 * copies, so every test draws exactly the inputs it drew before.
 */
#ifndef TESTS_COMMON_TEST_RAND_H
#define TESTS_COMMON_TEST_RAND_H

#include <stdint.h>

/* A generator's state: any non-zero seed. */
struct test_rng {
    uint64_t state;
};

/* Uniform in [0, 1) with 53 random bits: xorshift64 with shifts (13, 7, 17) (Marsaglia,
 * "Xorshift RNGs", J. Stat. Softw. 8(14), 2003). */
double test_urand(struct test_rng *r);

/* Standard normal: Marsaglia's polar method on test_urand(). */
double test_gauss(struct test_rng *r);

/* 64 random bits: xorshift64* (Vigna, "An experimental exploration of Marsaglia's xorshift
 * generators, scrambled", ACM TOMS 42(4), 2016). */
uint64_t test_u64(struct test_rng *r);

#endif /* TESTS_COMMON_TEST_RAND_H */
