/*
 * The head's calibration inside the estimator: every reading corrected to
 * true = (raw − offset)/gain in fine units before any estimator, exact on noise-free
 * readings; the configuration checked; an uncalibrated head never `ok` and its sd
 * honest (none beyond 6 sd) whatever its offsets; a calibration off by its stated sd
 * covered (>= 95 % within 3 sd).
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
#define ARM_MM  30.0

static struct test_rng rng;
static struct attitude_state st;
static struct attitude_output out;
static const uint8_t all_ok[4] = {0, 0, 0, 0};
static const bool all_present[4] = {true, true, true, true};

/* A simulated head: raw = gain · true + offset (docs/explanation/architecture.md). */
struct head {
    double offset_mm[4];
    double gain[4];
};

static double uniform(double lo, double hi) {
    return lo + (hi - lo) * test_urand(&rng);
}

static void random_head(struct head *h, double offset_max_mm, double gain_max) {
    for (unsigned k = 0; k < 4u; ++k) {
        h->offset_mm[k] = uniform(-offset_max_mm, offset_max_mm);
        h->gain[k] = 1.0 + uniform(-gain_max, gain_max);
    }
}

/* True distances of sensors A..D at (α, β) degrees and x̄ mm. */
static void geometry(double alpha_deg, double beta_deg, double xbar, double x[4]) {
    const double ta = tan(alpha_deg * TEST_PI / 180);
    const double tb = tan(beta_deg * TEST_PI / 180);
    x[0] = xbar - ARM_MM * ta;
    x[1] = xbar + ARM_MM * tb;
    x[2] = xbar + ARM_MM * ta;
    x[3] = xbar - ARM_MM * tb;
}

/* The calibration the estimator is told: the head's values plus errors (mm, gain) and the
 * stated sd. */
static void told(const struct head *h, const double err_o[4], const double err_g[4],
                 uint32_t osd_um, uint32_t gsd_ppm, struct calibration_head *c) {
    memset(c, 0, sizeof *c);
    c->calibrated = true;
    for (unsigned k = 0; k < 4u; ++k) {
        c->offset_um[k] = (int32_t)lround((h->offset_mm[k] + err_o[k]) * 1000);
        c->gain_ppm[k] = (int32_t)lround((h->gain[k] - 1 + err_g[k]) * 1e6);
        c->offset_sd_um[k] = osd_um;
        c->gain_sd_ppm[k] = gsd_ppm;
    }
}

static void config(struct attitude_config *cfg, const struct calibration_head *c) {
    attitude_config_default(cfg);
    cfg->calibration = *c;
}

/* One tumbling window of n rows of σ mm noise, whole-mm raw readings; true when out
 * holds the window's estimates. raw_out (n x 4) keeps the readings when not NULL. */
static bool window(const struct head *h, const double x[4], double sigma, unsigned n,
                   uint16_t (*raw_out)[4]) {
    bool ready = false;
    for (unsigned r = 0; r < n; ++r) {
        uint16_t raw[4];
        for (unsigned k = 0; k < 4u; ++k) {
            const double v = h->gain[k] * x[k] + h->offset_mm[k] + sigma * test_gauss(&rng);
            raw[k] = (uint16_t)lround(v < 1 ? 1 : v);
            if (raw_out != NULL) {
                raw_out[r][k] = raw[k];
            }
        }
        ready = attitude_push_sample(&st, raw, all_ok, all_present, &out);
    }
    return ready;
}

/* The mean estimator's α and β from corrected readings in double: the five angle
 * estimates of Eq. 1 per row, averaged over the rows, then over the five. */
static void mean_reference(uint16_t (*raw)[4], unsigned n, const struct calibration_head *c,
                           double *alpha_deg, double *beta_deg) {
    double sa = 0;
    double sb = 0;
    for (unsigned r = 0; r < n; ++r) {
        double y[4];
        for (unsigned k = 0; k < 4u; ++k) {
            y[k] = (raw[r][k] - c->offset_um[k] / 1000.0) / (1 + c->gain_ppm[k] / 1e6);
        }
        const double a = ARM_MM;
        sa += atan((y[1] - y[0]) / a) + atan((y[3] - y[0]) / a) + atan((y[2] - y[1]) / a) +
              atan((y[2] - y[3]) / a) + atan((y[2] - y[0]) / (2 * a));
        sb += atan((y[0] - y[3]) / a) + atan((y[2] - y[3]) / a) + atan((y[1] - y[0]) / a) +
              atan((y[1] - y[2]) / a) + atan((y[1] - y[3]) / (2 * a));
    }
    *alpha_deg = sa / (5.0 * n) * 180 / TEST_PI;
    *beta_deg = sb / (5.0 * n) * 180 / TEST_PI;
}

