/* host_sim calibrate's fit: exact on noise-free stations, stated sd matching the scatter
 * over many seeds (white, AR(1) and drifting noise), one distance, what it cannot fit. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>

#include "calibrate/calfit.h"
#include "calibrate/fixture.h"
#include "scene/geometry.h"

static void assert_close(double got, double want, double tol) {
    if (!(fabs(got - want) <= tol)) {
        fail_msg("got %.17g, want %.17g (tolerance %.3g)", got, want, tol);
    }
}

/* Noise-free readings raw = g·x + o (unrounded), stations at several attitudes and
 * distances, rows without truth between them: the fit gives o and g to 1e-6. */
static void test_exact_noise_free(void **state) {
    (void)state;
    const double o[4] = {-3.105, 7.882, 0.516, -12.34};
    const double g[4] = {1.0041, 0.99187, 1.01202, 0.99655};
    const double dist[5] = {60.0, 95.0, 130.0, 165.0, 200.0};
    const double att[4][2] = {{0, 0}, {5, -5}, {-10, 10}, {10, 5}};
    struct calfit_data d;
    calfit_init(&d, 30.0, 0.0);
    uint32_t t = 0;
    for (unsigned s = 0; s < 10u; ++s) {
        double x[4];
        scene_ideal_distances(30.0, dist[s % 5u], att[s % 4u][0], att[s % 4u][1], x);
        double raw[4];
        const bool valid[4] = {true, true, true, true};
        for (unsigned k = 0; k < 4u; ++k) {
            raw[k] = g[k] * x[k] + o[k];
        }
        for (unsigned i = 0; i < 50u; ++i, t += 20u) {
            assert_int_equal(calfit_add(&d, true, att[s % 4u][0], att[s % 4u][1], dist[s % 5u], raw,
                                        valid, t, 0u),
                             0);
        }
        assert_int_equal(calfit_add(&d, false, 0, 0, 0, raw, valid, t, 0u), 0);
    }
    struct calfit_result res;
    char err[256] = "";
    assert_int_equal(calfit_run(&d, &res, err, sizeof err), 0);
    assert_true(res.gains);
    assert_int_equal(d.n_stations, 10);
    assert_int_equal(d.rows_no_truth, 10);
    for (unsigned k = 0; k < 4u; ++k) {
        assert_close(res.sensor[k].offset_mm, o[k], 1e-6);
        assert_close(res.sensor[k].gain, g[k], 1e-6);
        assert_true(res.sensor[k].offset_sd_mm < 1e-4);
    }
    calfit_free(&d);
}

struct zstats {
    double sum2_offset, sum2_gain, max_abs;
    unsigned n;
    double sd_offset_sum;
};

/* Runs the fixture cfg over seeds, accumulating normalised errors of offsets and gains. */
static void many_seeds(const struct fixture_config *cfg, unsigned seeds, struct zstats *z) {
    memset(z, 0, sizeof *z);
    for (unsigned seed = 1; seed <= seeds; ++seed) {
        struct fixture_gen gen;
        char err[256] = "";
        assert_int_equal(fixture_gen_init(&gen, cfg, seed, err, sizeof err), 0);
        struct calfit_data d;
        calfit_init(&d, cfg->arm_mm, 1.0);
        struct scene_row row;
        uint32_t line = 10;
        while (fixture_gen_next(&gen, &row, NULL, err, sizeof err) == 0) {
            assert_int_equal(calfit_add_row(&d, &row, line++), 0);
        }
        struct calfit_result res;
        if (calfit_run(&d, &res, err, sizeof err) != 0) {
            fail_msg("seed %u: %s", seed, err);
        }
        for (unsigned k = 0; k < 4u; ++k) {
            const struct calfit_sensor *s = &res.sensor[k];
            const double zo = (s->offset_mm - gen.offset_mm[k]) / s->offset_sd_mm;
            z->sum2_offset += zo * zo;
            z->sd_offset_sum += s->offset_sd_mm;
            double zg = 0.0;
            if (res.gains) {
                zg = (s->gain - gen.gain[k]) / s->gain_sd;
                z->sum2_gain += zg * zg;
            }
            const double m = fabs(zo) > fabs(zg) ? fabs(zo) : fabs(zg);
            if (m > z->max_abs) {
                z->max_abs = m;
            }
            if (m >= 4.0) {
                fail_msg("seed %u sensor %c: offset %.4f (true %.4f, sd %.4f), gain %.6f (true "
                         "%.6f, sd %.6f): beyond 4 sd",
                         seed, 'A' + k, s->offset_mm, gen.offset_mm[k], s->offset_sd_mm, s->gain,
                         gen.gain[k], s->gain_sd);
            }
            z->n++;
        }
        calfit_free(&d);
        fixture_gen_free(&gen);
    }
}

