/* host_sim calibrate's thermal fit: exact on noise-free stations, each coefficient within 4 of
 * its stated sd over a sweep of coefficient ranges, spans and seeds (held-out seeds apart), and
 * the coefficient said unknown when the stations cannot give it. */
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

/* Noise-free stations raw = g·x + o + k·(T − 25) at three temperatures: the fit gives o at the
 * stations' mean temperature, g and k to 1e-6. */
static void test_exact_noise_free(void **state) {
    (void)state;
    const double o[4] = {-3.105, 7.882, 0.516, -12.34};
    const double g[4] = {1.0041, 0.99187, 1.01202, 0.99655};
    const double k[4] = {0.02, -0.0375, 0.0, 0.2};
    const double dist[5] = {60.0, 95.0, 130.0, 165.0, 200.0};
    const double att[4][2] = {{0, 0}, {5, -5}, {-10, 10}, {10, 5}};
    const double temps[3] = {5.0, 20.0, 41.0};
    struct calfit_data d;
    calfit_init(&d, 30.0, 0.0);
    uint32_t t = 0;
    double tsum = 0.0;
    for (unsigned s = 0; s < 12u; ++s) {
        const double temp = temps[s % 3u];
        tsum += temp;
        double x[4];
        scene_ideal_distances(30.0, dist[s % 5u], att[s % 4u][0], att[s % 4u][1], x);
        double raw[4];
        const bool valid[4] = {true, true, true, true};
        for (unsigned i = 0; i < 4u; ++i) {
            raw[i] = g[i] * x[i] + o[i] + k[i] * (temp - 25.0);
        }
        for (unsigned i = 0; i < 50u; ++i, t += 20u) {
            assert_int_equal(calfit_add_temp(&d, true, att[s % 4u][0], att[s % 4u][1], dist[s % 5u],
                                             raw, valid, true, temp, t, 0u),
                             0);
        }
        assert_int_equal(calfit_add(&d, false, 0, 0, 0, raw, valid, t, 0u), 0);
    }
    struct calfit_result res;
    char err[256] = "";
    assert_int_equal(calfit_run(&d, &res, err, sizeof err), 0);
    assert_true(res.thermal);
    assert_int_equal(res.thermal_state, CALFIT_THERMAL_FITTED);
    const double tc = round(tsum / 12.0 * 100.0) / 100.0;
    assert_close(res.cal_temp_c, tc, 1e-9);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_close(res.sensor[i].temp_coeff_mm_per_c, k[i], 1e-6);
        assert_close(res.sensor[i].offset_mm, o[i] + k[i] * (tc - 25.0), 1e-6);
        assert_close(res.sensor[i].gain, g[i], 1e-6);
    }
    calfit_free(&d);
}

struct zstats {
    double sum2_coeff, sum2_offset, max_abs, sd_coeff_sum;
    unsigned n;
};

/* Runs cfg over seeds first..first+seeds−1; every coefficient, offset (at cal_temp_c) and
 * gain within 4 of its stated sd of the truth. */
static void many_seeds(const struct fixture_config *cfg, uint64_t first, unsigned seeds,
                       struct zstats *z) {
    memset(z, 0, sizeof *z);
    for (uint64_t seed = first; seed < first + seeds; ++seed) {
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
            fail_msg("seed %llu: %s", (unsigned long long)seed, err);
        }
        assert_true(res.thermal);
        for (unsigned k = 0; k < 4u; ++k) {
            const struct calfit_sensor *s = &res.sensor[k];
            const double k_true = gen.coeff_mm_per_c[k];
            const double o_true = gen.offset_mm[k] + k_true * (res.cal_temp_c - cfg->temp_ref_c);
            const double zk = (s->temp_coeff_mm_per_c - k_true) / s->temp_coeff_sd_mm_per_c;
            const double zo = (s->offset_mm - o_true) / s->offset_sd_mm;
            const double zg = (s->gain - gen.gain[k]) / s->gain_sd;
            z->sum2_coeff += zk * zk;
            z->sum2_offset += zo * zo;
            z->sd_coeff_sum += s->temp_coeff_sd_mm_per_c;
            const double m = fmax(fabs(zk), fmax(fabs(zo), fabs(zg)));
            z->max_abs = fmax(z->max_abs, m);
            if (m >= 4.0) {
                fail_msg("seed %llu sensor %c: coefficient %.6f (true %.6f, sd %.6f), offset "
                         "%.4f (true %.4f, sd %.4f), gain %.6f (true %.6f, sd %.6f): beyond 4 sd",
                         (unsigned long long)seed, 'A' + k, s->temp_coeff_mm_per_c, k_true,
                         s->temp_coeff_sd_mm_per_c, s->offset_mm, o_true, s->offset_sd_mm, s->gain,
                         gen.gain[k], s->gain_sd);
            }
            z->n++;
        }
        calfit_free(&d);
        fixture_gen_free(&gen);
    }
}

