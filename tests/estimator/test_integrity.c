/*
 * estimator/integrity through the facade: each reason of the why set, the
 * never-ok rules (readings no part gives as valid, a parity failure, motion, drift), the
 * sd beside every value and none beside none, and the required injections (one
 * sensor a whole or half window at 8190, all four at 8190 / 65535 / 0, alternating
 * 0/65535, a fifth of the readings corrupted at random): never an answered angle more
 * than 6 sd off, never an ok window holding such a reading.
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
#include "test_rand.h"
#include "test_calibration.h"

#define TEST_PI 3.14159265358979323846
#define N       100
#ifndef RAMP_SEED
#define RAMP_SEED 0xD1B54A32D192ED03u
#endif
#ifndef JUMP_SEED
#define JUMP_SEED 0x9E3779B97F4A7C15u
#endif
#ifndef DRIFT_SEED
#define DRIFT_SEED 0x2545F4914F6CDD1Du
#endif

static struct attitude_state st;
static struct attitude_output out;

/* the tests' one generator (tests/common/test_rand.h): the same sequences as before */
static struct test_rng rng = {0x2545F4914F6CDD1Du};
static double urand(void) {
    return test_urand(&rng);
}
static double gauss(void) {
    return test_gauss(&rng);
}

static const uint8_t all_ok[4] = {0, 0, 0, 0};
static const bool all_present[4] = {true, true, true, true};

static void init(enum attitude_window_mode mode) {
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0;                  /* a still plate: no rate bound's prior (a fixture) */
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    cfg.window = N;
    cfg.mode = mode;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
}

static void ideal(double alpha_deg, double beta_deg, double x[4]) {
    const double ta = tan(alpha_deg * TEST_PI / 180), tb = tan(beta_deg * TEST_PI / 180);
    x[0] = 100 - 30 * ta;
    x[1] = 100 + 30 * tb;
    x[2] = 100 + 30 * ta;
    x[3] = 100 - 30 * tb;
}

static uint16_t noisy(double x, double sd) {
    return (uint16_t)lround(x + sd * gauss());
}

/* A corruption of row i of a window (returns true when it replaced some reading). */
typedef bool (*corrupt_fn)(unsigned i, uint16_t r[4]);

/* One tumbling window at (alpha, beta), σ = 2 mm, corrupted by f; true when ready. */
static bool window(double alpha, double beta, corrupt_fn f, bool *held_bad) {
    double x[4];
    ideal(alpha, beta, x);
    bool ready = false;
    *held_bad = false;
    for (unsigned i = 0; i < N; ++i) {
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = noisy(x[k], 2.0);
        }
        if (f != NULL && f(i, r)) {
            *held_bad = true;
        }
        ready = attitude_push_sample(&st, r, all_ok, all_present, &out);
    }
    return ready;
}

static bool has(const struct attitude_estimate *e, attitude_why_t bit) {
    return (e->why & bit) != 0u;
}

/* The integrity rules on one estimate against the truth. */
static void check_honest(const struct attitude_estimate *e, double alpha, double beta,
                         bool held_bad) {
    assert_true((e->status == ATTITUDE_OK) == (e->why == 0u));
    if (held_bad) {
        assert_int_not_equal(e->status, ATTITUDE_OK);
    }
    if (e->alpha_valid) {
        assert_true(e->alpha_sd_udeg >= 1);
        if (e->status != ATTITUDE_INVALID) {
            assert_true(fabs(e->alpha_udeg / 1e6 - alpha) <= 6.0 * e->alpha_sd_udeg / 1e6);
        }
    } else {
        assert_int_equal(e->alpha_sd_udeg, 0);
    }
    if (e->beta_valid) {
        assert_true(e->beta_sd_udeg >= 1);
        if (e->status != ATTITUDE_INVALID) {
            assert_true(fabs(e->beta_udeg / 1e6 - beta) <= 6.0 * e->beta_sd_udeg / 1e6);
        }
    } else {
        assert_int_equal(e->beta_sd_udeg, 0);
    }
    assert_true(e->distance_valid ? e->distance_sd_um >= 1 : e->distance_sd_um == 0);
}

/* Runs `windows` corrupted windows at random attitudes; checks every estimator. */
static void inject(corrupt_fn f, unsigned windows) {
    init(ATTITUDE_TUMBLING);
    for (unsigned w = 0; w < windows; ++w) {
        const double alpha = -5 + 10 * urand(), beta = -5 + 10 * urand();
        bool bad = false;
        assert_true(window(alpha, beta, f, &bad));
        for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
            check_honest(&out.est[e], alpha, beta, bad);
        }
    }
}

