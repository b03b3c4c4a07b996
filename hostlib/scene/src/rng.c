/*
 * xoshiro256** and SplitMix64 as published by Blackman and Vigna
 * (https://prng.di.unimi.it/, ACM TOMS 47(4) 2021), written here from the
 * algorithm description; Marsaglia and Bray's polar method (SIAM Review 6(3),
 * 1964) for normal deviates.
 */
#include "scene/rng.h"

#include <math.h>

static uint64_t splitmix64(uint64_t *x) {
    uint64_t z = (*x += 0x9e3779b97f4a7c15u);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
    return z ^ (z >> 31);
}

static uint64_t rotl(uint64_t x, unsigned k) {
    return (x << k) | (x >> (64u - k));
}

void scene_rng_seed(struct scene_rng *rng, uint64_t seed, uint64_t stream) {
    /* Mix the stream into the SplitMix state through one SplitMix step of its
     * own so that (seed, stream) and (seed + 1, stream − 1) do not collide. */
    uint64_t st = stream;
    uint64_t x = seed ^ splitmix64(&st);
    for (unsigned i = 0; i < 4u; ++i) {
        rng->s[i] = splitmix64(&x);
    }
    /* xoshiro's state must not be all zero; SplitMix64 is a bijection of its
     * counter so four zero outputs in a row cannot happen, but be explicit. */
    if ((rng->s[0] | rng->s[1] | rng->s[2] | rng->s[3]) == 0u) {
        rng->s[0] = 1u;
    }
    rng->spare = 0.0;
    rng->has_spare = false;
}

uint64_t scene_rng_u64(struct scene_rng *rng) {
    uint64_t *s = rng->s;
    const uint64_t result = rotl(s[1] * 5u, 7u) * 9u;
    const uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45u);
    return result;
}

double scene_rng_uniform(struct scene_rng *rng) {
    return (double)(scene_rng_u64(rng) >> 11) * 0x1.0p-53;
}

double scene_rng_range(struct scene_rng *rng, double lo, double hi) {
    return lo + (hi - lo) * scene_rng_uniform(rng);
}

uint32_t scene_rng_below(struct scene_rng *rng, uint32_t n) {
    /* Lemire's multiply-shift with rejection of the biased low zone. */
    const uint64_t threshold = (0x100000000u - (uint64_t)n) % n;
    for (unsigned tries = 0; tries < 64u; ++tries) {
        const uint64_t m = (scene_rng_u64(rng) >> 32) * (uint64_t)n;
        if ((m & 0xffffffffu) >= threshold) {
            return (uint32_t)(m >> 32);
        }
    }
    /* P(64 rejections) < 2^-64: unreachable in practice; still an answer. */
    return (uint32_t)((scene_rng_u64(rng) >> 32) % n);
}

double scene_det_log(double x) {
    /* x = m·2^e with m in [√½, √2); ln m = 2·atanh(s), s = (m−1)/(m+1), |s| ≤ 0.1716,
     * so s² ≤ 0.0295 and 14 odd terms leave a remainder below 1e-21. */
    int e = 0;
    double m = frexp(x, &e);
    if (m < 0.70710678118654752440) {
        m *= 2.0;
        e -= 1;
    }
    const double s = (m - 1.0) / (m + 1.0);
    const double s2 = s * s;
    double term = s;
    double sum = 0.0;
    double series[14];
    for (unsigned k = 0; k < 14u; ++k) {
        series[k] = term / (double)(2u * k + 1u);
        term *= s2;
    }
    for (unsigned k = 14u; k-- > 0u;) { /* smallest terms first */
        sum += series[k];
    }
    /* ln 2 split in a high part with trailing zero bits and a low correction
     * so that e·ln2_hi is exact for |e| < 2^11. */
    const double ln2_hi = 6.93147180369123816490e-01;
    const double ln2_lo = 1.90821492927058770002e-10;
    return (double)e * ln2_hi + ((double)e * ln2_lo + 2.0 * sum);
}

double scene_rng_normal(struct scene_rng *rng) {
    if (rng->has_spare) {
        rng->has_spare = false;
        return rng->spare;
    }
    /* Acceptance π/4 per try: 200 tries all fail with probability < 1e-130. */
    for (unsigned tries = 0; tries < 200u; ++tries) {
        const double u = 2.0 * scene_rng_uniform(rng) - 1.0;
        const double v = 2.0 * scene_rng_uniform(rng) - 1.0;
        const double s = u * u + v * v;
        if (s > 0.0 && s < 1.0) {
            const double f = sqrt(-2.0 * scene_det_log(s) / s);
            rng->spare = v * f;
            rng->has_spare = true;
            return u * f;
        }
    }
    return 0.0;
}
