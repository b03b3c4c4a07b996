/*
 * Ramps up to 10°/s through the facade: is every answered row's sd honest?
 *
 * A plate whose α, β and x̄ each follow their own schedule of holds and ramps (α and β at
 * the scenario's rate, to a target drawn in ±10°, then a hold of 0 to 2N rows; x̄ between
 * 150 and 600 mm at 5 mm/s per °/s), a = 30 mm, 50 rows/s, white Gaussian noise σ on every
 * reading rounded to whole mm. Every row goes through attitude_push_sample() as the
 * firmware calls it (with an exact calibration: calibrated, offsets and gains 0, sds 0,
 * which must change nothing). Scored per answered axis against the attitude at the row's
 * time: the share within 3 sd (goal ≥ 95 %), beyond 6 sd (goal ≤ 0.1 %), RMS error / RMS
 * sd. Estimators: consensus, kalman with Q = 0, a fixed Q (q_x̄ 4 mm²/s, q_t 0.2 mm²/s),
 * and auto; tumbling and sliding windows.
 *
 * Two sets: the tuning set (rates 0.1, 1, 3, 10 °/s, σ 1, 3, 7 mm, N 10, 100, 255, seeds
 * 1–2) the motion statistics were adjusted on, and the held-out set (rates 0.3, 2, 6 °/s,
 * σ 2, 5 mm, N 20, 50, 160, seeds 101–102), never used for tuning.
 *
 *   test_ramps            the ctest: a reduced sweep of both sets, asserting the goals
 *   test_ramps --table    the full table of docs/explanation/accuracy.md ("Ramps")
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

#define TEST_PI   3.14159265358979323846
#define PERIOD_S  0.02 /* 50 rows/s */
#define ARM_MM    30.0
#define ANGLE_MAX 10.0 /* ramp targets in ±10° */
/* test_ramps_reduced_guard's bounds: what is met today, with a margin (not the goals) */
#define GUARD_WITHIN3 85.0
#define GUARD_SILENT6 2.0

enum variant { V_CONSENSUS, V_KALMAN_Q0, V_KALMAN_Q, V_KALMAN_AUTO, V_COUNT };
static const char *const variant_name[V_COUNT] = {"consensus", "kalman Q=0", "kalman Q fixed",
                                                  "kalman auto"};

/* One axis of the truth: a hold or a ramp towards a target. */
struct schedule {
    double value;
    double target;
    double rate; /* per row, > 0 */
    double lo, hi;
    int hold; /* rows left to hold */
    unsigned max_hold;
};

static void schedule_step(struct schedule *s, struct test_rng *rng) {
    if (s->hold > 0) {
        s->hold--;
        return;
    }
    const double d = s->target - s->value;
    if (fabs(d) <= s->rate) {
        s->value = s->target;
        s->target = s->lo + (s->hi - s->lo) * test_urand(rng);
        s->hold = (int)(test_urand(rng) * (s->max_hold + 1u));
        return;
    }
    s->value += d > 0 ? s->rate : -s->rate;
}

struct tally {
    unsigned long answered, within3, beyond6;
    unsigned long silent3, silent6; /* beyond 3 (6) sd and not said `motion` */
    double err2, sd2;
};

struct scenario {
    double rate_dps;
    double sigma_mm;
    unsigned n;
    enum attitude_window_mode mode;
    uint64_t seed;
    unsigned rows;
    double bound_dps; /* the plate's rate bound (attitude_config.max_rate_mdeg_s) */
};

/* The unit's default bound: a sweep's scenarios run under it unless it names its own. */
#define BOUND_DEFAULT (ATTITUDE_MAX_RATE_MDEG_S_DEFAULT / 1000.0)
#define BOUND_AT_RATE (-1.0)

static struct attitude_state st[3];
static struct attitude_output out;