static void report(const char *what, const struct zstats *z) {
    const double rms_k = sqrt(z->sum2_coeff / z->n);
    const double rms_o = sqrt(z->sum2_offset / z->n);
    print_message("%s: %u fits, RMS normalised error coefficient %.3f offset %.3f, max |z| "
                  "%.2f, mean coefficient sd %.5f mm/C\n",
                  what, z->n, rms_k, rms_o, z->max_abs, z->sd_coeff_sum / z->n);
    /* the stated sd neither far too small nor far too large (the sweep's 160 fits each) */
    assert_true(rms_k >= 0.75 && rms_k <= 1.3);
    assert_true(rms_o >= 0.75 && rms_o <= 1.3);
}

/* fixture-thermal with 300 readings per station (the tests run under the sanitizers). */
static void thermal_config(struct fixture_config *cfg, double coeff_range, double span_c) {
    assert_int_equal(fixture_named("fixture-thermal", cfg), 0);
    cfg->readings_per_station = 300u;
    cfg->coeff_range_mm_per_c = coeff_range;
    cfg->temp_c[0] = cfg->temp_ref_c - span_c / 2.0;
    cfg->temp_c[1] = cfg->temp_ref_c;
    cfg->temp_c[2] = cfg->temp_ref_c + span_c / 2.0;
}

/* Coefficient ranges from none to 8 mm over a 40 °C cycle, over a 30 °C span; seeds 1-40 (seen
 * while writing the fit) and 1001-1040 (held out: run once, after). */
static void test_coefficient_sweep(void **state) {
    (void)state;
    const double ranges[5] = {0.0, 0.01, 0.0375, 0.1, 0.2};
    const uint64_t firsts[2] = {1u, 1001u};
    for (unsigned r = 0; r < 5u; ++r) {
        for (unsigned f = 0; f < 2u; ++f) {
            struct fixture_config cfg;
            thermal_config(&cfg, ranges[r], 30.0);
            struct zstats z;
            many_seeds(&cfg, firsts[f], 40u, &z);
            char what[120];
            snprintf(what, sizeof what,
                     "coefficients in +-%.4f mm/C (%.1f mm over 40 C), span 30 C, "
                     "seeds %llu-%llu",
                     ranges[r], ranges[r] * 40.0, (unsigned long long)firsts[f],
                     (unsigned long long)firsts[f] + 39u);
            report(what, &z);
        }
    }
}

/* The span: from the least a coefficient is fitted at to twice the orbit's swing. */
static void test_span_sweep(void **state) {
    (void)state;
    const double spans[3] = {10.5, 20.0, 60.0};
    for (unsigned s = 0; s < 3u; ++s) {
        struct fixture_config cfg;
        thermal_config(&cfg, 0.0375, spans[s]);
        struct zstats z;
        many_seeds(&cfg, 2001u, 40u, &z);
        char what[120];
        snprintf(what, sizeof what, "coefficients in +-0.0375 mm/C, span %.1f C, seeds 2001-2040",
                 spans[s]);
        report(what, &z);
    }
}

/* Fits cfg with seed; returns the result (d freed). */
static struct calfit_result fit_named(const struct fixture_config *cfg, uint64_t seed,
                                      struct calfit_data *d) {
    struct fixture_gen gen;
    char err[256] = "";
    assert_int_equal(fixture_gen_init(&gen, cfg, seed, err, sizeof err), 0);
    calfit_init(d, cfg->arm_mm, 1.0);
    struct scene_row row;
    uint32_t line = 10;
    while (fixture_gen_next(&gen, &row, NULL, err, sizeof err) == 0) {
        assert_int_equal(calfit_add_row(d, &row, line++), 0);
    }
    struct calfit_result res;
    if (calfit_run(d, &res, err, sizeof err) != 0) {
        fail_msg("%s", err);
    }
    fixture_gen_free(&gen);
    return res;
}

/* A span under 10 °C: unknown, nothing stated; the probe still sees a large coefficient. */
static void test_narrow_span_unknown(void **state) {
    (void)state;
    struct fixture_config cfg;
    assert_int_equal(fixture_named("fixture-thermal-narrow", &cfg), 0);
    cfg.readings_per_station = 300u;
    cfg.coeff_range_mm_per_c = 0.2;
    struct calfit_data d;
    const struct calfit_result res = fit_named(&cfg, 3u, &d);
    assert_false(res.thermal);
    assert_int_equal(res.thermal_state, CALFIT_THERMAL_NARROW);
    assert_true(res.temp_max_c - res.temp_min_c < CALFIT_MIN_TEMP_SPAN_C);
    assert_true(res.temp_max_c - res.temp_min_c > 4.0);
    bool seen = false;
    for (unsigned k = 0; k < 4u; ++k) {
        assert_true(res.sensor[k].temp_coeff_mm_per_c == 0.0);
        assert_true(res.sensor[k].temp_coeff_sd_mm_per_c == 0.0);
        assert_true(res.sensor[k].temp_probe);
        seen = seen || fabs(res.sensor[k].temp_probe_t) > 5.0;
    }
    assert_true(seen); /* some part's ±0.2 mm/°C shows over 6 °C */
    calfit_free(&d);
}

