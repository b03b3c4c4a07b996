/*
 * The drift allowance since the start: a calibrated head whose four offsets
 * walk independently (a random walk from 0 at the start, at the prior's rate
 * ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT and at 0.5× and 3× it) over four hours of a static
 * plate, shortened to 72,000 rows by a 200 ms period (the allowance counts time, rows ×
 * period_us). Over both axes: ≥ 95 % of answered rows within 3 sd, ≤ 0.1 % beyond 6 sd,
 * RMS error / RMS sd ≥ 0.5, ≥ 95 % of windows answered, tumbling (N = 100) and sliding
 * (N = 100). Before the allowance grew (a fixed 120 µm prior and the 16-block learnt drift)
 * the same walk left 80–85 % within 3 sd after the first hour. And `recalibrate`: said
 * after a 3 mm step of one offset, seldom on a head that drifts as the prior says.
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

#define TEST_PI   3.14159265358979323846
#define PERIOD_US 200000u /* 4 h in 72,000 rows */
#define ROWS      72000u
#define TRUTH_DEG 1.0

static struct test_rng rng;
static struct attitude_state st;
static struct attitude_output out;
static const uint8_t all_ok[4] = {0, 0, 0, 0};
static const bool all_present[4] = {true, true, true, true};

struct tally {
    unsigned windows, answered_windows, rows, within3, beyond6, recalibrate, after, after_said;
    unsigned uncalibrated, ok; /* windows saying `uncalibrated`; windows `ok` */
    double err2, sd2;
};

/* A plate at α = β = 1°, 500 mm, arm 30 mm (A, B, C, D as docs/explanation/architecture.md). */
static void ideal(double x[4]) {
    const double t = tan(TRUTH_DEG * TEST_PI / 180);
    x[0] = 500 - 30 * t;
    x[1] = 500 + 30 * t;
    x[2] = 500 + 30 * t;
    x[3] = 500 - 30 * t;
}

static void score(struct tally *t, const struct attitude_estimate *e) {
    t->windows++;
    t->uncalibrated += (e->why & ATTITUDE_WHY_UNCALIBRATED) != 0u ? 1u : 0u;
    t->ok += e->status == ATTITUDE_OK ? 1u : 0u;
    if (e->status == ATTITUDE_INVALID) {
        return;
    }
    t->answered_windows++;
    t->recalibrate += (e->why & ATTITUDE_WHY_RECALIBRATE) != 0u ? 1u : 0u;
    const int32_t v[2] = {e->alpha_udeg, e->beta_udeg};
    const int32_t sd[2] = {e->alpha_sd_udeg, e->beta_sd_udeg};
    for (unsigned a = 0; a < 2u; ++a) {
        const double err = (v[a] - TRUTH_DEG * 1e6) / 1e6;
        const double s = sd[a] / 1e6;
        t->rows++;
        t->within3 += fabs(err) <= 3 * s ? 1u : 0u;
        t->beyond6 += fabs(err) > 6 * s ? 1u : 0u;
        t->err2 += err * err;
        t->sd2 += s * s;
    }
}

/* ROWS rows of σ mm white noise plus per-sensor random walks at `rate` × the prior's;
 * step_mm: one offset step of sensor A after the first hour (0: none). `recalibrate` is
 * tallied over the quarter hour after it. */
