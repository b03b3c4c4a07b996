/*
 * A librating plate through the facade: is an oscillation seen as motion before an `ok`
 * row can be wrong?
 *
 * The plate tilts about a random axis through its centre: α = A cos ψ sin(2π f t + φ),
 * β = A sin ψ sin(2π f t + φ), x̄ fixed in 100..400 mm, a = 30 mm, 50 rows/s, white
 * Gaussian noise σ on every reading rounded to whole mm, an exact calibration. Every row
 * goes through attitude_push_sample() as the firmware calls it. Scored per answered value
 * (α, β, x̄) against the truth at the row's time: `ok` rows beyond 6 sd (goal 0), rows
 * beyond 6 sd whose `why` does not say `motion` (goal ≤ 0.1 %), and the share of windows
 * `ok`. Estimators: consensus and Kalman (Q = 0 in tumbling windows, auto in sliding ones,
 * as host_sim replay defaults); tumbling and sliding windows.
 *
 * Two sets: the tuning set (f 0.05, 0.25, 0.5, 2, 5 Hz; A 0.2, 1, 2, 3°; σ 1, 3 mm;
 * N 20, 100, 250; seeds 1–2), the only one the detector's thresholds were looked at on,
 * and the held-out set (f 0.1, 0.35, 0.8, 1.5, 3.5 Hz; A 0.5, 1.5, 2.5°; σ 1.5, 2 mm;
 * N 35, 60, 160, 200; seeds 101–102). Clean static runs (A = 0) give the share of `ok`
 * windows the detector must not cost.
 *
 * Not met: an oscillation whose variance is small against the noise's (σ 2–3 mm, a
 * period near the window or a few rows) leaves the angle combinations' scatter within the
 * parity's sampling spread while the row's attitude is beyond 6 sd of the window mean;
 * test_oscillation_goal_report prints those counts, GOAL NOT MET.
 *
 *   test_oscillation           the ctest: the fast, large oscillations asserted; the
 *                              window-synchronous case and a reduced held-out sweep reported
 *   test_oscillation --table   every scenario, one line each, and the totals
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

#define TEST_PI  3.14159265358979323846
#define PERIOD_S 0.02 /* 50 rows/s */
#define ARM_MM   30.0

enum variant { V_CONSENSUS, V_KALMAN, V_COUNT };
static const char *const variant_name[V_COUNT] = {"consensus", "kalman"};

struct scenario {
    double freq_hz;
    double amp_deg; /* 0: a static plate */
    double sigma_mm;
    unsigned n;
    enum attitude_window_mode mode;
    uint64_t seed;
    unsigned rows;
};

struct tally {
    unsigned long rows;     /* estimates (one per window end) */
    unsigned long ok;       /* ... `ok` */
    unsigned long answered; /* values answered (α, β, x̄ with an sd) */
    unsigned long ok6;      /* values beyond 6 sd in an `ok` row */
    unsigned long silent6;  /* values beyond 6 sd whose why does not say `motion` */
    unsigned long beyond6;
    unsigned long ok6_axis[3]; /* ok6 by value: α, β, x̄ */
};

static struct attitude_state st;
static struct attitude_output out;

static void score_value(struct tally *t, const struct attitude_estimate *e, unsigned axis,
                        bool valid, double est, double sd, double truth) {
    if (!valid || sd <= 0) {
        return;
    }
    const double err = fabs(est - truth);
    t->answered++;
    if (err > 6 * sd) {
        t->beyond6++;
        t->ok6 += e->status == ATTITUDE_OK ? 1u : 0u;
        t->ok6_axis[axis] += e->status == ATTITUDE_OK ? 1u : 0u;
        t->silent6 += (e->why & ATTITUDE_WHY_MOTION) == 0u ? 1u : 0u;
    }
}

/* Runs one scenario for one estimator; its tally is added to t. */
static void run(const struct scenario *sc, enum variant v, struct tally *t) {
    struct test_rng rng = {sc->seed * 0x9E3779B97F4A7C15u + 7u};
    const double psi = 2 * TEST_PI * test_urand(&rng);
    const double phase = 2 * TEST_PI * test_urand(&rng);
    const double xm = 100 + 300 * test_urand(&rng);
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.window = (uint16_t)sc->n;
    cfg.mode = sc->mode;
    cfg.estimators =
        ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS) | ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN);
    (void)memset(&cfg.calibration, 0, sizeof cfg.calibration);
    cfg.calibration.calibrated = true;
    cfg.kalman_process_noise_auto = sc->mode == ATTITUDE_SLIDING;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    static const uint8_t ok4[4] = {0, 0, 0, 0};
    static const bool present4[4] = {true, true, true, true};
    const enum attitude_estimator which =
        v == V_CONSENSUS ? ATTITUDE_EST_CONSENSUS : ATTITUDE_EST_KALMAN;
    for (unsigned row = 0; row < sc->rows; ++row) {
        const double s = sin(2 * TEST_PI * sc->freq_hz * row * PERIOD_S + phase);
        const double al = sc->amp_deg * cos(psi) * s;
        const double be = sc->amp_deg * sin(psi) * s;
        const double ta = ARM_MM * tan(al * TEST_PI / 180);
        const double tb = ARM_MM * tan(be * TEST_PI / 180);
        const double x[4] = {xm - ta, xm + tb, xm + ta, xm - tb};
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            const long z = lround(x[k] + sc->sigma_mm * test_gauss(&rng));
            r[k] = (uint16_t)(z < 1 ? 1 : (z > 4000 ? 4000 : z));
        }
        if (!attitude_push_sample(&st, r, ok4, present4, &out)) {
            continue;
        }
        const struct attitude_estimate *e = &out.est[which];
        t->rows++;
        t->ok += e->status == ATTITUDE_OK ? 1u : 0u;
        score_value(t, e, 0u, e->alpha_valid, e->alpha_udeg * 1e-6, e->alpha_sd_udeg * 1e-6, al);
        score_value(t, e, 1u, e->beta_valid, e->beta_udeg * 1e-6, e->beta_sd_udeg * 1e-6, be);
        score_value(t, e, 2u, e->distance_valid, e->distance_um * 1e-3, e->distance_sd_um * 1e-3,
                    xm);
    }
}