static void config(struct attitude_config *cfg, const struct scenario *sc, enum variant v) {
    attitude_config_default(cfg);
    cfg->window = (uint16_t)sc->n;
    cfg->mode = sc->mode;
    cfg->estimators =
        ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS) | ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN);
    /* an exact calibration: nothing to correct, nothing to add to the sd */
    (void)memset(&cfg->calibration, 0, sizeof cfg->calibration);
    cfg->calibration.calibrated = true;
    if (v == V_KALMAN_Q) { /* µm² per row: q · period */
        cfg->kalman_process_noise_um2[0] = (uint32_t)lround(4.0 * PERIOD_S * 1e6);
        cfg->kalman_process_noise_um2[1] = (uint32_t)lround(0.2 * PERIOD_S * 1e6);
        cfg->kalman_process_noise_um2[2] = cfg->kalman_process_noise_um2[1];
    }
    cfg->kalman_process_noise_auto = v == V_KALMAN_AUTO;
    cfg->max_rate_mdeg_s = (uint32_t)lround(sc->bound_dps * 1000.0);
}

static int debug_variant = -1; /* --debug: print the rows beyond 3 sd of this variant */
static unsigned debug_row;

static const struct attitude_estimate *debug_est;

static void score(struct tally *t, bool valid, int32_t est_udeg, int32_t sd_udeg,
                  double truth_deg) {
    if (!valid) {
        return;
    }
    const double err = est_udeg * 1e-6 - truth_deg;
    const double sd = sd_udeg * 1e-6;
    if (debug_variant >= 0 && fabs(err) > 3 * sd) {
        char why[ATTITUDE_WHY_TEXT_MAX];
        (void)attitude_why_format(debug_est->why, why, sizeof why);
        printf("row %u %s truth %.4f est %.4f sd %.4f err/sd %.2f %s %s\n", debug_row,
               est_udeg == debug_est->alpha_udeg ? "a" : "b", truth_deg, est_udeg * 1e-6, sd,
               err / sd, attitude_status_name(debug_est->status), why);
        const struct integrity_window *iw = &st[0].iw;
        for (unsigned m = 0; m < 3u; ++m) {
            printf("   stat %u:", m);
            for (unsigned k = 0; k < 4u; ++k) {
                printf(" %.3f(%.3f)", (double)iw->motion_mm[m][k] / 4294967296.0,
                       sqrt((double)iw->motion_var_mm2[m][k] / 4294967296.0));
            }
            printf("\n");
        }
        printf("   lag a %.3f sd %.3f, b %.3f sd %.3f\n", (double)iw->lag_mm[0] / 4294967296.0,
               sqrt((double)iw->lag_var_mm2[0] / 4294967296.0),
               (double)iw->lag_mm[1] / 4294967296.0,
               sqrt((double)iw->lag_var_mm2[1] / 4294967296.0));
    }
    t->answered++;
    t->within3 += fabs(err) <= 3 * sd ? 1u : 0u;
    t->beyond6 += fabs(err) > 6 * sd ? 1u : 0u;
    const bool said = (debug_est->why & ATTITUDE_WHY_MOTION) != 0u;
    t->silent3 += fabs(err) > 3 * sd && !said ? 1u : 0u;
    t->silent6 += fabs(err) > 6 * sd && !said ? 1u : 0u;
    t->err2 += err * err;
    t->sd2 += sd * sd;
}