/* --- the why text -------------------------------------------------------------------- */

static void test_why_format(void **state) {
    (void)state;
    char buf[ATTITUDE_WHY_TEXT_MAX];
    assert_int_equal(attitude_why_format(0u, buf, sizeof buf), 0);
    assert_string_equal(buf, "");
    assert_int_equal(
        attitude_why_format(ATTITUDE_WHY_NO_TARGET(0) | ATTITUDE_WHY_PARITY, buf, sizeof buf),
        (int)strlen("no-target:A+parity"));
    assert_string_equal(buf, "no-target:A+parity");
    assert_true(attitude_why_format(ATTITUDE_WHY_FLAGGED(2) | ATTITUDE_WHY_MISSING(3) |
                                        ATTITUDE_WHY_RANGE(1) | ATTITUDE_WHY_REJECTED(0) |
                                        ATTITUDE_WHY_MOTION | ATTITUDE_WHY_DRIFT |
                                        ATTITUDE_WHY_REASON(ATTITUDE_REASON_KALMAN_RESTARTED),
                                    buf, sizeof buf) > 0);
    assert_string_equal(buf,
                        "range:B+flagged:C+missing:D+rejected:A+motion+drift+kalman-restarted");
    /* every bit at once fits the documented maximum; one byte less does not */
    const attitude_why_t all = (((attitude_why_t)1u << 23u) - 1u) | ATTITUDE_WHY_UNCALIBRATED |
                               ATTITUDE_WHY_RECALIBRATE |
                               (((((attitude_why_t)1u << (ATTITUDE_REASON_COUNT - 1u)) - 1u))
                                << (ATTITUDE_WHY_REASON_SHIFT + 1u));
    const int len = attitude_why_format(all, buf, sizeof buf);
    assert_int_equal(len + 1, (int)ATTITUDE_WHY_TEXT_MAX - 2); /* 567: two bytes to spare */
    assert_int_equal(attitude_why_format(all, buf, (size_t)len), ATTITUDE_ERR_BUFFER);
    assert_string_equal(buf, "");
    assert_int_equal(attitude_why_format(1u, NULL, 4), ATTITUDE_ERR_NULL);
}

static void test_integrity_config_checked(void **state) {
    (void)state;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0;                  /* a still plate: no rate bound's prior (a fixture) */
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    cfg.range_max_mm = 8190;                  /* a no-target value cannot be a range */
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_INTEGRITY);
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0;                  /* a still plate: no rate bound's prior (a fixture) */
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    cfg.parity_sigmas_q8 = 255;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_INTEGRITY);
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0;                  /* a still plate: no rate bound's prior (a fixture) */
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    cfg.motion_sigmas_q8 = 0;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_INTEGRITY);
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0;                  /* a still plate: no rate bound's prior (a fixture) */
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    cfg.drift_shift = 9;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_INTEGRITY);
    assert_true(strlen(attitude_error_message(ATTITUDE_ERR_INTEGRITY)) > 0);
}

/* --- each reason ------------------------------------------------------------------------ */

static bool a_8190_all(unsigned i, uint16_t r[4]) {
    (void)i;
    r[0] = 8190;
    return true;
}

static void test_no_target_one_sensor_whole_window(void **state) {
    (void)state;
    inject(a_8190_all, 20);
    const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
    assert_int_equal(c->status, ATTITUDE_DEGRADED);
    assert_true(has(c, ATTITUDE_WHY_NO_TARGET(0)));
    assert_true(c->alpha_valid && c->beta_valid); /* answered from B, C, D */
    assert_int_equal(c->counts[0].used, 0);
    assert_int_equal(c->counts[0].flagged, N);
}

static bool a_8190_half(unsigned i, uint16_t r[4]) {
    if (i % 2u == 0u) {
        r[0] = 8190;
        return true;
    }
    return false;
}

static void test_no_target_half_window(void **state) {
    (void)state;
    inject(a_8190_half, 20);
    const struct attitude_estimate *m = &out.est[ATTITUDE_EST_MEAN];
    assert_int_equal(m->status, ATTITUDE_DEGRADED);
    assert_true(has(m, ATTITUDE_WHY_NO_TARGET(0)));
    assert_int_equal(m->counts[0].used, N / 2);
}