struct sweep {
    const char *name;
    const double *freqs;
    unsigned n_freqs;
    const double *amps;
    unsigned n_amps;
    const double *sigmas;
    unsigned n_sigmas;
    const unsigned *ns;
    unsigned n_ns;
    uint64_t seed0;
    unsigned seeds;
    unsigned windows; /* rows per run: windows · N, at least 1500 */
};

static void add(struct tally *a, const struct tally *b) {
    a->rows += b->rows;
    a->ok += b->ok;
    a->answered += b->answered;
    a->ok6 += b->ok6;
    a->silent6 += b->silent6;
    a->beyond6 += b->beyond6;
    for (unsigned i = 0; i < 3u; ++i) {
        a->ok6_axis[i] += b->ok6_axis[i];
    }
}

static void print_tally(const char *label, const struct tally *t) {
    printf("%-46s rows %7lu ok %6.2f%%  beyond6 %6lu  ok-beyond6 %5lu  unsaid-beyond6 %5lu "
           "(%.3f%%) ok6 a/b/x %lu/%lu/%lu\n",
           label, t->rows, t->rows ? 100.0 * (double)t->ok / (double)t->rows : 0.0, t->beyond6,
           t->ok6, t->silent6, t->answered ? 100.0 * (double)t->silent6 / (double)t->answered : 0.0,
           t->ok6_axis[0], t->ok6_axis[1], t->ok6_axis[2]);
}

/* Runs every scenario of sw; totals per estimator and mode in tot[v][mode]. */
static void run_sweep(const struct sweep *sw, bool print, struct tally tot[V_COUNT][2]) {
    (void)memset(tot, 0, sizeof(struct tally) * V_COUNT * 2u);
    for (unsigned fi = 0; fi < sw->n_freqs; ++fi) {
        for (unsigned ai = 0; ai < sw->n_amps; ++ai) {
            for (unsigned si = 0; si < sw->n_sigmas; ++si) {
                for (unsigned ni = 0; ni < sw->n_ns; ++ni) {
                    for (unsigned m = 0; m < 2u; ++m) {
                        for (unsigned v = 0; v < V_COUNT; ++v) {
                            struct tally t = {0};
                            for (unsigned s = 0; s < sw->seeds; ++s) {
                                const unsigned n = sw->ns[ni];
                                const unsigned rows =
                                    sw->windows * n < 1500u ? 1500u : sw->windows * n;
                                const struct scenario sc = {.freq_hz = sw->freqs[fi],
                                                            .amp_deg = sw->amps[ai],
                                                            .sigma_mm = sw->sigmas[si],
                                                            .n = n,
                                                            .mode = m == 0u ? ATTITUDE_TUMBLING
                                                                            : ATTITUDE_SLIDING,
                                                            .seed = sw->seed0 + s,
                                                            .rows = rows};
                                run(&sc, (enum variant)v, &t);
                            }
                            add(&tot[v][m], &t);
                            if (print) {
                                char label[96];
                                (void)snprintf(
                                    label, sizeof label, "%s f %.2f A %.1f s %.1f N %3u %s %s",
                                    sw->name, sw->freqs[fi], sw->amps[ai], sw->sigmas[si],
                                    sw->ns[ni], m == 0u ? "tumb" : "slid", variant_name[v]);
                                print_tally(label, &t);
                            }
                        }
                    }
                }
            }
        }
    }
}

static void print_totals(const char *name, struct tally tot[V_COUNT][2]) {
    for (unsigned v = 0; v < V_COUNT; ++v) {
        for (unsigned m = 0; m < 2u; ++m) {
            char label[96];
            (void)snprintf(label, sizeof label, "TOTAL %s %s %s", name, variant_name[v],
                           m == 0u ? "tumbling" : "sliding");
            print_tally(label, &tot[v][m]);
        }
    }
}

