/*
 * estimator/window_stats: exact sums, means and 5×5 covariances against a
 * direct computation, sliding windows that never drift, the MAD gate, and the
 * hazards (all-equal readings, missing and flagged sensors, 0 and 65535 mm,
 * negative and zero covariances).
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

#include "estimator/window_stats.h"

static struct window_state win;   /* large: keep off the stack */
static struct window_state other; /* a second window for comparisons */
static struct window_stats st;
static struct window_stats st2;

static double q32(int64_t v) {
    return (double)v / 4294967296.0;
}
static double q16(int64_t v) {
    return (double)v / 65536.0;
}

static uint32_t rng = 1u;
static int rnd(int n) {
    rng = rng * 1103515245u + 12345u;
    return (int)((rng >> 8) % (uint32_t)n);
}
/* roughly Gaussian integer noise, sd ~ 2 */
static int noise2(void) {
    int s = 0;
    for (int i = 0; i < 12; ++i) {
        s += rnd(1001);
    }
    return (int)lround((s - 6000) / 500.0);
}

static void init(struct window_state *w, uint16_t n, uint16_t gate_q8) {
    const struct window_config cfg = {
        .arm_um = 30000, .length = n, .gate_sigmas_q8 = gate_q8, .gate_floor_mm = 3};
    assert_int_equal(window_init(w, &cfg), WINDOW_OK);
}

/* Direct two-pass statistics of the complete rows of w, from the same integer angles. */
static void check_against_direct(struct window_state *w, const struct window_stats *s) {
    double sum[2][5] = {{0}}, prod[2][5][5] = {{{0}}};
    int n = 0;
    double sensor_sum[4] = {0}, sensor_sq[4] = {0};
    int sensor_n[4] = {0};
    for (uint16_t age = 0; age < window_fill(w); ++age) {
        const struct window_row *row = window_row_at(w, age);
        for (unsigned k = 0; k < 4; ++k) {
            if (window_row_valid(row) & (1u << k)) {
                sensor_sum[k] += row->range_mm[k];
                sensor_sq[k] += (double)row->range_mm[k] * row->range_mm[k];
                sensor_n[k]++;
            }
        }
        if (window_row_valid(row) != 0x0F) {
            continue;
        }
        struct angles_sample a;
        angles_compute(row->range_mm, window_row_valid(row), w->cfg.arm_um, &a);
        for (unsigned i = 0; i < 5; ++i) {
            sum[0][i] += a.alpha_udeg[i];
            sum[1][i] += a.beta_udeg[i];
            for (unsigned j = 0; j < 5; ++j) {
                prod[0][i][j] += (double)a.alpha_udeg[i] * a.alpha_udeg[j];
                prod[1][i][j] += (double)a.beta_udeg[i] * a.beta_udeg[j];
            }
        }
        n++;
    }
    assert_int_equal(s->complete, n);
    const struct window_axis_stats *ax[2] = {&s->alpha, &s->beta};
    for (unsigned a = 0; a < 2; ++a) {
        for (unsigned i = 0; i < 5; ++i) {
            if (n == 0) {
                continue;
            }
            const double m = sum[a][i] / n;
            assert_true(fabs(q16(ax[a]->complete_mean[i]) - m) <= 1.0 / 65536.0);
            for (unsigned j = 0; j < 5; ++j) {
                if (n < 2) {
                    assert_true(ax[a]->cov[i][j] == 0);
                    continue;
                }
                const double c = (prod[a][i][j] - sum[a][i] * sum[a][j] / n) / (n - 1);
                /* double itself carries ~1e-16 relative error of the sums (~1e18) */
                const double tol = 0.5 + 1e-15 * fabs(prod[a][i][j]);
                if (fabs((double)ax[a]->cov[i][j] - c) > tol) {
                    fail_msg("axis %u cov[%u][%u] = %lld, direct %.3f", a, i, j,
                             (long long)ax[a]->cov[i][j], c);
                }
                assert_true(ax[a]->cov[i][j] == ax[a]->cov[j][i]);
            }
        }
    }
    for (unsigned k = 0; k < 4; ++k) {
        assert_int_equal(s->sensor[k].used, sensor_n[k]);
        if (sensor_n[k] > 0) {
            const double m = sensor_sum[k] / sensor_n[k];
            assert_true(fabs(q32(s->sensor[k].mean_mm) - m) < 1e-9);
        }
        if (sensor_n[k] > 1) {
            const double v =
                (sensor_sq[k] - sensor_sum[k] * sensor_sum[k] / sensor_n[k]) / (sensor_n[k] - 1);
            assert_true(fabs(q32(s->sensor[k].var_mm2) - v) < 1e-6 * (1.0 + v));
        }
    }
}