static struct tally run_head(enum attitude_window_mode mode, double rate, double sigma,
                             double step_mm, uint64_t seed, bool calibrated) {
    rng.state = seed;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0; /* a still plate: no rate bound's prior (a fixture) */
    if (calibrated) {        /* calibrated at the start: the walk is what follows */
        test_calibration_exact(&cfg.calibration);
    }
    cfg.mode = mode;
    cfg.period_us = PERIOD_US;
    cfg.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    /* per-row step of the walk: rate · q0 (µm²/h) · period, in mm */
    const double step =
        sqrt(rate * ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT * 1e-6 * (PERIOD_US / 1e6) / 3600.0);
    /* an uncalibrated head's parts: offsets within ST's ±20 mm, parity 45 mm */
    static const double parts[4] = {15.0, -12.0, 10.0, -8.0};
    double x[4], walk[4] = {0, 0, 0, 0};
    ideal(x);
    struct tally t;
    (void)memset(&t, 0, sizeof t);
    for (unsigned i = 0; i < ROWS; ++i) {
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            walk[k] += step * test_gauss(&rng);
            const double jump = (k == 0u && i >= ROWS / 4u) ? step_mm : 0.0;
            r[k] = (uint16_t)lround(x[k] + (calibrated ? 0.0 : parts[k]) + walk[k] + jump +
                                    sigma * test_gauss(&rng));
        }
        if (attitude_push_sample(&st, r, all_ok, all_present, &out)) {
            score(&t, &out.est[ATTITUDE_EST_CONSENSUS]);
            const bool after = i >= ROWS / 4u + 2000u && i < ROWS / 4u + 6000u;
            t.after += after ? 1u : 0u;
            t.after_said +=
                after && (out.est[ATTITUDE_EST_CONSENSUS].why & ATTITUDE_WHY_RECALIBRATE) != 0u;
        }
    }
    return t;
}

/* A head calibrated at the start (exactly), as above. */
static struct tally run(enum attitude_window_mode mode, double rate, double sigma, double step_mm,
                        uint64_t seed) {
    return run_head(mode, rate, sigma, step_mm, seed, true);
}

static void check_goal(const char *what, const struct tally *t) {
    const double answered = (double)t->answered_windows / t->windows;
    const double w3 = (double)t->within3 / t->rows;
    const double b6 = (double)t->beyond6 / t->rows;
    const double ratio = sqrt(t->err2 / t->sd2);
    print_message("%s: answered %.1f %%, within 3 sd %.2f %%, beyond 6 sd %.3f %%, "
                  "err/sd %.3f, recalibrate %.1f %%\n",
                  what, 100 * answered, 100 * w3, 100 * b6, ratio,
                  100.0 * t->recalibrate / t->answered_windows);
    assert_true(answered >= 0.95);
    assert_true(w3 >= 0.95);
    assert_true(b6 <= 0.001);
    assert_true(ratio >= 0.5);
}

static void test_walk_four_hours(void **state) {
    (void)state;
    static const double rates[3] = {0.5, 1.0, 3.0};
    static const uint64_t seeds[3] = {0x9E3779B97F4A7C15u, 0xD1B54A32D192ED03u,
                                      0x2545F4914F6CDD1Du};
    for (unsigned m = 0; m < 2u; ++m) {
        const enum attitude_window_mode mode = m == 0u ? ATTITUDE_TUMBLING : ATTITUDE_SLIDING;
        for (unsigned r = m; r < 3u - m; ++r) { /* sliding: 1x only (its cost) */
            char what[64];
            (void)snprintf(what, sizeof what, "%s, walk %.1fx, sigma 2 mm",
                           m == 0u ? "tumbling" : "sliding", rates[r]);
            const struct tally t = run(mode, rates[r], 2.0, 0.0, seeds[r]);
            check_goal(what, &t);
        }
    }
}

/* All four offsets walking together (one walk at the prior's rate: a temperature or
 * reflectance change moves every part alike), four hours as above: invisible to the
 * parity and to α and β, the whole walk is in x̄; 24 heads tumbling, 4 sliding. The
 * distance is scored: ≥ 95 % of
 * answered rows within 3 sd, ≤ 0.1 % beyond 6 sd (before the distance carried the common
 * walk: about half within 3 sd). */