/* Offsets up to ±20 mm, gains ±3 %, 60–200 mm, ±5°: the corrected estimate equals the
 * double computation on the corrected readings within the fine units' quantisation
 * (2^-10 mm a reading: under 0.002°), and the distance within a micrometre; without the
 * correction the offsets put it degrees off. */
static void test_correction_exact(void **state) {
    (void)state;
    rng.state = 0x243F6A8885A308D3u;
    const double dists[4] = {60, 100, 150, 200};
    unsigned checked = 0;
    for (unsigned i = 0; i < 64u; ++i) {
        struct head h;
        random_head(&h, 20, 0.03);
        const double zero[4] = {0, 0, 0, 0};
        struct calibration_head c;
        told(&h, zero, zero, 0, 0, &c);
        struct attitude_config cfg;
        config(&cfg, &c);
        cfg.window = 20;
        cfg.gate_sigmas_q8 = 0;
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
        double x[4];
        geometry(uniform(-5, 5), uniform(-5, 5), dists[i % 4u], x);
        uint16_t raw[20][4];
        assert_true(window(&h, x, 0.0, 20, raw));
        double ra;
        double rb;
        mean_reference(raw, 20, &c, &ra, &rb);
        const struct attitude_estimate *e = &out.est[ATTITUDE_EST_MEAN];
        assert_true(e->alpha_valid && e->beta_valid);
        if (fabs(e->alpha_udeg / 1e6 - ra) > 0.002 || fabs(e->beta_udeg / 1e6 - rb) > 0.002) {
            fail_msg("head %u: (%.6f, %.6f) deg, the corrected readings give (%.6f, %.6f)", i,
                     e->alpha_udeg / 1e6, e->beta_udeg / 1e6, ra, rb);
        }
        /* the distance: the corrected sensor means' average */
        double xm = 0;
        for (unsigned r = 0; r < 20u; ++r) {
            for (unsigned k = 0; k < 4u; ++k) {
                xm += (raw[r][k] - c.offset_um[k] / 1000.0) / (1 + c.gain_ppm[k] / 1e6);
            }
        }
        xm /= 80.0;
        const struct attitude_estimate *p = &out.est[ATTITUDE_EST_CONSENSUS];
        assert_true(p->distance_valid);
        if (fabs(p->distance_um / 1000.0 - xm) > 0.002) {
            fail_msg("head %u: distance %.4f mm, the corrected readings give %.4f", i,
                     p->distance_um / 1000.0, xm);
        }
        ++checked;
    }
    assert_int_equal(checked, 64);
}

/* Whole-mm readings through an exact identity calibration: every fine value is raw·1024,
 * so the flatness residual is exactly the whole-mm one (and the goldens stay). */
static void test_identity_whole_mm(void **state) {
    (void)state;
    struct calibration_head c;
    test_calibration_exact(&c);
    struct attitude_config cfg;
    config(&cfg, &c);
    cfg.window = 4;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    const uint16_t rows[4][4] = {
        {100, 103, 107, 101}, {99, 104, 106, 101}, {101, 102, 108, 100}, {100, 103, 107, 102}};
    bool ready = false;
    for (unsigned r = 0; r < 4u; ++r) {
        ready = attitude_push_sample(&st, rows[r], all_ok, all_present, &out);
    }
    assert_true(ready);
    /* Σ(A + C − B − D) = 3 + 0 + 7 + 2 = 12 mm over 4 rows: 3 mm */
    assert_int_equal(out.est[ATTITUDE_EST_CONSENSUS].flatness_residual_um, 3000);
    /* x̄: the pair midpoints (100 + 107)/2 and (103 + 101)/2 averaged: 102.75 mm */
    assert_int_equal(out.est[ATTITUDE_EST_CONSENSUS].distance_um, 102750);
}

/* Sliding windows drop their oldest row by subtracting the same corrected values it
 * added (the ring keeps raw mm; the correction is recomputed): after 60 rows the sliding
 * estimate over the last 20 equals a fresh tumbling window of those 20 rows, exactly. */