static void push_plate(struct window_state *w, int xa, int xb, int xc, int xd, uint8_t present,
                       uint8_t valid) {
    const uint16_t r[4] = {(uint16_t)xa, (uint16_t)xb, (uint16_t)xc, (uint16_t)xd};
    window_push(w, r, present, valid);
}

static void test_init_errors(void **state) {
    (void)state;
    struct window_config cfg = {.arm_um = 30000, .length = 100, .gate_sigmas_q8 = 0};
    assert_int_equal(window_init(&win, &cfg), WINDOW_OK);
    cfg.arm_um = 999;
    assert_int_equal(window_init(&win, &cfg), WINDOW_ERR_ARM);
    cfg.arm_um = 30000;
    cfg.length = 1;
    assert_int_equal(window_init(&win, &cfg), WINDOW_ERR_LENGTH);
    cfg.length = WINDOW_MAX_SAMPLES + 1u;
    assert_int_equal(window_init(&win, &cfg), WINDOW_ERR_LENGTH);
    cfg.length = WINDOW_MAX_SAMPLES;
    assert_int_equal(window_init(&win, &cfg), WINDOW_OK);
    assert_true(WINDOW_MAX_SAMPLES >= 255u);
}

static void test_pair_index(void **state) {
    (void)state;
    unsigned seen = 0;
    for (unsigned i = 0; i < 5; ++i) {
        for (unsigned j = i; j < 5; ++j) {
            const unsigned p = window_pair_index(i, j);
            assert_true(p < WINDOW_PAIRS);
            assert_int_equal(p, window_pair_index(j, i));
            assert_false(seen & (1u << p));
            seen |= 1u << p;
        }
    }
    assert_int_equal(seen, (1u << WINDOW_PAIRS) - 1u);
}

static void test_tumbling_stats_match_direct(void **state) {
    (void)state;
    init(&win, 100, 0);
    for (int r = 0; r < 100; ++r) {
        push_plate(&win, 97 + noise2(), 100 + noise2(), 103 + noise2(), 100 + noise2(), 0x0F, 0x0F);
    }
    window_compute(&win, &st);
    assert_int_equal(st.rows, 100);
    check_against_direct(&win, &st);
    /* α5 has a quarter of α1's variance for equal noise (slope (x_C − x_A)/2a) */
    assert_true(st.alpha.cov[4][4] * 3 < st.alpha.cov[0][0]);
}

static void test_sliding_never_drifts(void **state) {
    (void)state;
    init(&win, 37, 0);
    for (int r = 0; r < 5000; ++r) {
        const uint8_t valid = (uint8_t)(rnd(10) == 0 ? rnd(16) : 0x0F);
        const uint8_t present = (uint8_t)(rnd(20) == 0 ? (valid & ~(1u << rnd(4))) : 0x0F);
        push_plate(&win, 1000 + rnd(4000), rnd(65536), 65535 - rnd(3), rnd(3), present,
                   (uint8_t)(valid & present));
    }
    /* a fresh window fed the same last 37 rows has identical sums */
    init(&other, 37, 0);
    for (uint16_t age = 37; age-- > 0;) {
        const struct window_row *row = window_row_at(&win, age);
        window_push(&other, row->range_mm, window_row_present(row), window_row_valid(row));
    }
    assert_memory_equal(&win.sums, &other.sums, sizeof win.sums);
    window_compute(&win, &st);
    check_against_direct(&win, &st);
}