/* Runs one scenario; tallies per variant and axis (α, β) are added to t. */
static void run(const struct scenario *sc, struct tally t[V_COUNT][2]) {
    struct test_rng rng = {sc->seed * 0x9E3779B97F4A7C15u + 1u};
    const double rate_t = sc->rate_dps * PERIOD_S;
    const char *hold_env = getenv("RAMPS_HOLD_WINDOWS"); /* --debug: longer holds */
    const unsigned max_hold = (hold_env != NULL ? (unsigned)atoi(hold_env) : 2u) * sc->n;
    struct schedule ax[3] = {
        {.lo = -ANGLE_MAX, .hi = ANGLE_MAX, .rate = rate_t, .max_hold = max_hold},
        {.lo = -ANGLE_MAX, .hi = ANGLE_MAX, .rate = rate_t, .max_hold = max_hold},
        {.value = 300, .lo = 150, .hi = 600, .rate = 5.0 * rate_t, .max_hold = max_hold},
    };
    for (unsigned i = 0; i < 3u; ++i) {
        if (i < 2u) {
            ax[i].value = ax[i].lo + (ax[i].hi - ax[i].lo) * test_urand(&rng);
        }
        ax[i].target = ax[i].lo + (ax[i].hi - ax[i].lo) * test_urand(&rng);
        ax[i].hold = (int)(test_urand(&rng) * (max_hold + 1u));
    }
    for (unsigned v = V_KALMAN_Q0; v < V_COUNT; ++v) {
        struct attitude_config cfg;
        config(&cfg, sc, (enum variant)v);
        assert_int_equal(attitude_init(&st[v - 1u], &cfg), ATTITUDE_ERR_NONE);
    }
    static const uint8_t ok4[4] = {0, 0, 0, 0};
    static const bool present4[4] = {true, true, true, true};
    for (unsigned row = 0; row < sc->rows; ++row) {
        for (unsigned i = 0; i < 3u; ++i) {
            schedule_step(&ax[i], &rng);
        }
        const double ta = ARM_MM * tan(ax[0].value * TEST_PI / 180);
        const double tb = ARM_MM * tan(ax[1].value * TEST_PI / 180);
        const double xm = ax[2].value;
        const double x[4] = {xm - ta, xm + tb, xm + ta, xm - tb};
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            const long z = lround(x[k] + sc->sigma_mm * test_gauss(&rng));
            r[k] = (uint16_t)(z < 1 ? 1 : (z > 4000 ? 4000 : z));
        }
        debug_row = row;
        if (getenv("RAMPS_TRACE") != NULL && row % 17u == 0u) {
            printf("  truth %u: %.3f %.3f %.1f\n", row, ax[0].value, ax[1].value, ax[2].value);
        }
        for (unsigned v = V_KALMAN_Q0; v < V_COUNT; ++v) {
            if (!attitude_push_sample(&st[v - 1u], r, ok4, present4, &out)) {
                continue;
            }
            if (v == V_KALMAN_Q0 && (debug_variant < 0 || debug_variant == V_CONSENSUS)) {
                const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
                debug_est = c;
                score(&t[V_CONSENSUS][0], c->alpha_valid, c->alpha_udeg, c->alpha_sd_udeg,
                      ax[0].value);
                score(&t[V_CONSENSUS][1], c->beta_valid, c->beta_udeg, c->beta_sd_udeg,
                      ax[1].value);
            }
            if (debug_variant >= 0 && debug_variant != (int)v) {
                continue;
            }
            const struct attitude_estimate *k = &out.est[ATTITUDE_EST_KALMAN];
            debug_est = k;
            score(&t[v][0], k->alpha_valid, k->alpha_udeg, k->alpha_sd_udeg, ax[0].value);
            score(&t[v][1], k->beta_valid, k->beta_udeg, k->beta_sd_udeg, ax[1].value);
        }
    }
}

struct sweep {
    const char *name;
    const double *rates;
    unsigned n_rates;
    const double *sigmas;
    unsigned n_sigmas;
    const unsigned *ns;
    unsigned n_ns;
    uint64_t seed0;
    unsigned seeds;
    unsigned rows_min; /* rows per run: max(rows_min, windows · N) */
    unsigned windows;
    unsigned modes;   /* bit 0 tumbling, bit 1 sliding; 0: both */
    double bound_dps; /* the rate bound: 0 the unit's default, BOUND_AT_RATE each
                         scenario's own rate (a plate at its bound), else this value */
    bool static_sliding_kalman_printed_only; /* the Kalman filter with Q = 0 in sliding
                                                windows (a still plate's configuration)
                                                in the table, not in the worst figures */
};

struct worst {
    double within3; /* lowest share within 3 sd */
    double beyond6; /* highest share beyond 6 sd */
    double silent3; /* highest share beyond 3 sd not said `motion` */
    double silent6; /* highest share beyond 6 sd not said `motion` */
    double ratio;   /* highest RMS err / RMS sd */
};

