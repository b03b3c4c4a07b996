/*
 * estimator/kalman: agreement with the batch weighted least-squares solution
 * and with its covariance (the inverse information), positive definiteness over long
 * runs, skipped and gated readings, the robust warm-up, lock-out restart,
 * noise tracking, observability with missing sensors, configuration errors.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "test_rand.h"

#include "estimator/kalman.h"
#include "kalman_internal.h" /* white-box: the filter's private constants */

#define TEST_PI 3.14159265358979323846
#define Q32     4294967296.0

static struct kalman_state kf;

static struct test_rng rng = {0x243F6A8885A308D3u}; /* tests/common/test_rand.h */
static double urand(void) {
    return test_urand(&rng);
}
static double gauss(void) {
    return test_gauss(&rng);
}

static struct kalman_config default_config(void) {
    struct kalman_config c;
    memset(&c, 0, sizeof c);
    for (unsigned s = 0; s < 4; ++s) {
        c.initial_noise_mm2[s] = (int64_t)4 << 32;
    }
    c.gate_sigmas_q8 = 5 * 256;
    c.gate_floor_mm = 3;
    c.warmup_rows = 3;
    c.noise_shift = 2;
    return c;
}

static void ideal(double arm, double xbar, double alpha_deg, double beta_deg, double x[4]) {
    const double ta = tan(alpha_deg * TEST_PI / 180), tb = tan(beta_deg * TEST_PI / 180);
    x[0] = xbar - arm * ta;
    x[1] = xbar + arm * tb;
    x[2] = xbar + arm * ta;
    x[3] = xbar - arm * tb;
}

static void push(const double x[4], uint8_t valid, struct kalman_rows *rows) {
    uint16_t r[4];
    for (unsigned k = 0; k < 4; ++k) {
        const double v = round(x[k]);
        r[k] = (uint16_t)(v < 0 ? 0 : v > 65535 ? 65535 : v);
    }
    kalman_push_row(&kf, r, valid, rows);
}

static void test_config_errors(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    c.process_noise_mm2[1] = -1;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_ERR_PROCESS_NOISE);
    c = default_config();
    c.initial_noise_mm2[2] = 0;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_ERR_MEASUREMENT_NOISE);
    c.initial_noise_mm2[2] = KALMAN_R_MIN_Q32 - 1; /* below the 1 mm rounding's variance */
    assert_int_equal(kalman_init(&kf, &c), KALMAN_ERR_MEASUREMENT_NOISE);
    c.initial_noise_mm2[2] = KALMAN_R_MIN_Q32;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    c = default_config();
    c.warmup_rows = 0;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_ERR_WARMUP);
    c.warmup_rows = KALMAN_WARMUP_MAX + 1;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_ERR_WARMUP);
    c = default_config();
    c.noise_shift = 9;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_ERR_NOISE_SHIFT);
}

static void test_noise_free_plate_is_exact(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    /* integer-exact geometry: a = 30, x̄ = 100, a·tan α = 3, a·tan β = −2 */
    const double x[4] = {97, 98, 103, 102};
    struct kalman_rows rows;
    for (int i = 0; i < 50; ++i) {
        push(x, 0x0F, &rows);
    }
    struct kalman_result est;
    kalman_estimate(&kf, 30000, &est);
    assert_true(est.alpha_observable && est.beta_observable);
    assert_true(abs(est.alpha_udeg - (int32_t)lround(atan(0.1) * 180e6 / TEST_PI)) <= 2);
    assert_true(abs(est.beta_udeg - (int32_t)lround(atan(-2.0 / 30) * 180e6 / TEST_PI)) <= 2);
    assert_true(fabs((double)est.distance_mm / Q32 - 100.0) < 1e-6);
}