static void test_sliding_subtracts_exactly(void **state) {
    (void)state;
    rng.state = 0x082EFA98EC4E6C89u;
    struct head h;
    random_head(&h, 20, 0.03);
    const double zero[4] = {0, 0, 0, 0};
    struct calibration_head c;
    told(&h, zero, zero, 50, 200, &c);
    struct attitude_config cfg;
    config(&cfg, &c);
    cfg.window = 20;
    cfg.mode = ATTITUDE_SLIDING;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    double x[4];
    geometry(3.0, -2.0, 120, x);
    uint16_t raw[60][4];
    assert_true(window(&h, x, 2.0, 60, raw));
    const struct attitude_output sliding = out;
    static struct attitude_state fresh;
    cfg.mode = ATTITUDE_TUMBLING;
    assert_int_equal(attitude_init(&fresh, &cfg), ATTITUDE_ERR_NONE);
    bool ready = false;
    for (unsigned r = 40; r < 60u; ++r) {
        ready = attitude_push_sample(&fresh, raw[r], all_ok, all_present, &out);
    }
    assert_true(ready);
    for (unsigned e = 0; e < 2u; ++e) {
        const enum attitude_estimator est = e == 0u ? ATTITUDE_EST_MEAN : ATTITUDE_EST_CONSENSUS;
        assert_int_equal(sliding.est[est].alpha_udeg, out.est[est].alpha_udeg);
        assert_int_equal(sliding.est[est].beta_udeg, out.est[est].beta_udeg);
        assert_int_equal(sliding.est[est].distance_um, out.est[est].distance_um);
        assert_int_equal(sliding.est[est].flatness_residual_um, out.est[est].flatness_residual_um);
    }
}

/* The extremes (under the sanitizers of the host build): calibrations at every bound,
 * readings from 1 mm to 65535 (no-target) in sliding and tumbling windows. Nothing
 * overflows, every answer keeps its contract (an sd >= 1 with its axis). */
static void test_extremes(void **state) {
    (void)state;
    rng.state = 0xC0AC29B7C97C50DDu;
    const int32_t om = CALIBRATION_OFFSET_MAX_UM;
    const int32_t gm = CALIBRATION_GAIN_MAX_PPM;
    for (unsigned i = 0; i < 16u; ++i) {
        struct calibration_head c;
        memset(&c, 0, sizeof c);
        c.calibrated = (i % 4u) != 3u;
        for (unsigned k = 0; k < 4u; ++k) {
            c.offset_um[k] = ((i + k) % 2u) != 0u ? om : -om;
            c.gain_ppm[k] = ((i / 2u + k) % 2u) != 0u ? gm : -gm;
            c.offset_sd_um[k] = (uint32_t)om;
            c.gain_sd_ppm[k] = (uint32_t)gm;
            c.offset_gain_corr_q15[k] = (i % 3u) == 0u ? INT16_MIN : INT16_MAX;
        }
        struct attitude_config cfg;
        config(&cfg, &c);
        cfg.window = (uint16_t)(i % 2u ? 10 : ATTITUDE_WINDOW_MAX);
        cfg.mode = i % 2u ? ATTITUDE_SLIDING : ATTITUDE_TUMBLING;
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
        unsigned answers = 0;
        for (unsigned r = 0; r < 600u; ++r) {
            uint16_t raw[4];
            for (unsigned k = 0; k < 4u; ++k) {
                const unsigned pick = (unsigned)(test_u64(&rng) % 8u);
                raw[k] = pick == 0u   ? 1u
                         : pick == 1u ? 65535u
                         : pick == 2u ? 8189u
                                      : (uint16_t)(1u + test_u64(&rng) % 300u);
            }
            if (attitude_push_sample(&st, raw, all_ok, all_present, &out)) {
                for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
                    const struct attitude_estimate *p = &out.est[e];
                    assert_true(p->alpha_valid ? p->alpha_sd_udeg >= 1 : p->alpha_sd_udeg == 0);
                    assert_true(p->beta_valid ? p->beta_sd_udeg >= 1 : p->beta_sd_udeg == 0);
                    assert_true(c.calibrated || p->status != ATTITUDE_OK);
                }
                ++answers;
            }
        }
        assert_true(answers > 0u);
    }
}