/* One table line per (rate, σ, N, mode, variant), α and β; updates the worst figures. */
static void print_row(const struct scenario *sc, enum variant v, const struct tally t[2],
                      bool print, struct worst *w) {
    double f[2][5];
    for (unsigned a = 0; a < 2u; ++a) {
        const double n = t[a].answered > 0 ? (double)t[a].answered : 1.0;
        f[a][0] = 100.0 * (double)t[a].within3 / n;
        f[a][1] = 100.0 * (double)t[a].beyond6 / n;
        f[a][2] = 100.0 * (double)t[a].silent3 / n;
        f[a][3] = 100.0 * (double)t[a].silent6 / n;
        f[a][4] = t[a].sd2 > 0 ? sqrt(t[a].err2 / t[a].sd2) : 0;
        if (t[a].answered > 0) {
            w->within3 = fmin(w->within3, f[a][0]);
            w->beyond6 = fmax(w->beyond6, f[a][1]);
            w->silent3 = fmax(w->silent3, f[a][2]);
            w->silent6 = fmax(w->silent6, f[a][3]);
            w->ratio = fmax(w->ratio, f[a][4]);
        }
    }
    if (print) {
        printf("| %g | %g | %u | %s | %s | %lu", sc->rate_dps, sc->sigma_mm, sc->n,
               sc->mode == ATTITUDE_SLIDING ? "sliding" : "tumbling", variant_name[v],
               t[0].answered);
        for (unsigned a = 0; a < 2u; ++a) {
            printf(" | %.2f | %.3f | %.2f | %.3f | %.2f", f[a][0], f[a][1], f[a][2], f[a][3],
                   f[a][4]);
        }
        printf(" |\n");
    }
}

static struct worst run_sweep(const struct sweep *sw, bool print) {
    struct worst w = {100.0, 0.0, 0.0, 0.0, 0.0};
    if (print) {
        printf("\n%s\n\n| °/s | σ mm | N | mode | estimator | answered | α ≤3sd %% | α >6sd %% | "
               "α >3sd silent %% | α >6sd silent %% | α err/sd | β ≤3sd %% | β >6sd %% | "
               "β >3sd silent %% | β >6sd silent %% | β err/sd |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
               sw->name);
    }
    for (unsigned ri = 0; ri < sw->n_rates; ++ri) {
        for (unsigned si = 0; si < sw->n_sigmas; ++si) {
            for (unsigned ni = 0; ni < sw->n_ns; ++ni) {
                for (unsigned m = 0; m < 2u; ++m) {
                    if (sw->modes != 0u && (sw->modes & (1u << m)) == 0u) {
                        continue;
                    }
                    struct tally t[V_COUNT][2];
                    (void)memset(t, 0, sizeof t);
                    struct scenario sc = {
                        .rate_dps = sw->rates[ri],
                        .bound_dps = sw->bound_dps == BOUND_AT_RATE
                                         ? sw->rates[ri]
                                         : (sw->bound_dps > 0 ? sw->bound_dps : BOUND_DEFAULT),
                        .sigma_mm = sw->sigmas[si],
                        .n = sw->ns[ni],
                        .mode = m == 0u ? ATTITUDE_TUMBLING : ATTITUDE_SLIDING};
                    /* tumbling answers once a window: more windows for its shares */
                    const unsigned windows = m == 0u ? 6u * sw->windows : sw->windows;
                    sc.rows = windows * sc.n > sw->rows_min ? windows * sc.n : sw->rows_min;
                    for (unsigned s = 0; s < sw->seeds; ++s) {
                        sc.seed = sw->seed0 + s;
                        run(&sc, t);
                    }
                    for (unsigned v = 0; v < V_COUNT; ++v) {
                        struct worst unscored = w;
                        const bool scored = !(sw->static_sliding_kalman_printed_only &&
                                              v == V_KALMAN_Q0 && sc.mode == ATTITUDE_SLIDING);
                        print_row(&sc, (enum variant)v, t[v], print, scored ? &w : &unscored);
                    }
                }
            }
        }
    }
    if (print) {
        printf("\nworst: within 3 sd %.2f %%, beyond 6 sd %.3f %%, silent beyond 3 sd %.2f %%, "
               "silent beyond 6 sd %.3f %%, err/sd %.3f\n",
               w.within3, w.beyond6, w.silent3, w.silent6, w.ratio);
    }
    return w;
}