static bool all_8190(unsigned i, uint16_t r[4]) {
    (void)i;
    r[0] = r[1] = r[2] = r[3] = 8191;
    return true;
}

static bool all_65535(unsigned i, uint16_t r[4]) {
    (void)i;
    r[0] = r[1] = r[2] = r[3] = 65535;
    return true;
}

static bool all_zero(unsigned i, uint16_t r[4]) {
    (void)i;
    r[0] = r[1] = r[2] = r[3] = 0;
    return true;
}

static void test_all_four_no_target_is_invalid(void **state) {
    (void)state;
    const corrupt_fn fs[3] = {all_8190, all_65535, all_zero};
    for (unsigned i = 0; i < 3; ++i) {
        inject(fs[i], 3);
        for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
            const struct attitude_estimate *est = &out.est[e];
            assert_int_equal(est->status, ATTITUDE_INVALID);
            assert_false(est->alpha_valid || est->beta_valid || est->distance_valid);
            for (unsigned k = 0; k < 4; ++k) {
                assert_true(has(est, i == 2 ? ATTITUDE_WHY_RANGE(k) : ATTITUDE_WHY_NO_TARGET(k)));
            }
        }
    }
}

static bool c_alternating(unsigned i, uint16_t r[4]) {
    r[2] = i % 2u ? 65535 : 0;
    return true;
}

static void test_alternating_zero_and_65535(void **state) {
    (void)state;
    inject(c_alternating, 20);
    const struct attitude_estimate *k = &out.est[ATTITUDE_EST_KALMAN];
    assert_int_equal(k->status, ATTITUDE_DEGRADED);
    assert_true(has(k, ATTITUDE_WHY_NO_TARGET(2)) && has(k, ATTITUDE_WHY_RANGE(2)));
}

static bool fifth_random(unsigned i, uint16_t r[4]) {
    (void)i;
    bool any = false;
    for (unsigned k = 0; k < 4; ++k) {
        if (urand() < 0.2) {
            /* half implausible values, half arbitrary in-range ones */
            r[k] = (uint16_t)(urand() < 0.5 ? (urand() < 0.5 ? 65535u : 8190u)
                                            : (uint16_t)(1 + urand() * 3999));
            any = true;
        }
    }
    return any;
}

static void test_random_fifth_corrupted(void **state) {
    (void)state;
    inject(fifth_random, 200);
}

/* A VL53L1X's "no target" as a logger without the status column records it: plausible
 * values scattered over 4..1954 mm (a real one, michaelrenoo/cpp-anti-collision-vl53l1x
 * lux8900-nichts.csv), in sensor C for the second half of each window. The window's gate
 * drops them; the Kalman filter's lock-out restarts it inside the window, and its few
 * rows since then may hold some: its sd must cover that (without the comparison with
 * the window's estimate after such a restart, answered 6.9 sd off on real data). */
static bool c_no_target_garbage(unsigned i, uint16_t r[4]) {
    if (i < N / 2u) {
        return false;
    }
    r[2] = (uint16_t)(4 + urand() * 1950);
    return false; /* plausible: nothing marks these readings as invalid */
}

static void test_plausible_no_target_garbage(void **state) {
    (void)state;
    init(ATTITUDE_TUMBLING);
    unsigned ok = 0;
    for (unsigned w = 0; w < 200u; ++w) {
        const double alpha = -5 + 10 * urand(), beta = -5 + 10 * urand();
        bool bad = false;
        assert_true(window(alpha, beta, c_no_target_garbage, &bad));
        for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
            check_honest(&out.est[e], alpha, beta, false);
            ok += out.est[e].status == ATTITUDE_OK ? 1u : 0u;
        }
    }
    assert_int_equal(ok, 0); /* the gate's rejections, parity or the restart say why */
}

static bool d_beyond_range(unsigned i, uint16_t r[4]) {
    if (i == 17u) {
        r[3] = 5000; /* above the 4000 mm of the default mode's range */
        return true;
    }
    return false;
}

static void test_range_one_reading(void **state) {
    (void)state;
    inject(d_beyond_range, 5);
    const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
    assert_int_equal(c->status, ATTITUDE_DEGRADED);
    assert_true(has(c, ATTITUDE_WHY_RANGE(3)));
    assert_int_equal(c->counts[3].used, N - 1);
}