static void test_gate_rejects_gross_outliers_only(void **state) {
    (void)state;
    init(&win, 100, 5 * 256);
    init(&other, 100, 5 * 256);
    for (int r = 0; r < 100; ++r) {
        int xa = 97 + noise2(), xb = 100 + noise2(), xc = 103 + noise2(), xd = 100 + noise2();
        const int out = (r % 25 == 3) ? 20 + rnd(60) : 0; /* 4 outliers on B, valid status */
        push_plate(&win, xa, xb + out, xc, xd, 0x0F, 0x0F);
        /* the same data with the outliers flagged instead */
        push_plate(&other, xa, xb + out, xc, xd, 0x0F, out != 0 ? 0x0D : 0x0F);
    }
    window_compute(&win, &st);
    window_compute(&other, &st2);
    assert_int_equal(st.sensor[1].rejected, 4);
    assert_int_equal(st.sensor[1].used, 96);
    assert_int_equal(st2.sensor[1].flagged, 4);
    for (unsigned k = 0; k < 4; ++k) {
        if (k != 1) {
            assert_int_equal(st.sensor[k].rejected, 0);
        }
        assert_true(st.sensor[k].mean_mm == st2.sensor[k].mean_mm);
        assert_true(st.sensor[k].var_mm2 == st2.sensor[k].var_mm2);
    }
    assert_memory_equal(&st.alpha, &st2.alpha, sizeof st.alpha);
    assert_memory_equal(&st.beta, &st2.beta, sizeof st.beta);
    assert_int_equal(st.complete, 96);
    /* the median of B is ~100 mm (x2 = 200) and the half width 5 · 1.4826 · (MAD + 1/2 mm)
     * · 108/100, about 20 mm at this noise (σ ≈ 3 mm), short of the smallest outlier */
    assert_true(abs(st.sensor[1].median_x2_mm - 200) <= 4);
    assert_true(st.sensor[1].gate_x2_mm >= 6 && st.sensor[1].gate_x2_mm <= 40);
    check_against_direct(&other, &st2); /* the flagged twin, checked directly */
}

static int cmp_int(const void *a, const void *b) {
    const int x = *(const int *)a;
    const int y = *(const int *)b;
    return (x > y) - (x < y);
}

/* The gate's median and MAD against sorting, in both of its forms: readings spanning fewer
 * than 256 values (counted into a histogram) and wider ones or more than 255 (bisection),
 * over sliding windows of random lengths with flagged readings. */