/* Batch WLS of all accepted readings with equal R vs the filter (diffuse prior). */
static void test_matches_batch_least_squares(void **state) {
    (void)state;
    for (int trial = 0; trial < 200; ++trial) {
        struct kalman_config c = default_config();
        c.gate_sigmas_q8 = 0; /* compare pure filtering */
        const double sd[4] = {0.5 + 3 * urand(), 0.5 + 3 * urand(), 0.5 + 3 * urand(),
                              0.5 + 3 * urand()};
        for (unsigned s = 0; s < 4; ++s) {
            c.initial_noise_mm2[s] = (int64_t)llround(sd[s] * sd[s] * Q32);
        }
        assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
        const double arm = 30.0, al = (urand() - 0.5) * 10, be = (urand() - 0.5) * 10;
        const double xbar = 80 + 400 * urand();
        double x0[4];
        ideal(arm, xbar, al, be, x0);
        /* the information matrix and vector, accumulated in double */
        double m[3][4] = {{0}};
        static const double h[4][3] = {{1, -1, 0}, {1, 0, 1}, {1, 1, 0}, {1, 0, -1}};
        const int n = 20 + (int)(urand() * 200);
        struct kalman_rows rows;
        for (int i = 0; i < n; ++i) {
            double x[4];
            uint8_t valid = 0x0F;
            if (urand() < 0.1) {
                valid = (uint8_t)(valid & ~(1u << (int)(urand() * 4))); /* flagged */
            }
            for (unsigned s = 0; s < 4; ++s) {
                x[s] = round(x0[s] + sd[s] * gauss());
                if (valid & (1u << s)) {
                    for (unsigned a = 0; a < 3; ++a) {
                        for (unsigned b = 0; b < 3; ++b) {
                            m[a][b] += h[s][a] * h[s][b] / (sd[s] * sd[s]);
                        }
                        m[a][3] += h[s][a] * x[s] / (sd[s] * sd[s]);
                    }
                }
            }
            push(x, valid, &rows);
        }
        /* solve */
        double inv[3][3];
        const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        inv[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / det;
        inv[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det;
        inv[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det;
        inv[1][0] = inv[0][1];
        inv[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det;
        inv[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det;
        inv[2][0] = inv[0][2];
        inv[2][1] = inv[1][2];
        inv[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
        double th[3];
        for (unsigned a = 0; a < 3; ++a) {
            th[a] = inv[a][0] * m[0][3] + inv[a][1] * m[1][3] + inv[a][2] * m[2][3];
        }
        struct kalman_result est;
        kalman_estimate(&kf, 30000, &est);
        const double alpha_wls = atan(th[1] / arm) * 180e6 / TEST_PI;
        if (fabs(est.alpha_udeg - alpha_wls) > 5.0) {
            fail_msg("trial %d: kalman %d udeg, WLS %.1f", trial, est.alpha_udeg, alpha_wls);
        }
        assert_true(fabs(est.beta_udeg - atan(th[2] / arm) * 180e6 / TEST_PI) <= 5.0);
        assert_true(fabs((double)est.distance_mm / Q32 - th[0]) < 1e-4);
        /* covariance = inverse information (the prior adds < 1e-9 relative) */
        for (unsigned a = 0; a < 3; ++a) {
            for (unsigned b = 0; b < 3; ++b) {
                const double p = (double)est.p_mm2[a][b] / Q32;
                assert_true(fabs(p - inv[a][b]) < 1e-6 + 1e-5 * fabs(inv[a][a]));
                assert_true(est.p_mm2[a][b] == est.p_mm2[b][a]);
            }
        }
        assert_int_equal(kf.numeric_restarts, 0);
    }
}

/* Alg. 2 in double: the reference for the fixed-point filter, reading for reading. */
struct dkf {
    double x[3];
    double p[3][3];
};
static const double H[4][3] = {{1, -1, 0}, {1, 0, 1}, {1, 1, 0}, {1, 0, -1}};

static void dkf_init(struct dkf *d) {
    memset(d, 0, sizeof *d);
    for (unsigned a = 0; a < 3; ++a) {
        d->p[a][a] = (double)KALMAN_P0_MM2_Q32 / Q32;
    }
}

static void dkf_update(struct dkf *d, unsigned s, double z, double r) {
    double g[3];
    for (unsigned a = 0; a < 3; ++a) {
        g[a] = d->p[a][0] * H[s][0] + d->p[a][1] * H[s][1] + d->p[a][2] * H[s][2];
    }
    const double sv = g[0] * H[s][0] + g[1] * H[s][1] + g[2] * H[s][2] + r;
    const double e = z - (d->x[0] * H[s][0] + d->x[1] * H[s][1] + d->x[2] * H[s][2]);
    for (unsigned a = 0; a < 3; ++a) {
        d->x[a] += g[a] / sv * e;
        for (unsigned b = 0; b < 3; ++b) {
            d->p[a][b] -= g[a] * g[b] / sv;
        }
    }
}

/* The filter against double Alg. 2, reading for reading, at Q = 0 (every other trial; until
 * the information form's) and Q > 0 (its block updates and exact Joseph updates
 * mixed). Unequal noise, readings dropped at random, the B/D pair missing for the first 60
 * rows (the β axis is the prior alone) and again later, every R changed in mid-run. P
 * within 1e-6 relative + 16 LSB of Q32, the state within 1e-5 mm; in the steady state
 * (Q > 0: its gains kept once P settled within 2^-12 of its trace) P within 1e-3
 * relative, the state within 1e-3 mm. */
static void test_filter_matches_double(void **state) {
    (void)state;
    double worst_x[2] = {0, 0}, worst_p[2] = {0, 0}; /* Q = 0, Q > 0 */
    for (int trial = 0; trial < 40; ++trial) {
        const bool q_zero = (trial & 1) == 0;
        struct kalman_config c = default_config();
        c.gate_sigmas_q8 = 0;
        c.warmup_rows = 1;
        const fix_q32_t q = q_zero ? 0 : (int64_t)1 << 20;
        for (unsigned a = 0; a < 3; ++a) {
            c.process_noise_mm2[a] = q;
        }
        for (unsigned s = 0; s < 4; ++s) {
            const double sd = 0.3 + 6 * urand();
            c.initial_noise_mm2[s] = (int64_t)llround(sd * sd * Q32);
        }
        assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
        kf.started = true; /* straight into online updates from the diffuse prior */
        struct dkf d;
        dkf_init(&d);
        double x0[4];
        ideal(30, 100 + 300 * urand(), (urand() - 0.5) * 10, (urand() - 0.5) * 10, x0);
        for (int row = 0; row < 400; ++row) {
            if (row == 200) {
                for (unsigned s = 0; s < 4; ++s) { /* first tracking: R replaced */
                    const double sd = 0.2 + 8 * urand();
                    kalman_track_noise(&kf, s, (int64_t)llround(sd * sd * Q32), 100);
                }
            }
            for (unsigned a = 0; a < 3; ++a) {
                d.p[a][a] += (double)q / Q32;
            }
            const bool pair_gone = row < 60 || (row >= 100 && row < 160); /* B and D */
            uint16_t z[4] = {0, 0, 0, 0};
            uint8_t valid = 0;
            for (unsigned s = 0; s < 4; ++s) {
                if ((pair_gone && (s == 1 || s == 3)) || urand() < 0.05) {
                    continue;
                }
                const double v = round(x0[s] + 2 * gauss());
                z[s] = (uint16_t)(v < 0 ? 0 : v);
                valid = (uint8_t)(valid | (1u << s));
                dkf_update(&d, s, z[s], (double)kf.r[s] / Q32);
            }
            struct kalman_rows rows;
            kalman_push_row(&kf, z, valid, &rows);
            assert_int_equal(rows.count, 1);
            assert_int_equal(rows.used[0], valid);
            fix_q32_t p[3][3];
            kalman_covariance(&kf, p);
            for (unsigned a = 0; a < 3; ++a) {
                for (unsigned b = 0; b < 3; ++b) {
                    const double pf = (double)p[a][b] / Q32;
                    const double scale = sqrt(d.p[a][a] * d.p[b][b]);
                    const double rel = fabs(pf - d.p[a][b]) / (scale + 16.0 / Q32 * 1e6);
                    worst_p[!q_zero] = rel > worst_p[!q_zero] ? rel : worst_p[!q_zero];
                    /* a steady row (kalman_track.c) keeps the P that settled within 2^-12
                     * of its trace: 1e-3 of the scale then, 1e-6 otherwise */
                    const bool steady = !q_zero && kf.cov.steady;
                    const double tol_p = steady ? 1e-3 : 1e-6;
                    if (fabs(pf - d.p[a][b]) > tol_p * scale + 16.0 / Q32 || p[a][b] != p[b][a]) {
                        fail_msg("trial %d (%s) row %d P[%u][%u]: %.9g, double %.9g", trial,
                                 q_zero ? "Q = 0" : "Q > 0", row, a, b, pf, d.p[a][b]);
                    }
                }
                const double dxa = fabs((double)kf.x[a] / Q32 - d.x[a]);
                worst_x[!q_zero] = dxa > worst_x[!q_zero] ? dxa : worst_x[!q_zero];
                if (dxa > (!q_zero && kf.cov.steady ? 1e-3 : 1e-5)) {
                    fail_msg("trial %d (%s) row %d x[%u]: %.9f, double %.9f", trial,
                             q_zero ? "Q = 0" : "Q > 0", row, a, (double)kf.x[a] / Q32, d.x[a]);
                }
            }
        }
        assert_int_equal(kf.numeric_restarts, 0);
    }
    print_message("worst vs double: Q = 0 x %.2g mm, P %.2g rel; Q > 0 x %.2g mm, P %.2g rel\n",
                  worst_x[0], worst_p[0], worst_x[1], worst_p[1]);
}
/* A uniform run (every row all four readings, the same R) at Q = 0, started by the warm-up
 * as the facade starts it (prior mean = the first row's median), against Alg. 2 in double
 * with that prior, row for row. The run takes the static path (kalman_static.c: until
 * the information form's fast solve, asserted the same way). */
static void test_uniform_run_matches_double(void **state) {
    (void)state;
    double worst = 0;
    for (int trial = 0; trial < 40; ++trial) {
        struct kalman_config c = default_config();
        c.gate_sigmas_q8 = 0;
        c.warmup_rows = 1;
        for (unsigned s = 0; s < 4; ++s) {
            const double sd = 0.3 + 6 * urand();
            c.initial_noise_mm2[s] = (int64_t)llround(sd * sd * Q32);
        }
        assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
        struct dkf d;
        dkf_init(&d);
        double x0[4];
        ideal(30, 100 + 300 * urand(), (urand() - 0.5) * 20, (urand() - 0.5) * 20, x0);
        for (int row = 0; row < 300; ++row) {
            uint16_t z[4];
            for (unsigned s = 0; s < 4; ++s) {
                const double v = round(x0[s] + 2 * gauss());
                z[s] = (uint16_t)(v < 0 ? 0 : v);
            }
            struct kalman_rows rows;
            kalman_push_row(&kf, z, 0x0F, &rows);
            if (row == 0) { /* the warm-up's start: the median of one row, their mean */
                d.x[0] = ((double)z[0] + z[1] + z[2] + z[3]) / 4.0;
            }
            for (unsigned s = 0; s < 4; ++s) {
                dkf_update(&d, s, z[s], (double)kf.r[s] / Q32);
            }
            fix_q32_t p[3][3];
            kalman_covariance(&kf, p);
            for (unsigned a = 0; a < 3; ++a) {
                const double dxa = fabs((double)kf.x[a] / Q32 - d.x[a]);
                worst = dxa > worst ? dxa : worst;
                if (dxa > 1e-6) {
                    fail_msg("trial %d row %d x[%u]: %.9f, double %.9f", trial, row, a,
                             (double)kf.x[a] / Q32, d.x[a]);
                }
                for (unsigned b = 0; b < 3; ++b) {
                    const double scale = sqrt(d.p[a][a] * d.p[b][b]);
                    assert_true(fabs((double)p[a][b] / Q32 - d.p[a][b]) <
                                1e-6 * scale + 16.0 / Q32);
                }
            }
        }
        /* the run stayed uniform and took the static path from its first rows */
        assert_true(kf.cov.still && !kf.cov.still_broken);
    }
    print_message("uniform run vs double: x within %.2g mm\n", worst);
}

/* The static run (Q = 0) left and taken again, against Alg. 2 in double reading for
 * reading: a reading 40 mm off (beyond the static row's 32 mm: that row runs as four
 * scalar updates, and the run starts again after it), an R change (the run ends for good:
 * the rows so far were weighed with the old R), a missing reading. */
static void test_static_run_interrupted_matches_double(void **state) {
    (void)state;
    for (int trial = 0; trial < 20; ++trial) {
        struct kalman_config c = default_config();
        c.gate_sigmas_q8 = 0;
        c.warmup_rows = 1;
        for (unsigned s = 0; s < 4; ++s) {
            const double sd = 0.3 + 6 * urand();
            c.initial_noise_mm2[s] = (int64_t)llround(sd * sd * Q32);
        }
        assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
        struct dkf d;
        dkf_init(&d);
        double x0[4];
        ideal(30, 100 + 300 * urand(), (urand() - 0.5) * 20, (urand() - 0.5) * 20, x0);
        for (int row = 0; row < 200; ++row) {
            if (row == 120) {
                const double sd = 0.2 + 8 * urand();
                kalman_track_noise(&kf, 1, (int64_t)llround(sd * sd * Q32), 100);
            }
            uint16_t z[4];
            uint8_t valid = 0x0F;
            for (unsigned s = 0; s < 4; ++s) {
                const double v = round(x0[s] + 2 * gauss() + (row == 50 && s == 0 ? 40 : 0));
                z[s] = (uint16_t)(v < 0 ? 0 : v);
            }
            if (row == 160) {
                valid = 0x07; /* D missing */
            }
            struct kalman_rows rows;
            kalman_push_row(&kf, z, valid, &rows);
            if (row == 0) {
                d.x[0] = ((double)z[0] + z[1] + z[2] + z[3]) / 4.0;
            }
            for (unsigned s = 0; s < 4; ++s) {
                if ((valid & (1u << s)) != 0u) {
                    dkf_update(&d, s, z[s], (double)kf.r[s] / Q32);
                }
            }
            if (row == 49 || row == 60) {
                assert_true(kf.cov.still);
            }
            if (row == 120) {
                assert_false(kf.cov.still);
            }
            fix_q32_t p[3][3];
            kalman_covariance(&kf, p);
            for (unsigned a = 0; a < 3; ++a) {
                if (fabs((double)kf.x[a] / Q32 - d.x[a]) > 1e-5) {
                    fail_msg("trial %d row %d x[%u]: %.9f, double %.9f", trial, row, a,
                             (double)kf.x[a] / Q32, d.x[a]);
                }
                for (unsigned b = 0; b < 3; ++b) {
                    const double scale = sqrt(d.p[a][a] * d.p[b][b]);
                    assert_true(fabs((double)p[a][b] / Q32 - d.p[a][b]) <
                                1e-6 * scale + 16.0 / Q32);
                }
            }
        }
        assert_int_equal(kf.numeric_restarts, 0);
    }
}

/* Data far from the model in a uniform run: a pair of very unequal weights (R_A = 200 mm²,
 * the rest 1 mm²) and A + C far from B + D make δθ_α about 249 mm with every mean within
 * 127 mm of the start (found by review of the information form's fast solve, which wrapped
 * to −7 mm; the block update's 128 mm bound on e is the same kind of edge). */
static void test_large_slopes_match_double(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    c.gate_sigmas_q8 = 0;
    c.warmup_rows = 1;
    c.initial_noise_mm2[0] = (int64_t)200 << 32;
    for (unsigned s = 1; s < 4; ++s) {
        c.initial_noise_mm2[s] = (int64_t)1 << 32;
    }
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    struct dkf d;
    dkf_init(&d);
    const uint16_t z[4] = {1127, 873, 1127, 873};
    for (int row = 0; row < 5; ++row) {
        struct kalman_rows rows;
        kalman_push_row(&kf, z, 0x0F, &rows);
        if (row == 0) {
            d.x[0] = 1000.0; /* the warm-up's start, the mean of the row's medians */
        }
        for (unsigned s = 0; s < 4; ++s) {
            dkf_update(&d, s, z[s], (double)kf.r[s] / Q32);
        }
        for (unsigned a = 0; a < 3; ++a) {
            assert_true(fabs((double)kf.x[a] / Q32 - d.x[a]) < 1e-5);
        }
    }
    assert_true(fabs((double)kf.x[1] / Q32 - 248.995) < 1e-3);
}

/* kalman_update before the warm-up has started the filter: not used, and said so. */
static void test_update_before_start_refused(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    assert_false(kalman_update(&kf, 0, 1000, false));
    struct kalman_rows rows;
    const uint16_t z[4] = {1000, 1000, 1000, 1000};
    for (int row = 0; row < 3; ++row) {
        kalman_push_row(&kf, z, 0x0F, &rows); /* warm-up: 3 rows */
    }
    assert_true(kf.started);
    assert_true(kalman_update(&kf, 0, 1000, true));
    assert_true(fabs((double)kf.x[0] / Q32 - 1000.0) < 1e-6);
}

/* Readings 65 m from a prior mean of 0, 40 000 rows of a static run (once the
 * information form's sums near their headroom, which halved several times: that assertion
 * went with them); the state and P follow Alg. 2 in double. P comes from the static run's
 * closed form: as four scalar updates in Q32 it would carry each row's rounding, 4e-3 of
 * the scale after these rows (P_00 1.3e5 LSB, a row takes 3 LSB off it). */
static void test_far_readings_long_run_match_double(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    c.gate_sigmas_q8 = 0;
    c.warmup_rows = 1;
    c.initial_noise_mm2[2] = (int64_t)9 << 32; /* unequal weights */
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    kf.started = true; /* prior mean 0: every deviation is the reading itself */
    struct dkf d;
    dkf_init(&d);
    static const uint16_t base[4] = {65000, 65300, 65500, 65200};
    for (int row = 0; row < 40000; ++row) {
        uint16_t z[4];
        for (unsigned s = 0; s < 4; ++s) {
            z[s] = (uint16_t)(base[s] + (unsigned)(row * 7 + (int)s * 13) % 31u);
            dkf_update(&d, s, z[s], (double)kf.r[s] / Q32);
        }
        struct kalman_rows rows;
        kalman_push_row(&kf, z, 0x0F, &rows);
    }
    assert_true(kf.cov.still); /* the static run */
    fix_q32_t p[3][3];
    kalman_covariance(&kf, p);
    double worst_p = 0;
    for (unsigned a = 0; a < 3; ++a) {
        assert_true(fabs((double)kf.x[a] / Q32 - d.x[a]) < 1e-4);
        for (unsigned b = 0; b < 3; ++b) {
            const double scale = sqrt(d.p[a][a] * d.p[b][b]);
            const double dp = fabs((double)p[a][b] / Q32 - d.p[a][b]);
            worst_p = dp / scale > worst_p ? dp / scale : worst_p;
            assert_true(dp < 1e-5 * scale + 16.0 / Q32);
        }
    }
    print_message("x within %.2g mm of double, P within %.2g of the scale\n",
                  fabs((double)kf.x[0] / Q32 - d.x[0]), worst_p);
}

static void test_long_run_stays_positive_definite(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    c.process_noise_mm2[0] = (int64_t)1 << 20; /* small Q keeps P from collapsing */
    c.process_noise_mm2[1] = (int64_t)1 << 18;
    c.process_noise_mm2[2] = (int64_t)1 << 18;
    c.initial_noise_mm2[3] = (int64_t)1 << 30; /* 0.25 mm² */
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    double x0[4];
    ideal(30, 500, 2, -3, x0);
    struct kalman_rows rows;
    for (int i = 0; i < 100000; ++i) {
        double x[4];
        for (unsigned s = 0; s < 4; ++s) {
            x[s] = x0[s] + 2 * gauss();
        }
        push(x, (uint8_t)(1 + (int)(urand() * 15)), &rows); /* random subsets */
        for (unsigned a = 0; a < 3; ++a) {
            assert_true(kf.cov.p[a][a] > 0);
            for (unsigned b = 0; b < 3; ++b) {
                assert_true(kf.cov.p[a][b] == kf.cov.p[b][a]);
            }
        }
    }
    assert_int_equal(kf.numeric_restarts, 0);
    /* leading principal minors of P (double) are positive */
    double p[3][3];
    for (unsigned a = 0; a < 3; ++a) {
        for (unsigned b = 0; b < 3; ++b) {
            p[a][b] = (double)kf.cov.p[a][b] / Q32;
        }
    }
    assert_true(p[0][0] * p[1][1] - p[0][1] * p[1][0] > 0);
    const double det = p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) -
                       p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                       p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]);
    assert_true(det > 0);
}

static void test_flagged_skipped_and_outliers_gated(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    double x0[4];
    ideal(30, 200, 1, 0, x0);
    struct kalman_rows rows;
    int used_b = 0, rejected_b = 0;
    for (int i = 0; i < 100; ++i) {
        double x[4];
        for (unsigned s = 0; s < 4; ++s) {
            x[s] = x0[s] + 2 * gauss();
        }
        uint8_t valid = 0x0F;
        if (i % 10 == 5) {
            x[1] += 40; /* gross outlier, valid status */
        }
        if (i % 10 == 7) {
            valid = 0x0B; /* C flagged */
        }
        push(x, valid, &rows);
        for (unsigned r = 0; r < rows.count; ++r) {
            used_b += (rows.used[r] >> 1) & 1;
            rejected_b += (rows.rejected[r] >> 1) & 1;
            assert_false(rows.used[r] & rows.rejected[r]);
        }
        if (i % 10 == 7 && rows.count == 1) {
            assert_false(rows.used[0] & 0x04);
            assert_false(rows.rejected[0] & 0x04); /* flagged is skipped, not rejected */
        }
    }
    assert_int_equal(rejected_b, 10);
    assert_int_equal(used_b, 90);
    struct kalman_result est;
    kalman_estimate(&kf, 30000, &est);
    assert_true(abs(est.alpha_udeg - 1000000) < 5 * est.alpha_sigma_udeg + 1);
}

static void test_warmup_outlier_in_first_rows(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    struct kalman_rows rows;
    const double good[4] = {97, 100, 103, 100};
    double bad[4] = {97, 100, 103, 100};
    bad[0] += 60; /* row 0: A is a gross outlier, before any gate could work */
    push(bad, 0x0F, &rows);
    assert_int_equal(rows.count, 0); /* buffered */
    push(good, 0x0F, &rows);
    assert_int_equal(rows.count, 0);
    push(good, 0x0F, &rows);
    assert_int_equal(rows.count, 3); /* the warm-up flush */
    assert_int_equal(rows.rejected[0], 0x01);
    assert_int_equal(rows.used[0], 0x0E);
    assert_int_equal(rows.used[1], 0x0F);
    struct kalman_result est;
    kalman_estimate(&kf, 30000, &est);
    assert_true(abs(est.alpha_udeg - 5710593) <= 2);
}

static void test_lockout_restart_after_jump(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    struct kalman_rows rows;
    const double before[4] = {97, 100, 103, 100};
    const double after[4] = {297, 300, 303, 300};
    for (int i = 0; i < 30; ++i) {
        push(before, 0x0F, &rows);
    }
    for (int i = 0; i < 30; ++i) {
        push(after, 0x0F, &rows);
    }
    assert_true(kf.restarts >= 1);
    struct kalman_result est;
    kalman_estimate(&kf, 30000, &est);
    assert_true(fabs((double)est.distance_mm / Q32 - 300.0) < 1e-3);
}

static void test_missing_sensors_observability(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    const double x[4] = {97, 98, 103, 102};
    struct kalman_rows rows;
    struct kalman_result est;
    /* one sensor missing: still both axes */
    for (unsigned miss = 0; miss < 4; ++miss) {
        assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
        for (int i = 0; i < 20; ++i) {
            push(x, (uint8_t)(0x0F & ~(1u << miss)), &rows);
        }
        kalman_estimate(&kf, 30000, &est);
        assert_true(est.alpha_observable && est.beta_observable);
        assert_true(abs(est.alpha_udeg - 5710593) <= 2);
    }
    /* A and C missing: α unobservable */
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    for (int i = 0; i < 20; ++i) {
        push(x, 0x0A, &rows);
    }
    kalman_estimate(&kf, 30000, &est);
    assert_false(est.alpha_observable);
    assert_true(est.beta_observable);
    /* A and B missing: neither */
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    for (int i = 0; i < 20; ++i) {
        push(x, 0x0C, &rows);
    }
    kalman_estimate(&kf, 30000, &est);
    assert_false(est.alpha_observable);
    assert_false(est.beta_observable);
    /* nothing valid: not started or no information */
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    for (int i = 0; i < 5; ++i) {
        push(x, 0x00, &rows);
    }
    kalman_estimate(&kf, 30000, &est);
    assert_false(est.alpha_observable);
}

static void test_noise_tracking(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    const int64_t nine = (int64_t)9 << 32;
    assert_false(kalman_track_noise(&kf, 2, nine, 1)); /* fewer than 2 readings: ignored */
    assert_true(kf.r[2] == (int64_t)4 << 32);
    /* first: replaces the guess, 9 against 4 mm²: more than twice it, said */
    assert_true(kalman_track_noise(&kf, 2, nine, 100));
    assert_true(kf.r[2] == nine);
    /* then 1/4 of the way, never said (the guess is gone) */
    assert_false(kalman_track_noise(&kf, 2, (int64_t)13 << 32, 100));
    assert_true(kf.r[2] == (int64_t)10 << 32);
    /* zero variance: the 1/12 mm² floor; a guess too large is not said */
    assert_false(kalman_track_noise(&kf, 1, 0, 100));
    assert_true(kf.r[1] == 357913941);
    /* a first variance within 2x of the guess (6 against 4 mm²): replaced, not said */
    assert_false(kalman_track_noise(&kf, 0, (int64_t)6 << 32, 100));
    assert_true(kf.r[0] == (int64_t)6 << 32);
    /* from 8 to 31 readings it takes 4x: 12 mm² of 20 readings is not said, 17 of 8 is */
    assert_false(kalman_track_noise(&kf, 3, (int64_t)12 << 32, 20));
    struct kalman_config c2 = default_config();
    assert_int_equal(kalman_init(&kf, &c2), KALMAN_OK);
    assert_true(kalman_track_noise(&kf, 3, (int64_t)17 << 32, 8));
    assert_int_equal(kalman_init(&kf, &c2), KALMAN_OK);
    assert_false(kalman_track_noise(&kf, 3, (int64_t)100 << 32, 7)); /* 7: never */
    assert_int_equal(kalman_init(&kf, &c2), KALMAN_OK);
    assert_true(kalman_track_noise(&kf, 2, nine, 100));
    kalman_track_noise(&kf, 2, (int64_t)13 << 32, 100);
    kalman_reset(&kf); /* a window reset keeps what was learned */
    assert_true(kf.r[2] == (int64_t)10 << 32);
}

static void test_process_noise_follows_a_ramp(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    c.process_noise_mm2[1] = (int64_t)1 << 28; /* (0.25 mm)² per row on a·tan α */
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    struct kalman_rows rows;
    for (int i = 0; i < 400; ++i) {
        double x[4];
        ideal(30, 150, -5 + 0.025 * i, 0, x);
        push(x, 0x0F, &rows);
    }
    struct kalman_result est;
    kalman_estimate(&kf, 30000, &est);
    /* 1 mm quantisation of a noise-free ramp alone moves the readings' own angle
     * by up to atan(1/60) = 0.95°; the filter stays within half a degree */
    assert_true(abs(est.alpha_udeg - 4975000) < 500000);
    /* with Q = 0 the same ramp is averaged, far behind */
    c.process_noise_mm2[1] = 0;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    for (int i = 0; i < 400; ++i) {
        double x[4];
        ideal(30, 150, -5 + 0.025 * i, 0, x);
        push(x, 0x0F, &rows);
    }
    kalman_estimate(&kf, 30000, &est);
    assert_true(abs(est.alpha_udeg - 4975000) > 3000000); /* about the ramp's mean */
}

static void test_extreme_noise_and_long_outage(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    c.process_noise_mm2[0] = KALMAN_P0_MM2_Q32; /* the largest Q accepted */
    c.process_noise_mm2[1] = KALMAN_P0_MM2_Q32;
    c.process_noise_mm2[2] = KALMAN_P0_MM2_Q32;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    /* a window of 0 and 65535 mm readings: variance 2^30 mm², beyond any usable R */
    kalman_track_noise(&kf, 0, (int64_t)1 << 62, 100);
    assert_true(kf.r[0] == (int64_t)1 << 52); /* bounded like a configured R (σ 1024 mm) */
    struct kalman_rows rows;
    const double x[4] = {97, 100, 103, 100};
    for (int i = 0; i < 10; ++i) {
        push(x, 0x0F, &rows);
    }
    /* a long outage under maximal process noise: P grows but never overflows */
    for (int i = 0; i < 100000; ++i) {
        push(x, 0x00, &rows);
    }
    for (unsigned a = 0; a < 3; ++a) {
        assert_true(kf.cov.p[a][a] > 0);
        assert_true(kf.cov.p[a][a] <= KALMAN_P0_MM2_Q32 << 4);
    }
    /* and the readings coming back are used again */
    const uint16_t r[4] = {0, 65535, 65535, 0};
    kalman_push_row(&kf, r, 0x0F, &rows);
    push(x, 0x0F, &rows);
    assert_int_equal(kf.numeric_restarts, 0);
    struct kalman_result est;
    kalman_estimate(&kf, 30000, &est);
    assert_true(est.alpha_udeg >= -FIX_UDEG_90 && est.alpha_udeg <= FIX_UDEG_90);
}

static void test_flush_short_window(void **state) {
    (void)state;
    struct kalman_config c = default_config();
    c.warmup_rows = 5;
    assert_int_equal(kalman_init(&kf, &c), KALMAN_OK);
    struct kalman_rows rows;
    const double x[4] = {97, 100, 103, 100};
    push(x, 0x0F, &rows);
    push(x, 0x0F, &rows);
    assert_int_equal(rows.count, 0);
    kalman_flush(&kf, &rows);
    assert_int_equal(rows.count, 2);
    struct kalman_result est;
    kalman_estimate(&kf, 30000, &est);
    assert_true(est.alpha_observable);
    assert_true(abs(est.alpha_udeg - 5710593) <= 2);
    kalman_flush(&kf, &rows); /* nothing left */
    assert_int_equal(rows.count, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_config_errors),
        cmocka_unit_test(test_noise_free_plate_is_exact),
        cmocka_unit_test(test_matches_batch_least_squares),
        cmocka_unit_test(test_filter_matches_double),
        cmocka_unit_test(test_uniform_run_matches_double),
        cmocka_unit_test(test_static_run_interrupted_matches_double),
        cmocka_unit_test(test_large_slopes_match_double),
        cmocka_unit_test(test_update_before_start_refused),
        cmocka_unit_test(test_far_readings_long_run_match_double),
        cmocka_unit_test(test_long_run_stays_positive_definite),
        cmocka_unit_test(test_flagged_skipped_and_outliers_gated),
        cmocka_unit_test(test_warmup_outlier_in_first_rows),
        cmocka_unit_test(test_lockout_restart_after_jump),
        cmocka_unit_test(test_missing_sensors_observability),
        cmocka_unit_test(test_noise_tracking),
        cmocka_unit_test(test_process_noise_follows_a_ramp),
        cmocka_unit_test(test_extreme_noise_and_long_outage),
        cmocka_unit_test(test_flush_short_window),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