static void test_flagged_missing_rejected(void **state) {
    (void)state;
    init(ATTITUDE_TUMBLING);
    double x[4];
    ideal(1, -1, x);
    for (unsigned i = 0; i < N; ++i) {
        uint16_t r[4];
        uint8_t status[4] = {0, 0, 0, 0};
        bool present[4] = {true, true, true, true};
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = noisy(x[k], 2.0);
        }
        if (i == 3u) {
            status[2] = 4; /* flagged:C */
        }
        if (i == 5u) {
            present[3] = false; /* missing:D */
        }
        if (i == 7u) {
            r[0] = 160; /* a plausible range, 60 mm off: the gate rejects it (rejected:A) */
        }
        (void)attitude_push_sample(&st, r, status, present, &out);
    }
    const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
    assert_int_equal(c->status, ATTITUDE_DEGRADED);
    assert_true(has(c, ATTITUDE_WHY_FLAGGED(2)) && has(c, ATTITUDE_WHY_MISSING(3)) &&
                has(c, ATTITUDE_WHY_REJECTED(0)));
    char buf[ATTITUDE_WHY_TEXT_MAX];
    assert_true(attitude_why_format(c->why, buf, sizeof buf) > 0);
    assert_string_equal(buf, "flagged:C+missing:D+rejected:A");
}

/* A sensor 12 mm off for the whole window (an offset fault no status shows): the four
 * disagree with a flat plate. Degraded with `parity`, and the sd covers the fault in any
 * one sensor, so the estimate stays within its sd. */
static bool b_offset(unsigned i, uint16_t r[4]) {
    (void)i;
    r[1] = (uint16_t)(r[1] + 12u);
    return true;
}

static void test_parity(void **state) {
    (void)state;
    inject(b_offset, 20);
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct attitude_estimate *est = &out.est[e];
        if (est->status != ATTITUDE_INVALID) {
            assert_int_equal(est->status, ATTITUDE_DEGRADED);
            assert_true(has(est, ATTITUDE_WHY_PARITY));
        }
    }
    /* a clean window right after: parity holds again (the fault was not learnt) */
    bool bad = false;
    assert_true(window(0.5, 0.5, NULL, &bad));
    assert_false(has(&out.est[ATTITUDE_EST_CONSENSUS], ATTITUDE_WHY_PARITY));
}

/* Parity false alarms on clean windows: k = 4 gives 6.3e-5 per window for Gaussian noise;
 * 400 clean windows may show none (the drift learning only widens the test). */
static void test_parity_false_alarms(void **state) {
    (void)state;
    init(ATTITUDE_TUMBLING);
    unsigned alarms = 0;
    unsigned ok = 0;
    for (unsigned w = 0; w < 400; ++w) {
        bool bad = false;
        const double alpha = -5 + 10 * urand(), beta = -5 + 10 * urand();
        assert_true(window(alpha, beta, NULL, &bad));
        const struct attitude_estimate *c = &out.est[ATTITUDE_EST_KALMAN];
        alarms += has(c, ATTITUDE_WHY_PARITY) ? 1u : 0u;
        ok += c->status == ATTITUDE_OK ? 1u : 0u;
        check_honest(c, alpha, beta, false);
    }
    print_message("parity alarms on 400 clean windows: %u; ok %u\n", alarms, ok);
    assert_true(alarms <= 1u);
    assert_true(ok >= 396u);
}

/* A ramp inside a window: α from 0 to 10° over the window. The window mean lags the last
 * row by about 5° (about 9σ of the ramp statistic): `motion`, and the sd covers the lag. */
static void test_motion_ramp(void **state) {
    (void)state;
    init(ATTITUDE_TUMBLING);
    for (unsigned i = 0; i < N; ++i) {
        double x[4];
        ideal(10.0 * i / (N - 1), 0, x);
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = noisy(x[k], 2.0);
        }
        (void)attitude_push_sample(&st, r, all_ok, all_present, &out);
    }
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct attitude_estimate *est = &out.est[e];
        if (est->status == ATTITUDE_INVALID) {
            continue;
        }
        assert_true(has(est, ATTITUDE_WHY_MOTION));
        assert_int_equal(est->status, ATTITUDE_DEGRADED);
        check_honest(est, 10.0, 0.0, false);
    }
}