static void check_rms(const char *what, const struct zstats *z, bool gains) {
    const double rms_o = sqrt(z->sum2_offset / z->n);
    const double rms_g = gains ? sqrt(z->sum2_gain / z->n) : 1.0;
    print_message("%s: %u fits, RMS normalised error offset %.3f gain %.3f, max |z| %.2f, "
                  "mean offset sd %.4f mm\n",
                  what, z->n, rms_o, rms_g, z->max_abs, z->sd_offset_sum / z->n);
    assert_true(rms_o >= 0.8 && rms_o <= 1.25);
    assert_true(rms_g >= 0.8 && rms_g <= 1.25);
}

/* A shorter fixture than the named one (the tests run under the sanitizers). */
static void test_config(const char *name, struct fixture_config *cfg) {
    assert_int_equal(fixture_named(name, cfg), 0);
    cfg->readings_per_station = 300u;
}

static void test_white_noise_many_seeds(void **state) {
    (void)state;
    struct fixture_config cfg;
    test_config("fixture", &cfg);
    struct zstats z;
    many_seeds(&cfg, 200u, &z);
    check_rms("white sigma 2 mm", &z, true);
}

static void test_ar1_noise_many_seeds(void **state) {
    (void)state;
    struct fixture_config cfg;
    test_config("fixture-ar1", &cfg);
    struct zstats z;
    many_seeds(&cfg, 200u, &z);
    check_rms("AR(1) phi 0.9", &z, true);
}

static void test_drift_many_seeds(void **state) {
    (void)state;
    struct fixture_config cfg;
    test_config("fixture-drift", &cfg);
    struct zstats z;
    many_seeds(&cfg, 200u, &z);
    check_rms("drift up to 0.5 mm over the run", &z, true);
}

/* One distance: offsets only; the offsets make gain 1 right at that distance. */
static void test_one_distance(void **state) {
    (void)state;
    struct fixture_config cfg;
    test_config("fixture-one-distance", &cfg);
    struct fixture_gen gen;
    char err[256] = "";
    assert_int_equal(fixture_gen_init(&gen, &cfg, 5u, err, sizeof err), 0);
    struct calfit_data d;
    calfit_init(&d, cfg.arm_mm, 1.0);
    struct scene_row row;
    while (fixture_gen_next(&gen, &row, NULL, err, sizeof err) == 0) {
        assert_int_equal(calfit_add_row(&d, &row, 0u), 0);
    }
    struct calfit_result res;
    assert_int_equal(calfit_run(&d, &res, err, sizeof err), 0);
    assert_false(res.gains);
    for (unsigned k = 0; k < 4u; ++k) {
        const struct calfit_sensor *s = &res.sensor[k];
        const double want = gen.offset_mm[k] + (gen.gain[k] - 1.0) * 100.0;
        assert_true(fabs(s->offset_mm - want) < 4.0 * s->offset_sd_mm + 0.06);
        assert_close(s->gain, 1.0, 0.0);
        assert_close(s->gain_sd, 0.0, 0.0);
        assert_int_equal(s->dof, 19);
    }
    calfit_free(&d);
    fixture_gen_free(&gen);
}

/* What it cannot fit: the message names what is missing. */
static void expect_error(struct calfit_data *d, const char *want) {
    struct calfit_result res;
    char err[512] = "";
    assert_int_equal(calfit_run(d, &res, err, sizeof err), -1);
    if (strstr(err, want) == NULL) {
        fail_msg("error '%s' does not say '%s'", err, want);
    }
}