static const double tune_freqs[] = {0.05, 0.25, 0.5, 2, 5};
static const double tune_amps[] = {0.2, 1, 2, 3};
static const double tune_sigmas[] = {1, 3};
static const unsigned tune_ns[] = {20, 100, 250};
static const double held_freqs[] = {0.1, 0.35, 0.8, 1.5, 3.5};
static const double held_amps[] = {0.5, 1.5, 2.5};
static const double held_sigmas[] = {1.5, 2};
static const unsigned held_ns[] = {35, 60, 160, 200};
static const double still_freqs[] = {1};
static const double still_amps[] = {0};
static const double still_sigmas[] = {1, 2, 3};
static const unsigned still_ns[] = {20, 50, 100, 250};

#define COUNT(a) (unsigned)(sizeof(a) / sizeof((a)[0]))

static const struct sweep tune = {"tune",
                                  tune_freqs,
                                  COUNT(tune_freqs),
                                  tune_amps,
                                  COUNT(tune_amps),
                                  tune_sigmas,
                                  COUNT(tune_sigmas),
                                  tune_ns,
                                  COUNT(tune_ns),
                                  1,
                                  2,
                                  20};
static const struct sweep held = {"held",
                                  held_freqs,
                                  COUNT(held_freqs),
                                  held_amps,
                                  COUNT(held_amps),
                                  held_sigmas,
                                  COUNT(held_sigmas),
                                  held_ns,
                                  COUNT(held_ns),
                                  101,
                                  2,
                                  20};
static const struct sweep still = {"still",
                                   still_freqs,
                                   COUNT(still_freqs),
                                   still_amps,
                                   COUNT(still_amps),
                                   still_sigmas,
                                   COUNT(still_sigmas),
                                   still_ns,
                                   COUNT(still_ns),
                                   201,
                                   3,
                                   30};

/* Asserts the goals: no `ok` row beyond 6 sd, ≤ 0.1 % beyond 6 sd unsaid. */
static void check(struct tally tot[V_COUNT][2]) {
    for (unsigned v = 0; v < V_COUNT; ++v) {
        for (unsigned m = 0; m < 2u; ++m) {
            assert_int_equal(tot[v][m].ok6, 0);
            assert_true(tot[v][m].silent6 * 1000u <= tot[v][m].answered);
        }
    }
}

/* Prints whether the goals are met, loudly when not: the cases the detector does not yet
 * cover (docs: what falls short), measured but not asserted. */
static void report_goal(const char *name, struct tally tot[V_COUNT][2]) {
    unsigned long ok6 = 0;
    for (unsigned v = 0; v < V_COUNT; ++v) {
        for (unsigned m = 0; m < 2u; ++m) {
            ok6 += tot[v][m].ok6;
        }
    }
    print_totals(name, tot);
    if (ok6 != 0u) {
        printf("GOAL NOT MET (measured, not asserted): %s: %lu ok values beyond 6 sd\n", name, ok6);
    }
}

/* An oscillation with many periods in the window (2 and 5 Hz, 3°, σ 1 mm, N 100 and 250):
 * the window mean is the plate's mean attitude, the row's own up to 3° from it; the
 * detector must say it or carry it. */
static void test_oscillation_fast_large(void **state) {
    (void)state;
    static const double f[] = {5};
    static const double a[] = {3};
    static const double s[] = {1};
    static const unsigned n[] = {100, 250};
    const struct sweep sw = {"fast", f, 1, a, 1, s, 1, n, 2, 1, 2, 20};
    struct tally tot[V_COUNT][2];
    run_sweep(&sw, false, tot);
    print_totals("fast", tot);
    check(tot);
}

/* The window-synchronous case the red team found (0.5 Hz at N = 100, 2°, σ 2 mm) and a
 * reduced held-out sweep: reported, not asserted (not met: see the module comment). */
static void test_oscillation_goal_report(void **state) {
    (void)state;
    static const double f1[] = {0.5};
    static const double a1[] = {2};
    static const double s1[] = {2};
    static const unsigned n1[] = {100};
    const struct sweep sync = {"sync", f1, 1, a1, 1, s1, 1, n1, 1, 11, 2, 20};
    static const double f2[] = {0.35, 1.5};
    static const double a2[] = {1.5, 2.5};
    static const double s2[] = {2};
    static const unsigned n2[] = {35, 160};
    const struct sweep held_reduced = {"held-reduced", f2, 2, a2, 2, s2, 1, n2, 2, 101, 1, 20};
    struct tally tot[V_COUNT][2];
    run_sweep(&sync, false, tot);
    report_goal("sync", tot);
    run_sweep(&held_reduced, false, tot);
    report_goal("held-reduced", tot);
}

int main(int argc, char **argv) {
    if (argc > 1 && strcmp(argv[1], "--table") == 0) {
        const char *only = argc > 2 ? argv[2] : NULL;
        const struct sweep *sets[3] = {&tune, &held, &still};
        for (unsigned i = 0; i < 3u; ++i) {
            if (only != NULL && strcmp(only, sets[i]->name) != 0) {
                continue;
            }
            struct tally tot[V_COUNT][2];
            run_sweep(sets[i], getenv("OSC_QUIET") == NULL, tot);
            print_totals(sets[i]->name, tot);
        }
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_oscillation_fast_large),
        cmocka_unit_test(test_oscillation_goal_report),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