/* A step late in a sliding window (the newest eighth): `motion`, within its sd. */
static void test_motion_late_step(void **state) {
    (void)state;
    init(ATTITUDE_SLIDING);
    for (unsigned i = 0; i < N; ++i) {
        double x[4];
        ideal(i < N - 12u ? -2.0 : 3.0, 0, x);
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = noisy(x[k], 2.0);
        }
        (void)attitude_push_sample(&st, r, all_ok, all_present, &out);
    }
    const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
    assert_true(has(c, ATTITUDE_WHY_MOTION));
    check_honest(c, 3.0, 0.0, false);
}

/* The consensus' α across tumbling windows w0..windows-1 of a schedule alpha(row), β = 0,
 * against the attitude at each window's last row: RMS error / sd, the largest |error| / sd,
 * and the learnt steady-motion lag² as a share of the α axis' white variance (both
 * averaged over the windows; white-box: integrity state). */
struct calibration {
    double rms_z, max_z, steady_share;
};
static struct calibration alpha_calibration(double (*alpha_at)(unsigned row), unsigned windows,
                                            unsigned w0) {
    init(ATTITUDE_TUMBLING);
    double z2 = 0, steady = 0, white = 0;
    struct calibration c = {0, 0, 0};
    for (unsigned w = 0; w < windows; ++w) {
        for (unsigned i = 0; i < N; ++i) {
            double x[4];
            ideal(alpha_at(w * N + i), 0, x);
            uint16_t r[4];
            for (unsigned k = 0; k < 4; ++k) {
                r[k] = noisy(x[k], 2.0);
            }
            (void)attitude_push_sample(&st, r, all_ok, all_present, &out);
        }
        const struct attitude_estimate *e = &out.est[ATTITUDE_EST_CONSENSUS];
        assert_true(e->alpha_valid);
        if (w >= w0) {
            const double z =
                (e->alpha_udeg / 1e6 - alpha_at(w * N + N - 1)) / (e->alpha_sd_udeg / 1e6);
            z2 += z * z;
            c.max_z = fabs(z) > c.max_z ? fabs(z) : c.max_z;
            steady += (double)st.integrity.steady_lag2_mm2[INTEGRITY_ALPHA];
            white += (double)(st.iw.white_mm2[0] + st.iw.white_mm2[2]) / 4.0;
        }
    }
    c.rms_z = sqrt(z2 / (windows - w0));
    c.steady_share = steady / white;
    return c;
}

/* 0.9° per window: the window mean lags its last row by about 0.45°, 1.5 of its sd, while
 * the window's own ramp statistic sees 1σ of it (undetectable in one window). */
static double slow_ramp(unsigned row) {
    return -10.0 + 0.009 * row;
}
static double level(unsigned row) {
    (void)row;
    return 1.0;
}

/* A ramp too slow for any one window's statistics: the lag learnt from the last four
 * blocks' means goes into the sd, so over 40 windows (after the four that teach it) the
 * error stays within 3.5 sd and RMS error / sd is about 1 (without it 1.85, up to 3.3 sd).
 * A level plate's sd is not padded by it: the learnt lag² averages under 5 % of the white
 * variance. */
static void test_steady_ramp_learnt(void **state) {
    (void)state;
    rng.state = RAMP_SEED; /* its own noise, whatever ran before */
    const struct calibration ramp = alpha_calibration(slow_ramp, 44, 4);
    print_message("slow ramp: rms err/sd %.2f, max %.2f, steady lag² %.2f of white\n", ramp.rms_z,
                  ramp.max_z, ramp.steady_share);
    assert_true(ramp.rms_z < 1.3 && ramp.rms_z > 0.6);
    assert_true(ramp.max_z < 3.5);
    const struct calibration flat = alpha_calibration(level, 200, 4);
    print_message("level: steady lag² %.4f of white, rms err/sd %.2f\n", flat.steady_share,
                  flat.rms_z);
    assert_true(flat.steady_share < 0.05);
}

/* A plate that jumps to a new α (uniform ±4°) between windows and holds it inside each is
 * not a steady motion: consecutive steps disagree, or the windows show no ramp. Over 400
 * windows the learnt lag² averages 0.26 to 0.49 of the white variance (10 seeds; a chance
 * collinear run of four jumps with a ramp statistic noisy enough to agree still pads),
 * against 3.0 for the slow ramp above; the bound is 0.8, and no window beyond 6 sd. */