static void test_validation(void **state) {
    (void)state;
    struct attitude_config cfg;
    struct calibration_head c;
    test_calibration_exact(&c);
    config(&cfg, &c);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    const struct attitude_state before = st;
    struct attitude_config bad = cfg;
    bad.calibration.offset_um[2] = CALIBRATION_OFFSET_MAX_UM + 1;
    assert_int_equal(attitude_init(&st, &bad), ATTITUDE_ERR_CALIBRATION);
    assert_memory_equal(&st, &before, sizeof st); /* a refusal changes nothing */
    bad = cfg;
    bad.calibration.offset_um[0] = -CALIBRATION_OFFSET_MAX_UM - 1;
    assert_int_equal(attitude_init(&st, &bad), ATTITUDE_ERR_CALIBRATION);
    bad = cfg;
    bad.calibration.gain_ppm[1] = -CALIBRATION_GAIN_MAX_PPM - 1;
    assert_int_equal(attitude_init(&st, &bad), ATTITUDE_ERR_CALIBRATION);
    bad = cfg;
    bad.calibration.gain_ppm[3] = CALIBRATION_GAIN_MAX_PPM + 1;
    assert_int_equal(attitude_init(&st, &bad), ATTITUDE_ERR_CALIBRATION);
    bad = cfg;
    bad.calibration.offset_sd_um[1] = (uint32_t)CALIBRATION_OFFSET_MAX_UM + 1u;
    assert_int_equal(attitude_init(&st, &bad), ATTITUDE_ERR_CALIBRATION);
    bad = cfg;
    bad.calibration.gain_sd_ppm[0] = (uint32_t)CALIBRATION_GAIN_MAX_PPM + 1u;
    assert_int_equal(attitude_init(&st, &bad), ATTITUDE_ERR_CALIBRATION);
    /* the bounds themselves are accepted */
    bad = cfg;
    for (unsigned k = 0; k < 4u; ++k) {
        bad.calibration.offset_um[k] =
            k % 2u ? CALIBRATION_OFFSET_MAX_UM : -CALIBRATION_OFFSET_MAX_UM;
        bad.calibration.gain_ppm[k] = k % 2u ? -CALIBRATION_GAIN_MAX_PPM : CALIBRATION_GAIN_MAX_PPM;
        bad.calibration.offset_sd_um[k] = CALIBRATION_OFFSET_MAX_UM;
        bad.calibration.gain_sd_ppm[k] = CALIBRATION_GAIN_MAX_PPM;
        bad.calibration.offset_gain_corr_q15[k] = INT16_MIN;
    }
    assert_int_equal(attitude_init(&st, &bad), ATTITUDE_ERR_NONE);
    /* an uncalibrated head's other fields are ignored */
    bad.calibration.calibrated = false;
    bad.calibration.offset_um[0] = INT32_MAX;
    assert_int_equal(attitude_init(&st, &bad), ATTITUDE_ERR_NONE);
    assert_true(strlen(attitude_error_message(ATTITUDE_ERR_CALIBRATION)) > 10u);
    char buf[ATTITUDE_WHY_TEXT_MAX];
    assert_int_equal(
        attitude_why_format(ATTITUDE_WHY_UNCALIBRATED | ATTITUDE_WHY_PARITY, buf, sizeof buf),
        (int)strlen("parity+uncalibrated"));
    assert_string_equal(buf, "parity+uncalibrated");
}

/* Errors over many windows, per estimator: how many answered rows, ok rows, within 3 sd
 * and beyond 6 sd (both axes counted). */
struct tally {
    unsigned answers;
    unsigned ok;
    unsigned within3;
    unsigned beyond6;
    unsigned uncal_said;
};

static void count(struct tally *t, const struct attitude_estimate *e, double alpha, double beta) {
    if (!e->alpha_valid || !e->beta_valid) {
        return;
    }
    t->answers++;
    if (getenv("CAL_DEBUG") != NULL && e->status != ATTITUDE_OK) {
        char buf[ATTITUDE_WHY_TEXT_MAX];
        (void)attitude_why_format(e->why, buf, sizeof buf);
        printf("why %s\n", buf);
    }
    t->ok += e->status == ATTITUDE_OK ? 1u : 0u;
    t->uncal_said += (e->why & ATTITUDE_WHY_UNCALIBRATED) != 0u ? 1u : 0u;
    const double za = fabs(e->alpha_udeg / 1e6 - alpha) / (e->alpha_sd_udeg / 1e6);
    const double zb = fabs(e->beta_udeg / 1e6 - beta) / (e->beta_sd_udeg / 1e6);
    t->within3 += (za <= 3 ? 1u : 0u) + (zb <= 3 ? 1u : 0u);
    t->beyond6 += (za > 6 ? 1u : 0u) + (zb > 6 ? 1u : 0u);
}