static void test_common_walk_in_distance(void **state) {
    (void)state;
    const double step =
        sqrt(ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT * 1e-6 * (PERIOD_US / 1e6) / 3600.0);
    for (unsigned m = 0; m < 2u; ++m) {
        unsigned rows = 0, within3 = 0, beyond6 = 0;
        const unsigned heads = m == 0u ? 24u : 4u; /* sliding: fewer (its cost) */
        for (unsigned s = 0; s < heads; ++s) {
            rng.state = 0x3C6EF372FE94F82Bu + 0x9E3779B97F4A7C15u * s;
            struct attitude_config cfg;
            attitude_config_default(&cfg);
            test_calibration_exact(&cfg.calibration);
            cfg.mode = m == 0u ? ATTITUDE_TUMBLING : ATTITUDE_SLIDING;
            cfg.period_us = PERIOD_US;
            cfg.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS);
            assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
            double x[4];
            ideal(x);
            double walk = 0;
            for (unsigned i = 0; i < ROWS; ++i) {
                walk += step * test_gauss(&rng);
                uint16_t r[4];
                for (unsigned k = 0; k < 4; ++k) {
                    r[k] = (uint16_t)lround(x[k] + walk + 2.0 * test_gauss(&rng));
                }
                if (!attitude_push_sample(&st, r, all_ok, all_present, &out)) {
                    continue;
                }
                const struct attitude_estimate *e = &out.est[ATTITUDE_EST_CONSENSUS];
                if (!e->distance_valid || e->distance_sd_um <= 0) {
                    continue;
                }
                const double err = fabs(e->distance_um / 1000.0 - 500.0);
                const double sd = e->distance_sd_um / 1000.0;
                rows++;
                within3 += err <= 3 * sd ? 1u : 0u;
                beyond6 += err > 6 * sd ? 1u : 0u;
            }
        }
        print_message("common walk, %s: distance within 3 sd %.2f %%, beyond 6 sd %.3f %% of %u\n",
                      m == 0u ? "tumbling" : "sliding", 100.0 * within3 / rows,
                      100.0 * beyond6 / rows, rows);
        assert_true(rows > 0u);
        assert_true(within3 >= 0.95 * rows);
        assert_true(beyond6 <= 0.001 * rows);
    }
}

/* A 6 mm step of one offset after an hour (a per-sensor mean square of 9 mm² in the
 * parity, beyond 9 × the allowance of 0.59 mm² then) is `recalibrate` in most windows of
 * the quarter hour after it (from 400 s after it: the learning follows with gain 1/16 per block); a
 * head drifting as the prior says is seldom told to recalibrate. */
static void test_recalibrate(void **state) {
    (void)state;
    const struct tally quiet = run(ATTITUDE_TUMBLING, 1.0, 2.0, 0.0, 0x94D049BB133111EBu);
    const struct tally step = run(ATTITUDE_TUMBLING, 1.0, 2.0, 6.0, 0x5851F42D4C957F2Du);
    const double q = (double)quiet.recalibrate / quiet.answered_windows;
    const double s = (double)step.after_said / step.after;
    print_message("recalibrate: walk at the prior %.1f %% of windows; a 6 mm step after 1 h: "
                  "%.1f %% of the windows of the quarter hour after it\n",
                  100 * q, 100 * s);
    assert_true(q <= 0.02);
    assert_true(s >= 0.80);
}

/* A head never calibrated (offsets +15, −12, +10, −8 mm) has nothing to recalibrate: the
 * same 6 mm step that is
 * `recalibrate` above is said `uncalibrated` in every window and never `recalibrate`
 * (without the rule, said on heads never calibrated: 715 of 8,000 rows in a reviewer's
 * case), and never `ok`. */
static void test_uncalibrated_never_recalibrate(void **state) {
    (void)state;
    const struct tally step =
        run_head(ATTITUDE_TUMBLING, 1.0, 2.0, 6.0, 0x5851F42D4C957F2Du, false);
    print_message("uncalibrated parts, 6 mm step: %u of %u windows uncalibrated, %u recalibrate\n",
                  step.uncalibrated, step.windows, step.recalibrate);
    assert_true(step.windows > 0u);
    assert_int_equal(step.uncalibrated, step.windows);
    assert_int_equal(step.recalibrate, 0u);
    assert_int_equal(step.ok, 0u);
}

/* The walk in fixed point: after an hour of 20 ms rows (180,000) of a flat plate with
 * identical readings (no learnt drift), the prior walk is q0·t = 0.576 mm² exactly (Q32,
 * within 1e-6 mm²); at 200 ms rows the same rows are ten hours. The sd carries the whole
 * walk: nothing the parity shows scales it down (a learner that did hid
 * smooth drifts: test_smooth_drift). */
