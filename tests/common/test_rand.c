/* Deterministic pseudo-random numbers for the host tests: see test_rand.h. */
#include "test_rand.h"

#include <math.h>

double test_urand(struct test_rng *r) {
    uint64_t s = r->state;
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    r->state = s;
    return (double)(s >> 11) / 9007199254740992.0;
}

double test_gauss(struct test_rng *r) {
    double u;
    double v;
    double s;
    do {
        u = 2 * test_urand(r) - 1;
        v = 2 * test_urand(r) - 1;
        s = u * u + v * v;
    } while (s >= 1 || s == 0);
    return u * sqrt(-2 * log(s) / s);
}

uint64_t test_u64(struct test_rng *r) {
    uint64_t s = r->state;
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    r->state = s;
    return s * 0x2545F4914F6CDD1Du;
}