/* Heads with offsets uniform in ±20 mm and gains in ±3 % (the parts' spread), no
 * calibration: no row `ok`, each says `uncalibrated`, none beyond 6 sd. */
static void test_uncalibrated(void **state) {
    (void)state;
    rng.state = 0x13198A2E03707344u;
    const double dists[4] = {60, 100, 150, 200};
    struct tally t[2] = {{0}, {0}};
    for (unsigned i = 0; i < 400u; ++i) {
        struct head h;
        random_head(&h, 20, 0.03);
        struct attitude_config cfg;
        attitude_config_default(&cfg); /* uncalibrated */
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
        const double alpha = uniform(-5, 5);
        const double beta = uniform(-5, 5);
        double x[4];
        geometry(alpha, beta, dists[i % 4u], x);
        for (unsigned w = 0; w < 2u; ++w) {
            assert_true(window(&h, x, 2.0, 100, NULL));
            count(&t[0], &out.est[ATTITUDE_EST_CONSENSUS], alpha, beta);
            count(&t[1], &out.est[ATTITUDE_EST_KALMAN], alpha, beta);
        }
    }
    for (unsigned j = 0; j < 2u; ++j) {
        printf("uncalibrated %s: %u answers, %u ok, within 3 sd %.2f %%, beyond 6 sd %u\n",
               j == 0 ? "consensus" : "kalman", t[j].answers, t[j].ok,
               100.0 * t[j].within3 / (2.0 * t[j].answers), t[j].beyond6);
        assert_true(t[j].answers > 700u);
        assert_int_equal(t[j].ok, 0);
        assert_int_equal(t[j].uncal_said, t[j].answers);
        assert_int_equal(t[j].beyond6, 0);
    }
}

/* A head never calibrated says `uncalibrated`, and nothing a calibration would answer:
 * its parity reads the parts' offsets, so neither `drift` (a drift since a calibration it
 * never had) nor `recalibrate`. Heads with offsets in ±20 mm and ±2 mm (the second a head
 * whose parity passes, so the drift is learnt from it), 20 tumbling windows of 100 rows
 * each, σ 2 mm. */
static void test_uncalibrated_says_only_uncalibrated(void **state) {
    (void)state;
    rng.state = 0x2FFD72DBD01ADFB7u;
    const double spreads[2] = {20, 2};
    unsigned answers = 0;
    unsigned said = 0; /* estimates that say drift or recalibrate */
    for (unsigned i = 0; i < 60u; ++i) {
        struct head h;
        random_head(&h, spreads[i % 2u], 0.03);
        struct attitude_config cfg;
        attitude_config_default(&cfg); /* uncalibrated */
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
        double x[4];
        geometry(uniform(-5, 5), uniform(-5, 5), 100, x);
        for (unsigned w = 0; w < 20u; ++w) {
            assert_true(window(&h, x, 2.0, 100, NULL));
            for (unsigned e = 0; e < 2u; ++e) {
                const struct attitude_estimate *est =
                    &out.est[e == 0u ? ATTITUDE_EST_CONSENSUS : ATTITUDE_EST_KALMAN];
                answers++;
                said +=
                    (est->why & (ATTITUDE_WHY_DRIFT | ATTITUDE_WHY_RECALIBRATE)) != 0u ? 1u : 0u;
                assert_true((est->why & ATTITUDE_WHY_UNCALIBRATED) != 0u);
            }
        }
    }
    printf("uncalibrated heads: %u estimates, %u say drift or recalibrate\n", answers, said);
    assert_int_equal(said, 0);
}

/* The Kalman filter takes the corrected readings in whole mm; a calibration whose offsets
 * have a fraction must not leave it in them (plain rounding did: each reading lost the
 * same fraction, up to 0.5 mm a sensor, and the filter's angles and distance carried it,
 * an independent review found: 1.69× the true calibration's RMS error). Offsets 0.4,
 * −0.5, −0.3, 0.5 mm at 120 mm, σ 1 mm, 60 tumbling windows of 100 rows: over the
 * windows, the filter's mean α, β and distance are the consensus's (which sums the exact
 * values) within 4 standard errors of their difference; plain rounding put α 0.68° apart. */