static void add_station(struct calfit_data *d, double dist, unsigned rows, const bool valid[4]) {
    double x[4];
    scene_ideal_distances(d->arm_mm, dist, 0.0, 0.0, x);
    for (unsigned i = 0; i < rows; ++i) {
        double raw[4];
        for (unsigned k = 0; k < 4u; ++k) {
            raw[k] = x[k] + (double)(i % 3u);
        }
        assert_int_equal(calfit_add(d, true, 0.0, 0.0, dist, raw, valid, i, 0u), 0);
    }
    assert_int_equal(calfit_add(d, false, 0, 0, 0, x, valid, 0, 0u), 0);
}

static void test_errors(void **state) {
    (void)state;
    const bool all[4] = {true, true, true, true};
    struct calfit_data d;
    calfit_init(&d, 30.0, 1.0);
    expect_error(&d, "no row carries truth");
    struct scene_row row = {.has_alpha = true, .has_beta = true, .present = {1, 1, 1, 1}};
    assert_int_equal(calfit_add_row(&d, &row, 4u), 0);
    assert_int_equal(d.rows_partial_truth, 1);
    assert_int_equal(d.rows_no_truth, 0);
    expect_error(&d, "no row carries all of alpha_deg, beta_deg and distance_mm");
    calfit_free(&d);

    calfit_init(&d, 30.0, 1.0);
    add_station(&d, 100.0, 20u, all);
    add_station(&d, 150.0, 20u, all);
    expect_error(&d, "2 stations (runs of rows with the same truth), the fit needs at least 3");
    calfit_free(&d);

    /* Sensor B valid at one distance only: its gain cannot be told from its offset. */
    calfit_init(&d, 30.0, 1.0);
    const bool no_b[4] = {true, false, true, true};
    add_station(&d, 100.0, 20u, all);
    add_station(&d, 150.0, 20u, no_b);
    add_station(&d, 100.0, 20u, all);
    add_station(&d, 200.0, 20u, no_b);
    expect_error(&d, "sensor B: 2 stations with at least 10 valid readings, the fit needs 3");
    add_station(&d, 100.0, 20u, all);
    expect_error(&d, "sensor B: its stations' true distances are all 100.000 mm");
    assert_int_equal(d.invalid[1], 40);
    calfit_free(&d);
}

/* The autocorrelation time of AR(1) noise, φ = 0.9: τ = (1 + φ)/(1 − φ) = 19. */
static void test_tau_of_ar1(void **state) {
    (void)state;
    struct fixture_config cfg;
    assert_int_equal(fixture_named("fixture-ar1", &cfg), 0);
    double sum = 0.0;
    unsigned settled = 0;
    for (unsigned seed = 1; seed <= 10u; ++seed) {
        struct fixture_gen gen;
        char err[256] = "";
        assert_int_equal(fixture_gen_init(&gen, &cfg, seed, err, sizeof err), 0);
        struct calfit_data d;
        calfit_init(&d, cfg.arm_mm, 1.0);
        struct scene_row row;
        while (fixture_gen_next(&gen, &row, NULL, err, sizeof err) == 0) {
            assert_int_equal(calfit_add_row(&d, &row, 0u), 0);
        }
        struct calfit_result res;
        assert_int_equal(calfit_run(&d, &res, err, sizeof err), 0);
        for (unsigned k = 0; k < 4u; ++k) {
            settled += res.sensor[k].tau_settled ? 1u : 0u;
            sum += res.sensor[k].tau;
        }
        calfit_free(&d);
        fixture_gen_free(&gen);
    }
    /* Sokal's window (5τ = 95 lags) in stations of 700 readings: most settle; the rest
     * stop where the window would reach a quarter of a station and say so. */
    print_message("AR(1) phi 0.9: mean tau %.2f (true 19), %u of 40 settled\n", sum / 40.0,
                  settled);
    assert_true(settled >= 20u);
    assert_close(sum / 40.0, 19.0, 2.5);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_noise_free),     cmocka_unit_test(test_white_noise_many_seeds),
        cmocka_unit_test(test_ar1_noise_many_seeds), cmocka_unit_test(test_drift_many_seeds),
        cmocka_unit_test(test_one_distance),         cmocka_unit_test(test_errors),
        cmocka_unit_test(test_tau_of_ar1),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
