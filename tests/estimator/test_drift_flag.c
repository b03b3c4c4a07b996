/*
 * The `drift` flag against white noise: a static plate with white noise only
 * must not be called `drift`, whatever the window and the noise. The learnt drift is a
 * mean of noisy samples (one per block of N rows); at short windows and high noise its
 * scatter alone crossed the 500 µm flag (N = 20, σ 7.3 mm: 35 % of windows before the
 * significance test). The flag now waits until the learnt drift is beyond
 * INTEGRITY_DRIFT_SIGNIFICANCE_Q8 of its own white-noise sd: here ≤ 1 % of windows over a
 * grid of N and σ and several seeds, while a real wander is still flagged.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "estimator/attitude.h"
#include "test_calibration.h"
#include "test_rand.h"

#define TEST_PI 3.14159265358979323846
#define WINDOWS 500u /* windows per seed */
#define SEEDS   8u   /* N <= 20, where the learnt drift scatters most; 3 above */

/* Its own noise stream (tests/common: xorshift64, polar method), seeded per run. */
static struct test_rng rng;
static double gauss(void) {
    return test_gauss(&rng);
}
static const uint64_t seeds[SEEDS] = {0x9E3779B97F4A7C15u, 0xD1B54A32D192ED03u, 0x2545F4914F6CDD1Du,
                                      0xBF58476D1CE4E5B9u, 0x94D049BB133111EBu, 0x5851F42D4C957F2Du,
                                      0x14057B7EF767814Fu, 0xDA942042E4DD58B5u};

static struct attitude_state st;
static struct attitude_output out;
static const uint8_t all_ok[4] = {0, 0, 0, 0};
static const bool all_present[4] = {true, true, true, true};

/* A plate at α = β = 1°, 500 mm, arm 30 mm (A, B, C, D as docs/explanation/architecture.md). */
static void ideal(double x[4]) {
    const double t = tan(1.0 * TEST_PI / 180);
    x[0] = 500 - 30 * t;
    x[1] = 500 + 30 * t;
    x[2] = 500 + 30 * t;
    x[3] = 500 - 30 * t;
}

/* Windows of n rows, σ mm of white noise on every sensor plus per-sensor offsets that
 * wander window to window (AR(1), stationary 1σ wander_mm; 0: white noise only). Returns
 * the share of answers said `drift`: every tumbling window, or every sliding row once the
 * window is full. Only the consensus is computed (the flag is the window's, common to
 * every estimator). */
static double drift_share(unsigned n, double sigma, double wander_mm, uint64_t seed,
                          enum attitude_window_mode mode, unsigned windows) {
    rng.state = seed;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    cfg.window = (uint16_t)n;
    cfg.mode = mode;
    cfg.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    double x[4];
    ideal(x);
    double offset[4] = {0, 0, 0, 0};
    unsigned answers = 0, flagged = 0;
    for (unsigned w = 0; w < windows; ++w) {
        for (unsigned i = 0; i < n; ++i) {
            uint16_t r[4];
            for (unsigned k = 0; k < 4; ++k) {
                r[k] = (uint16_t)lround(x[k] + offset[k] + sigma * gauss());
            }
            if (attitude_push_sample(&st, r, all_ok, all_present, &out)) {
                const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
                answers++;
                flagged += (c->why & ATTITUDE_WHY_DRIFT) != 0u ? 1u : 0u;
            }
        }
        for (unsigned k = 0; k < 4; ++k) { /* 0.5 step to step, stationary 1σ wander_mm */
            offset[k] = 0.5 * offset[k] + wander_mm * sqrt(0.75) * gauss();
        }
    }
    return answers != 0u ? (double)flagged / answers : 1.0;
}

/* The reported case: N = 20, σ 7.3 mm (35 % of windows `drift` before), tumbling and
 * sliding, several seeds: at most 1 % of the answers. */
static void test_white_noise_n20_sigma73(void **state) {
    (void)state;
    const enum attitude_window_mode modes[2] = {ATTITUDE_TUMBLING, ATTITUDE_SLIDING};
    double worst = 0;
    for (unsigned m = 0; m < 2u; ++m) {
        double share = 0;
        for (unsigned s = 0; s < SEEDS; ++s) {
            share += drift_share(20u, 7.3, 0.0, seeds[s], modes[m], WINDOWS) / SEEDS;
        }
        print_message("white noise N 20 sigma 7.3 mm %s: drift in %.2f %% of answers\n",
                      m == 0u ? "tumbling" : "sliding", 100.0 * share);
        worst = share > worst ? share : worst;
    }
    assert_true(worst <= 0.01);
}

/* N = 10..200, σ 0.5..8 mm, tumbling, 500 windows per seed (8 seeds for N <= 20, 3 above):
 * at most 1 % of the windows of any cell (pooled over the seeds). */
static void test_white_noise_grid(void **state) {
    (void)state;
    static const unsigned ns[] = {10u, 20u, 50u, 100u, 200u};
    static const double sigmas[] = {0.5, 1.0, 2.0, 4.0, 7.3, 8.0};
    double worst = 0;
    for (unsigned a = 0; a < sizeof ns / sizeof ns[0]; ++a) {
        char line[160];
        int len = snprintf(line, sizeof line, "N %3u:", ns[a]);
        for (unsigned b = 0; b < sizeof sigmas / sizeof sigmas[0]; ++b) {
            const unsigned n_seeds = ns[a] <= 20u ? SEEDS : 3u;
            double share = 0;
            for (unsigned s = 0; s < n_seeds; ++s) {
                share += drift_share(ns[a], sigmas[b], 0.0, seeds[s] ^ (ns[a] * 977u + b),
                                     ATTITUDE_TUMBLING, WINDOWS) /
                         n_seeds;
            }
            len += snprintf(line + len, sizeof line - (size_t)len, "  %.1f mm %5.2f %%", sigmas[b],
                            100.0 * share);
            worst = share > worst ? share : worst;
        }
        print_message("white noise %s\n", line);
    }
    print_message("white noise grid: worst cell %.2f %% of windows `drift`\n", 100.0 * worst);
    assert_true(worst <= 0.01);
}

/* A real wander is still said at high noise and short windows: offsets of 3 mm 1σ
 * (9 mm² of drift variance, about 13 sd of the learnt drift's white scatter at N = 20,
 * σ 7.3 mm) are `drift` in most windows, in both modes. */
static void test_real_drift_at_high_noise(void **state) {
    (void)state;
    const double tumbling = drift_share(20u, 7.3, 3.0, seeds[0], ATTITUDE_TUMBLING, 200u);
    const double sliding = drift_share(20u, 7.3, 3.0, seeds[1], ATTITUDE_SLIDING, 200u);
    print_message("3 mm wander, N 20 sigma 7.3 mm: drift in %.1f %% (tumbling), %.1f %% "
                  "(sliding)\n",
                  100.0 * tumbling, 100.0 * sliding);
    assert_true(tumbling >= 0.8);
    assert_true(sliding >= 0.8);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_white_noise_n20_sigma73),
        cmocka_unit_test(test_white_noise_grid),
        cmocka_unit_test(test_real_drift_at_high_noise),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