static const double tune_rates[] = {0.1, 1, 3, 10};
static const double tune_sigmas[] = {1, 3, 7};
static const unsigned tune_ns[] = {10, 100, 255};
static const double held_rates[] = {0.3, 2, 6};
static const double held_sigmas[] = {2, 5};
static const unsigned held_ns[] = {20, 50, 160};

static void report(const char *name, struct worst w) {
    print_message(
        "%s: within 3 sd >= %.2f %%, beyond 6 sd <= %.3f %%, silent beyond 3 sd <= %.2f %%, "
        "silent beyond 6 sd <= %.3f %%, err/sd <= %.3f\n",
        name, w.within3, w.beyond6, w.silent3, w.silent6, w.ratio);
}

/* The goals where they are met: a 1°/s tilt with a 5 mm/s approach, σ 1 mm, N = 255, every
 * estimator, sliding (tuning set; tumbling: 2 of 360 windows beyond 6 sd, see the doc). Fails on
 * the code without the ramp statistics: the approach's share of each sensor's variance hid the
 * tilt's lag (consensus 75 % within 3 sd, the Kalman filter with Q = 0 90 %, on the full table's
 * two seeds). */
static void test_ramps_slow_tilt_with_approach(void **state) {
    (void)state;
    static const double rates[] = {1};
    static const double sigmas[] = {1};
    static const unsigned ns[] = {255};
    const struct sweep sw = {
        "1 deg/s, N 255", rates, 1, sigmas, 1, ns, 1, 1, 1, 3000, 12, 2u, 0, false};
    const struct worst w = run_sweep(&sw, false);
    report("1 deg/s, sigma 1 mm, N 255", w);
    assert_true(w.within3 >= 95.0);
    assert_true(w.silent3 <= 5.0);
    assert_true(w.silent6 <= 0.1);
}

/* The goals for a slow tilt (0.1°/s) at short windows and high noise, sliding, every
 * estimator: a filter that outlives its windows and lags by less than one window's noise.
 * Fails on the code before the Kalman filter's learnt lag: with Q = 0, 88 %
 * within 3 sd and 5.9 % beyond 6 sd, `ok`, at σ 7 mm. */
static void test_ramps_slow_tilt_short_windows(void **state) {
    (void)state;
    static const double rates[] = {0.1};
    static const double sigmas[] = {3, 7};
    static const unsigned ns[] = {10};
    const struct sweep sw = {
        "0.1 deg/s, N 10", rates, 1, sigmas, 2, ns, 1, 1, 1, 5000, 0, 2u, 0, false};
    const struct worst w = run_sweep(&sw, false);
    report("0.1 deg/s, sigma 3 and 7 mm, N 10", w);
    assert_true(w.within3 >= 95.0);
    assert_true(w.silent3 <= 5.0);
    assert_true(w.silent6 <= 0.1);
}

/* A guard, not the goal: the reduced sweep of both sets (tuning: 1 and 10 °/s, σ 1 and
 * 7 mm, N 10 and 100; held out: 6 °/s, σ 5 mm, N 20 and 50) must not get worse than what
 * docs/explanation/accuracy.md "Ramps" reports (the goals are missed there: fast ramps in a
 * sliding window's last rows, the Kalman filter with Q = 0 or a fixed Q). */
static void test_ramps_reduced_guard(void **state) {
    (void)state;
    static const double t_rates[] = {1, 10};
    static const double t_sigmas[] = {1, 7};
    static const unsigned t_ns[] = {10, 100};
    const struct sweep tune = {
        "tuning (reduced)", t_rates, 2, t_sigmas, 2, t_ns, 2, 1, 1, 3000, 20, 0u, 0, false};
    const struct worst wt = run_sweep(&tune, false);
    report("tuning, reduced", wt);
    static const double h_rates[] = {6};
    static const double h_sigmas[] = {5};
    static const unsigned h_ns[] = {20, 50};
    const struct sweep held = {
        "held out (reduced)", h_rates, 1, h_sigmas, 1, h_ns, 2, 101, 1, 3000, 20, 0u, 0, false};
    const struct worst wh = run_sweep(&held, false);
    report("held out, reduced", wh);
    assert_true(wt.within3 >= GUARD_WITHIN3 && wh.within3 >= GUARD_WITHIN3);
    assert_true(wt.silent6 <= GUARD_SILENT6 && wh.silent6 <= GUARD_SILENT6);
}