static void test_walk_fixed_point(void **state) {
    (void)state;
    static const uint32_t periods[2] = {20000u, 200000u};
    for (unsigned p = 0; p < 2u; ++p) {
        struct attitude_config cfg;
        attitude_config_default(&cfg);
        cfg.max_rate_mdeg_s = 0; /* a still plate: no rate bound's prior (a fixture) */
        test_calibration_exact(&cfg.calibration);
        cfg.period_us = periods[p];
        cfg.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS);
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
        const uint16_t r[4] = {500, 500, 500, 500};
        for (unsigned i = 0; i < 180000u; ++i) {
            (void)attitude_push_sample(&st, r, all_ok, all_present, &out);
        }
        const double hours = 180000.0 * periods[p] / 3.6e9;
        const double want = ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT * 1e-6 * hours;
        const double got = (double)st.integrity.walk_mm2 / 4294967296.0;
        const double used = (double)integrity_drift_var(&st.integrity) / 4294967296.0;
        print_message("walk after %.0f h: %.6f mm² (q0·t %.6f), in the sd %.6f mm²\n", hours, got,
                      want, used);
        assert_true(fabs(got - want) < 1e-6);
        assert_true(fabs(used - want) < 1e-6);
    }
}

/* A head that does not wander (white noise only, calibrated exactly), 20 ms rows: the
 * priors (120 µm, the walk) alone grow the sd beyond the error, the conservative side
 * (RMS error / RMS sd over half an hour 0.33 at σ = 1 mm, about 0.45 at 2 mm: below the
 * goal of 0.5, said in docs/explanation/accuracy.md). In every run ≥ 95 % within 3 sd and
 * ≤ 0.1 % beyond 6; pooled over six seeds, the sd at most 3.5 times the error. */
static void test_white_head_half_hour(void **state) {
    (void)state;
    static const double sigmas[3] = {1.0, 2.0, 3.0};
    static const unsigned rows[3] = {45000u, 90000u, 90000u};
    for (unsigned i = 0; i < 3u; ++i) {
        struct tally pooled;
        (void)memset(&pooled, 0, sizeof pooled);
        for (unsigned seed = 0; seed < 6u; ++seed) {
            rng.state = 0xA24BAED4963EE407u + 97u * seed + i;
            struct attitude_config cfg;
            attitude_config_default(&cfg);
            cfg.max_rate_mdeg_s = 0; /* a still plate: no rate bound's prior (a fixture) */
            test_calibration_exact(&cfg.calibration);
            cfg.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS);
            assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
            double x[4];
            ideal(x);
            struct tally t;
            (void)memset(&t, 0, sizeof t);
            for (unsigned row = 0; row < rows[i]; ++row) {
                uint16_t r[4];
                for (unsigned k = 0; k < 4; ++k) {
                    r[k] = (uint16_t)lround(x[k] + sigmas[i] * test_gauss(&rng));
                }
                if (attitude_push_sample(&st, r, all_ok, all_present, &out)) {
                    score(&t, &out.est[ATTITUDE_EST_CONSENSUS]);
                }
            }
            assert_true((double)t.within3 / t.rows >= 0.95);
            assert_true((double)t.beyond6 / t.rows <= 0.001);
            pooled.windows += t.windows;
            pooled.answered_windows += t.answered_windows;
            pooled.rows += t.rows;
            pooled.within3 += t.within3;
            pooled.beyond6 += t.beyond6;
            pooled.recalibrate += t.recalibrate;
            pooled.err2 += t.err2;
            pooled.sd2 += t.sd2;
        }
        const double ratio = sqrt(pooled.err2 / pooled.sd2);
        print_message("white head, sigma %.0f mm, %u min, 6 seeds: within 3 sd %.2f %%, "
                      "err/sd %.3f\n",
                      sigmas[i], rows[i] / 3000u, 100.0 * pooled.within3 / pooled.rows, ratio);
        assert_true(pooled.answered_windows == pooled.windows);
        assert_true(ratio >= 1 / 3.5);
    }
}