#define JUMP_WINDOWS 400u
static double jump_alpha[JUMP_WINDOWS];
static double jumps(unsigned row) {
    return jump_alpha[(row / N) % JUMP_WINDOWS];
}
static void test_jumps_are_not_steady_motion(void **state) {
    (void)state;
    rng.state = JUMP_SEED; /* its own noise, whatever ran before */
    for (unsigned w = 0; w < JUMP_WINDOWS; ++w) {
        jump_alpha[w] = -4.0 + 8.0 * urand();
    }
    const struct calibration c = alpha_calibration(jumps, JUMP_WINDOWS, 4);
    print_message("jumps: steady lag² %.3f of white, rms err/sd %.2f\n", c.steady_share, c.rms_z);
    assert_true(c.steady_share < 0.8);
    assert_true(c.max_z < 6.0);
}

/* Offsets that wander from window to window (each sensor an AR(1) walk of 0.5 mm 1σ,
 * which no status shows): the parity residual's scatter teaches the drift, `drift` is
 * said (flag lowered to 300 µm here) and the sd grows to cover it. */
static void test_drift_learnt(void **state) {
    (void)state;
    rng.state = DRIFT_SEED; /* its own noise, whatever ran before */
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.max_rate_mdeg_s = 0;                  /* a still plate: no rate bound's prior (a fixture) */
    test_calibration_exact(&cfg.calibration); /* ideal sensors: an exact calibration */
    cfg.window = N;
    cfg.drift_flag_um = 300;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    double offset[4] = {0, 0, 0, 0};
    unsigned drift_said = 0;
    double sd_first = 0, sd_late = 0;
    for (unsigned w = 0; w < 80; ++w) {
        double x[4];
        ideal(1, 1, x);
        for (unsigned i = 0; i < N; ++i) {
            uint16_t r[4];
            for (unsigned k = 0; k < 4; ++k) {
                r[k] = noisy(x[k] + offset[k], 2.0);
            }
            (void)attitude_push_sample(&st, r, all_ok, all_present, &out);
        }
        for (unsigned k = 0; k < 4; ++k) {
            offset[k] = 0.5 * offset[k] + 0.433 * gauss();
        }
        const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
        if (w == 0u) {
            sd_first = c->alpha_sd_udeg;
        }
        if (w >= 40u) {
            sd_late += c->alpha_sd_udeg / 40.0;
            drift_said += has(c, ATTITUDE_WHY_DRIFT) ? 1u : 0u;
            check_honest(c, 1, 1, false);
        }
    }
    print_message("drift: alpha sd %.3f -> %.3f deg, drift said in %u of 40 windows\n",
                  sd_first / 1e6, sd_late / 1e6, drift_said);
    assert_true(sd_late > 1.5 * sd_first);
    assert_true(drift_said >= 20u);
}

/* Rounding without noise: identical readings still carry the 1/12 mm² of 1 mm steps. */
static void test_quantisation_floor(void **state) {
    (void)state;
    init(ATTITUDE_TUMBLING);
    const uint16_t r[4] = {99, 100, 101, 100};
    for (unsigned i = 0; i < N; ++i) {
        (void)attitude_push_sample(&st, r, all_ok, all_present, &out);
    }
    const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
    /* y = (x_C − x_A)/2 with each mean off by up to 0.5 mm: sd of y >= sqrt(2/12)/2 mm,
     * i.e. >= 0.39° at a = 30 mm */
    assert_true(c->alpha_sd_udeg >= 390000);
    assert_true(c->distance_sd_um >= 144); /* sqrt(4/12)/4 mm */
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_why_format),
        cmocka_unit_test(test_integrity_config_checked),
        cmocka_unit_test(test_no_target_one_sensor_whole_window),
        cmocka_unit_test(test_no_target_half_window),
        cmocka_unit_test(test_all_four_no_target_is_invalid),
        cmocka_unit_test(test_alternating_zero_and_65535),
        cmocka_unit_test(test_random_fifth_corrupted),
        cmocka_unit_test(test_plausible_no_target_garbage),
        cmocka_unit_test(test_range_one_reading),
        cmocka_unit_test(test_flagged_missing_rejected),
        cmocka_unit_test(test_parity),
        cmocka_unit_test(test_parity_false_alarms),
        cmocka_unit_test(test_motion_ramp),
        cmocka_unit_test(test_motion_late_step),
        cmocka_unit_test(test_drift_learnt),
        cmocka_unit_test(test_quantisation_floor),
        cmocka_unit_test(test_steady_ramp_learnt),
        cmocka_unit_test(test_jumps_are_not_steady_motion),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