static void test_gate_median_mad_against_sorting(void **state) {
    (void)state;
    static int vals[WINDOW_MAX_SAMPLES];
    static int devs[WINDOW_MAX_SAMPLES];
    const uint32_t saved_rng = rng; /* the later tests' data stay as they were */
    for (int trial = 0; trial < 3000; ++trial) {
        const uint16_t n = (uint16_t)(2 + rnd(WINDOW_MAX_SAMPLES - 1));
        init(&win, n, (uint16_t)(256 + rnd(2000)));
        const int spread = trial % 3 == 0 ? 1 + rnd(40) : (trial % 3 == 1 ? 200 + rnd(100) : 2000);
        const int rows = n + rnd(60);
        for (int r = 0; r < rows; ++r) {
            const uint8_t valid = (uint8_t)(rnd(12) == 0 ? rnd(16) : 0x0F);
            push_plate(&win, 5000 + rnd(spread), 5000 + rnd(spread), 5000 + rnd(spread),
                       60000 + rnd(spread), 0x0F, valid);
        }
        window_compute(&win, &st);
        for (unsigned k = 0; k < 4; ++k) {
            int m = 0;
            for (uint16_t age = 0; age < window_fill(&win); ++age) {
                const struct window_row *row = window_row_at(&win, age);
                if (window_row_valid(row) & (1u << k)) {
                    vals[m++] = row->range_mm[k];
                }
            }
            if (m == 0) {
                assert_int_equal(st.sensor[k].gate_x2_mm, 0);
                continue;
            }
            qsort(vals, (size_t)m, sizeof vals[0], cmp_int);
            const int med2 = vals[(m - 1) / 2] + vals[m / 2];
            assert_int_equal(st.sensor[k].median_x2_mm, med2);
            for (int i = 0; i < m; ++i) {
                devs[i] = abs(2 * vals[i] - med2);
            }
            qsort(devs, (size_t)m, sizeof devs[0], cmp_int);
            const int64_t mad2 = devs[(m - 1) / 2];
            /* (MAD + 1/2 mm) (m + 8)/m, in Q8: whole-mm readings, a short window's scatter */
            const int64_t mad_n = ((mad2 + 1) * (m + 8) * 256) / m;
            const int64_t scaled = (mad_n * 97163 * win.cfg.gate_sigmas_q8) >> 32;
            const int64_t floor2 = 2 * (int64_t)win.cfg.gate_floor_mm;
            assert_int_equal(st.sensor[k].gate_x2_mm, scaled > floor2 ? scaled : floor2);
        }
    }
    rng = saved_rng;
}

static void test_all_equal_readings_zero_variance(void **state) {
    (void)state;
    init(&win, 50, 5 * 256);
    for (int r = 0; r < 50; ++r) {
        push_plate(&win, 97, 100, 103, 100, 0x0F, 0x0F);
    }
    window_compute(&win, &st);
    for (unsigned k = 0; k < 4; ++k) {
        assert_true(st.sensor[k].var_mm2 == 0);
        assert_int_equal(st.sensor[k].rejected, 0);
        assert_int_equal(st.sensor[k].used, 50);
        /* MAD is 0 on whole-mm readings: the noise's may be up to 1/2 mm, so the gate is
         * 5 · 1.4826 · 1/2 mm · 58/50 = 4.3 mm (x2 = 8, floored), above the floor's 3 */
        assert_int_equal(st.sensor[k].gate_x2_mm, 8);
    }
    for (unsigned i = 0; i < 5; ++i) {
        for (unsigned j = 0; j < 5; ++j) {
            assert_true(st.alpha.cov[i][j] == 0);
            assert_true(st.beta.cov[i][j] == 0);
        }
    }
    assert_int_equal(st.residual_um, 0);
    assert_true(st.residual_valid);
}

static void test_negative_and_zero_covariances(void **state) {
    (void)state;
    /* only B moves: α1 = atan((B − A)/a) and α3 = atan((C − B)/a) anti-correlate,
     * α2, α4, α5 do not involve B and are constant: zero covariances */
    init(&win, 100, 0);
    for (int r = 0; r < 100; ++r) {
        push_plate(&win, 100, 100 + noise2(), 100, 100, 0x0F, 0x0F);
    }
    window_compute(&win, &st);
    assert_true(st.alpha.cov[0][2] < 0);
    assert_true(st.alpha.cov[0][0] > 0);
    assert_true(st.alpha.cov[0][3] == 0);
    assert_true(st.alpha.cov[1][1] == 0);
    assert_true(st.alpha.cov[4][4] == 0);
    check_against_direct(&win, &st);
}