/* A smooth drift, as a temperature cycle makes one: every offset a sinusoid of period 2 h
 * with its own amplitude (below), one phase for all,
 * 0 at the calibration; σ 2 mm, 2 h of 20 ms rows. Its increments over a minute are far
 * below the walk's, over an hour above: a learner reading the minute spans
 * and scaled the walk prior down: 78 % within 3 sd, 0.67 % beyond 6 sd, 44 rows `ok`
 * beyond 6 sd (an independent review found it with random amplitudes).
 * Now ≥ 95 % within 3 sd, ≤ 0.1 % beyond 6 sd, and no `ok` row beyond 6 sd. */
static void test_smooth_drift(void **state) {
    (void)state;
    rng.state = 0xBF58476D1CE4E5B9u;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0; /* a still plate: no rate bound's prior (a fixture) */
    test_calibration_exact(&cfg.calibration);
    cfg.period_us = 20000u;
    cfg.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    /* a drift mostly along α (C − A = −1.5 mm) with a small parity (A + C − B − D = −0.2
     * mm): a realisation of independent amplitudes that the parity barely shows */
    static const double amp[4] = {1.0, 0.4, -0.5, 0.3};
    const double phase = 2 * TEST_PI * test_urand(&rng);
    double x[4];
    ideal(x);
    struct tally t;
    (void)memset(&t, 0, sizeof t);
    unsigned ok_beyond6 = 0;
    for (unsigned i = 0; i < 360000u; ++i) { /* 2 h of 20 ms rows */
        const double s = sin(2 * TEST_PI * i * 0.02 / 7200.0 + phase) - sin(phase);
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = (uint16_t)lround(x[k] + amp[k] * s + 2.0 * test_gauss(&rng));
        }
        if (attitude_push_sample(&st, r, all_ok, all_present, &out)) {
            const struct attitude_estimate *e = &out.est[ATTITUDE_EST_CONSENSUS];
            const unsigned before = t.beyond6;
            score(&t, e);
            ok_beyond6 += e->status == ATTITUDE_OK ? t.beyond6 - before : 0u;
        }
    }
    const double w3 = (double)t.within3 / t.rows;
    const double b6 = (double)t.beyond6 / t.rows;
    print_message("smooth drift, 1 mm over 2 h, 2 h: within 3 sd %.2f %%, beyond 6 sd %.3f %%, "
                  "ok beyond 6 sd %u, err/sd %.3f\n",
                  100 * w3, 100 * b6, ok_beyond6, sqrt(t.err2 / t.sd2));
    assert_true(w3 >= 0.95);
    assert_true(b6 <= 0.001);
    assert_int_equal(ok_beyond6, 0);
}

/* period_us outside 1000..10,000,000 µs is refused, naming the integrity fields. */
static void test_period_checked(void **state) {
    (void)state;
    static const uint32_t bad[3] = {0u, 999u, 10000001u};
    for (unsigned i = 0; i < 3u; ++i) {
        struct attitude_config cfg;
        attitude_config_default(&cfg);
        cfg.max_rate_mdeg_s = 0; /* a still plate: no rate bound's prior (a fixture) */
        cfg.period_us = bad[i];
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_INTEGRITY);
    }
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0; /* a still plate: no rate bound's prior (a fixture) */
    assert_int_equal(cfg.period_us, 20000u);
    cfg.period_us = 1000u;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    cfg.period_us = 10000000u;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    assert_non_null(strstr(attitude_error_message(ATTITUDE_ERR_INTEGRITY), "period_us"));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_walk_fixed_point),
        cmocka_unit_test(test_period_checked),
        cmocka_unit_test(test_walk_four_hours),
        cmocka_unit_test(test_white_head_half_hour),
        cmocka_unit_test(test_smooth_drift),
        cmocka_unit_test(test_recalibrate),
        cmocka_unit_test(test_common_walk_in_distance),
        cmocka_unit_test(test_uncalibrated_never_recalibrate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