/* The plate's rate bound (attitude_config.max_rate_mdeg_s): a plate ramping at its bound,
 * 0.2 (a docking plate), 1 (the default) and 10 °/s (a bench plate by hand), σ 2 mm, N 20,
 * 100 and 250, both modes: every answered row honest (goals: >= 95 % within 3 sd, <= 0.1 %
 * beyond 6 sd) for the consensus and the Kalman filter as the unit runs them (a window's
 * filter in tumbling mode, a fixed or learnt Q in sliding mode). The Kalman filter with
 * Q = 0 in sliding windows, a configuration for a still plate that remembers every row
 * since its restart, is printed (RAMPS_PRINT=1) but not held to them: 94.5 % within 3 sd
 * and 0.24 % beyond 6 sd at 1°/s, N = 20. */
static void test_ramps_at_the_rate_bound(void **state) {
    (void)state;
    static const double rates[] = {0.2, 1, 10};
    static const double sigmas[] = {2};
    static const unsigned ns[] = {20, 100, 250};
    const struct sweep sw = {"at the bound", rates, 3,  sigmas,        1,   ns, 3, 7, 1,
                             3000,           12,    0u, BOUND_AT_RATE, true};
    const struct worst w = run_sweep(&sw, getenv("RAMPS_PRINT") != NULL);
    report("plate at its rate bound (0.2, 1, 10 deg/s), sigma 2 mm, N 20-250", w);
    assert_true(w.within3 >= 95.0);
    assert_true(w.beyond6 <= 0.1);
}

int main(int argc, char **argv) {
    if (argc == 8 && strcmp(argv[1], "--debug") == 0) { /* rate sigma n mode(0/1) variant seed */
        struct scenario sc = {.rate_dps = atof(argv[2]),
                              .sigma_mm = atof(argv[3]),
                              .n = (unsigned)atoi(argv[4]),
                              .mode = atoi(argv[5]) != 0 ? ATTITUDE_SLIDING : ATTITUDE_TUMBLING,
                              .seed = (uint64_t)atoi(argv[7]),
                              .bound_dps = BOUND_DEFAULT};
        debug_variant = atoi(argv[6]);
        sc.rows = 30u * sc.n > 5000u ? 30u * sc.n : 5000u;
        struct tally t[V_COUNT][2];
        (void)memset(t, 0, sizeof t);
        run(&sc, t);
        struct worst w = {100.0, 0.0, 0.0, 0.0, 0.0};
        print_row(&sc, (enum variant)debug_variant, t[debug_variant], true, &w);
        return 0;
    }
    if (argc > 1 && strcmp(argv[1], "--table") == 0) {
        const struct sweep tune = {"Tuning set (seeds 1-2)",
                                   tune_rates,
                                   4,
                                   tune_sigmas,
                                   3,
                                   tune_ns,
                                   3,
                                   1,
                                   2,
                                   5000,
                                   30,
                                   0u,
                                   0,
                                   false};
        const struct sweep held = {"Held-out set (seeds 101-102)",
                                   held_rates,
                                   3,
                                   held_sigmas,
                                   2,
                                   held_ns,
                                   3,
                                   101,
                                   2,
                                   5000,
                                   30,
                                   0u,
                                   0,
                                   false};
        const bool only_held = argc > 2 && strcmp(argv[2], "held") == 0;
        const bool only_tune = argc > 2 && strcmp(argv[2], "tune") == 0;
        if (!only_held) {
            (void)run_sweep(&tune, true);
        }
        if (!only_tune) {
            (void)run_sweep(&held, true);
        }
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ramps_slow_tilt_with_approach),
        cmocka_unit_test(test_ramps_slow_tilt_short_windows),
        cmocka_unit_test(test_ramps_reduced_guard),
        cmocka_unit_test(test_ramps_at_the_rate_bound),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