static void test_missing_and_flagged_sensors(void **state) {
    (void)state;
    init(&win, 40, 5 * 256);
    for (int r = 0; r < 40; ++r) {
        /* B never present, D flagged every other row */
        const uint8_t valid = (uint8_t)((r % 2) ? 0x05 : 0x0D);
        push_plate(&win, 97 + noise2(), 0, 103 + noise2(), 100 + noise2(), 0x0D, valid);
    }
    window_compute(&win, &st);
    assert_int_equal(st.sensor[1].missing, 40);
    assert_int_equal(st.sensor[1].used, 0);
    assert_int_equal(st.sensor[3].flagged, 20);
    assert_int_equal(st.sensor[3].used, 20);
    assert_int_equal(st.complete, 0);
    assert_false(st.residual_valid);
    /* α5 (A, C) from all 40 rows, α2 (A, D) from 20, α1 (A, B) from none */
    assert_int_equal(st.alpha.count[4], 40);
    assert_int_equal(st.alpha.count[1], 20);
    assert_int_equal(st.alpha.count[0], 0);
    assert_true(st.alpha.mean[0] == 0);
    assert_true(st.alpha.cov[4][4] == 0); /* no complete rows: no covariance */

    /* two sensors missing: nothing but counts */
    init(&win, 10, 5 * 256);
    for (int r = 0; r < 10; ++r) {
        push_plate(&win, 97, 0, 0, 100, 0x09, 0x09);
    }
    window_compute(&win, &st);
    assert_int_equal(st.sensor[1].missing, 10);
    assert_int_equal(st.sensor[2].missing, 10);
    assert_int_equal(st.alpha.count[4], 0);
    assert_int_equal(st.beta.count[0], 10); /* β1 = atan((x_A − x_D)/a) */
}

static void test_extreme_ranges(void **state) {
    (void)state;
    init(&win, WINDOW_MAX_SAMPLES, 0);
    for (unsigned r = 0; r < WINDOW_MAX_SAMPLES; ++r) {
        const int hi = (r % 2) ? 65535 : 0;
        push_plate(&win, hi, 65535 - hi, hi, 65535 - hi, 0x0F, 0x0F);
    }
    window_compute(&win, &st);
    const double n = WINDOW_MAX_SAMPLES;
    const double var = 65535.0 * 65535.0 / 4.0 * n / (n - 1);
    for (unsigned k = 0; k < 4; ++k) {
        assert_true(fabs(q32(st.sensor[k].var_mm2) - var) < 1e-6);
        assert_true(fabs(q32(st.sensor[k].mean_mm) - 32767.5) < 1e-9);
    }
    check_against_direct(&win, &st);
    /* near ±90°: α1 = atan(±65535/30) */
    assert_true(st.alpha.cov[0][0] > (int64_t)8e15);
    assert_int_equal(st.residual_um, 0);
}

static void test_gate_with_zero_and_max_readings(void **state) {
    (void)state;
    /* a sensor stuck at 0 or 65535 among normal readings is gated out */
    init(&win, 20, 5 * 256);
    for (int r = 0; r < 20; ++r) {
        const int xb = r == 5 ? 0 : (r == 9 ? 65535 : 1000 + noise2());
        push_plate(&win, 1000 + noise2(), xb, 1000 + noise2(), 1000 + noise2(), 0x0F, 0x0F);
    }
    window_compute(&win, &st);
    assert_int_equal(st.sensor[1].rejected, 2);
    assert_true(fabs(q32(st.sensor[1].mean_mm) - 1000.0) < 3.0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_init_errors),
        cmocka_unit_test(test_pair_index),
        cmocka_unit_test(test_tumbling_stats_match_direct),
        cmocka_unit_test(test_sliding_never_drifts),
        cmocka_unit_test(test_gate_rejects_gross_outliers_only),
        cmocka_unit_test(test_gate_median_mad_against_sorting),
        cmocka_unit_test(test_all_equal_readings_zero_variance),
        cmocka_unit_test(test_negative_and_zero_covariances),
        cmocka_unit_test(test_missing_and_flagged_sensors),
        cmocka_unit_test(test_extreme_ranges),
        cmocka_unit_test(test_gate_with_zero_and_max_readings),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