/* No temp_c at all, one station without it, too few stations: unknown, and why. */
static void test_unknown_states(void **state) {
    (void)state;
    struct fixture_config cfg;
    assert_int_equal(fixture_named("fixture-thermal-blind", &cfg), 0);
    cfg.readings_per_station = 100u;
    struct calfit_data d;
    struct calfit_result res = fit_named(&cfg, 1u, &d);
    assert_false(res.thermal);
    assert_int_equal(res.thermal_state, CALFIT_THERMAL_NO_TEMP);
    assert_int_equal(res.stations_no_temp, 30);
    calfit_free(&d);

    /* one station's rows without temperature */
    const bool valid[4] = {true, true, true, true};
    calfit_init(&d, 30.0, 0.0);
    const double dist[6] = {60.0, 95.0, 130.0, 165.0, 200.0, 80.0};
    const double temp[6] = {10.0, 40.0, 10.0, 40.0, 25.0, 25.0};
    for (unsigned s = 0; s < 6u; ++s) {
        const double raw[4] = {dist[s] + 1.0, dist[s] - 1.0, dist[s] + 2.0, dist[s]};
        for (unsigned i = 0; i < 20u; ++i) {
            assert_int_equal(calfit_add_temp(&d, true, 0.0, 0.0, dist[s], raw, valid, s != 4u,
                                             temp[s], 20u * i, 100u * s + i),
                             0);
        }
        assert_int_equal(calfit_add(&d, false, 0, 0, 0, raw, valid, 0u, 0u), 0);
    }
    char err[256] = "";
    assert_int_equal(calfit_run(&d, &res, err, sizeof err), 0);
    assert_int_equal(res.thermal_state, CALFIT_THERMAL_SOME_MISSING);
    assert_int_equal(res.stations_no_temp, 1);
    assert_int_equal(res.no_temp_first_line, 400);
    assert_int_equal(res.no_temp_last_line, 419);
    calfit_free(&d);

    /* three stations spanning 30 °C: enough for offset and gain, not for the coefficient */
    calfit_init(&d, 30.0, 0.0);
    for (unsigned s = 0; s < 3u; ++s) {
        const double raw[4] = {dist[s] + 1.0, dist[s] - 1.0, dist[s] + 2.0, dist[s]};
        for (unsigned i = 0; i < 20u; ++i) {
            assert_int_equal(calfit_add_temp(&d, true, 0.0, 0.0, dist[s], raw, valid, true,
                                             10.0 + 15.0 * s, 20u * i, 0u),
                             0);
        }
        assert_int_equal(calfit_add(&d, false, 0, 0, 0, raw, valid, 0u, 0u), 0);
    }
    assert_int_equal(calfit_run(&d, &res, err, sizeof err), 0);
    assert_false(res.thermal);
    assert_int_equal(res.thermal_state, CALFIT_THERMAL_FEW_STATIONS);
    calfit_free(&d);
}

/* calfit_wls_general against the two-parameter calfit_wls on the same data. */
static void test_general_wls(void **state) {
    (void)state;
    const double x[5] = {60.0, 95.0, 130.0, 165.0, 200.0};
    const double y[5] = {61.2, 95.1, 131.9, 166.2, 203.3};
    const double w[5] = {1.0, 2.0, 0.5, 1.0, 3.0};
    double f[10];
    for (unsigned i = 0; i < 5u; ++i) {
        f[2 * i] = 1.0;
        f[2 * i + 1] = x[i];
    }
    double c2[2], v2[3], cg[4], vg[16];
    assert_int_equal(calfit_wls(x, y, w, 5u, 2u, c2, v2), 0);
    assert_int_equal(calfit_wls_general(f, y, w, 5u, 2u, cg, vg), 0);
    assert_close(cg[0], c2[0], 1e-9);
    assert_close(cg[1], c2[1], 1e-12);
    assert_close(vg[0], v2[0], 1e-9);
    assert_close(vg[1], v2[1], 1e-12);
    assert_close(vg[3], v2[2], 1e-14);
    /* a feature that repeats another: singular */
    for (unsigned i = 0; i < 5u; ++i) {
        f[2 * i + 1] = 1.0;
    }
    assert_int_equal(calfit_wls_general(f, y, w, 5u, 2u, cg, vg), -1);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_noise_free),    cmocka_unit_test(test_general_wls),
        cmocka_unit_test(test_narrow_span_unknown), cmocka_unit_test(test_unknown_states),
        cmocka_unit_test(test_coefficient_sweep),   cmocka_unit_test(test_span_sweep),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