static void test_kalman_fraction_carried(void **state) {
    (void)state;
    rng.state = 0x6C8E9CF570932BD5u;
    const struct head h = {{0.4, -0.5, -0.3, 0.5}, {1, 1, 1, 1}};
    static const double zero[4] = {0, 0, 0, 0};
    struct calibration_head c;
    told(&h, zero, zero, 20, 200, &c);
    struct attitude_config cfg;
    config(&cfg, &c);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    double x[4];
    geometry(1.0, -1.0, 120, x);
    double diff[3] = {0, 0, 0}; /* Σ kalman − consensus: α, β (°), distance (mm) */
    double diff2[3] = {0, 0, 0};
    const unsigned windows = 60;
    for (unsigned w = 0; w < windows; ++w) {
        assert_true(window(&h, x, 1.0, 100, NULL));
        const struct attitude_estimate *k = &out.est[ATTITUDE_EST_KALMAN];
        const struct attitude_estimate *e = &out.est[ATTITUDE_EST_CONSENSUS];
        assert_int_not_equal(k->status, ATTITUDE_INVALID);
        assert_int_not_equal(e->status, ATTITUDE_INVALID);
        const double d[3] = {(k->alpha_udeg - e->alpha_udeg) / 1e6,
                             (k->beta_udeg - e->beta_udeg) / 1e6,
                             (k->distance_um - e->distance_um) / 1e3};
        for (unsigned j = 0; j < 3u; ++j) {
            diff[j] += d[j];
            diff2[j] += d[j] * d[j];
        }
    }
    for (unsigned j = 0; j < 3u; ++j) {
        const double mean = diff[j] / windows;
        const double se = sqrt(diff2[j] / windows / windows) + 1e-6;
        printf("kalman - consensus, %s: mean %.4f, its standard error %.4f\n",
               j == 0   ? "alpha (deg)"
               : j == 1 ? "beta (deg)"
                        : "distance (mm)",
               mean, se);
        assert_true(fabs(mean) <= 4 * se);
    }
    assert_true(fabs(diff[0] / windows) < 0.05); /* plain rounding: 0.68° */
    assert_true(fabs(diff[2] / windows) < 0.05);
}

/* A calibration wrong by its stated sd (offsets 0.5 mm, gains 2e-3, drawn per head):
 * >= 95 % of answered rows within 3 sd, none beyond 6 sd, and rows are `ok` again. */
static void test_stated_sd_covered(void **state) {
    (void)state;
    rng.state = 0xA4093822299F31D0u;
    const double dists[4] = {60, 100, 150, 200};
    struct tally t[2] = {{0}, {0}};
    for (unsigned i = 0; i < 400u; ++i) {
        struct head h;
        random_head(&h, 20, 0.03);
        double eo[4];
        double eg[4];
        for (unsigned k = 0; k < 4u; ++k) {
            eo[k] = 0.5 * test_gauss(&rng);
            eg[k] = 2e-3 * test_gauss(&rng);
        }
        struct calibration_head c;
        told(&h, eo, eg, 500, 2000, &c);
        struct attitude_config cfg;
        config(&cfg, &c);
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
        const double alpha = uniform(-5, 5);
        const double beta = uniform(-5, 5);
        double x[4];
        geometry(alpha, beta, dists[i % 4u], x);
        for (unsigned w = 0; w < 2u; ++w) {
            assert_true(window(&h, x, 2.0, 100, NULL));
            count(&t[0], &out.est[ATTITUDE_EST_CONSENSUS], alpha, beta);
            count(&t[1], &out.est[ATTITUDE_EST_KALMAN], alpha, beta);
        }
    }
    for (unsigned j = 0; j < 2u; ++j) {
        const double within = t[j].within3 / (2.0 * t[j].answers);
        printf("stated sd %s: %u answers, %u ok, within 3 sd %.2f %%, beyond 6 sd %u\n",
               j == 0 ? "consensus" : "kalman", t[j].answers, t[j].ok, 100 * within, t[j].beyond6);
        assert_true(t[j].answers > 700u);
        assert_true(t[j].ok > t[j].answers / 2u);
        assert_int_equal(t[j].uncal_said, 0);
        assert_true(within >= 0.95);
        assert_int_equal(t[j].beyond6, 0);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_correction_exact),
        cmocka_unit_test(test_identity_whole_mm),
        cmocka_unit_test(test_validation),
        cmocka_unit_test(test_uncalibrated),
        cmocka_unit_test(test_uncalibrated_says_only_uncalibrated),
        cmocka_unit_test(test_stated_sd_covered),
        cmocka_unit_test(test_sliding_subtracts_exactly),
        cmocka_unit_test(test_extremes),
        cmocka_unit_test(test_kalman_fraction_carried),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
