/* The orbit-thermal scenario (scene/thermal.h): the temperature cycle, offsets following it by
 * their coefficients, the walk, the measured temperature, the trace's temp_c column and
 * calibration keys read back. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "scene/geometry.h"
#include "scene/scenario.h"
#include "scene/scene_io.h"
#include "scene/thermal.h"
#include "scene/trace.h"

static void assert_close(double got, double want, double tol) {
    if (!(fabs(got - want) <= tol)) {
        fail_msg("got %.17g, want %.17g (tolerance %.3g)", got, want, tol);
    }
}

static void test_defaults(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("orbit-thermal", &cfg), 0);
    assert_true(cfg.thermal.on);
    /* six hours of 20 ms rows, four 90-minute orbits */
    assert_int_equal(scene_config_rows(&cfg), 6u * 3600u * 50u);
    assert_close(cfg.thermal.period_s, 5400.0, 0.0);
    /* the default range moves an offset by 1.5 mm over the 40 °C cycle at its ends */
    assert_close(cfg.thermal.coeff_range_mm_per_c * 2.0 * cfg.thermal.amplitude_c, 1.5, 1e-12);
    assert_int_equal(scene_config_set_hours(&cfg, 0.5), 0);
    assert_int_equal(scene_config_rows(&cfg), 90000u);
    assert_int_equal(scene_config_set_hours(&cfg, 25.0), -1);
    assert_int_equal(scene_config_set_hours(&cfg, 0.0), -1);
    struct scene_config plain;
    assert_int_equal(scene_config_named("table1", &plain), 0);
    assert_false(plain.thermal.on);
}

/* Every row: the true temperature is the cycle's, the measured one within 6 sd of its noise
 * (6: 1.8 million draws) plus half a quantum, each reading minus its ideal distance minus the
 * part's whole offset is the 2 mm Gaussian noise (with rounding), and the whole offset is the
 * stated one plus the coefficient times (T − cal_temp) plus a walk whose spread grows as the rate
 * says. */
static void test_rows_follow_the_cycle(void **state) {
    (void)state;
    enum { SEEDS = 40 };
    double walk2[4] = {0};
    double resid2 = 0.0;
    double resid_n = 0.0;
    const double hours = 0.25;
    for (uint64_t seed = 1; seed <= SEEDS; ++seed) {
        struct scene_config cfg;
        assert_int_equal(scene_config_named("orbit-thermal", &cfg), 0);
        assert_int_equal(scene_config_set_hours(&cfg, hours), 0);
        cfg.thermal.phase_deg = 30.0;
        struct scene_gen gen;
        char err[256] = "";
        assert_int_equal(scene_gen_init(&gen, &cfg, seed, err, sizeof err), 0);
        struct scene_row row;
        struct scene_row_info info;
        const struct scene_thermal *t = &cfg.thermal;
        while (scene_gen_next(&gen, &row, &info, err, sizeof err) == 0) {
            const double ts = row.t_ms / 1000.0;
            const double want =
                20.0 + 20.0 * sin(2.0 * SCENE_PI * ts / 5400.0 + 30.0 * SCENE_PI / 180.0);
            assert_close(info.temp_true_c, want, 1e-9);
            assert_true(row.has_temp);
            assert_close(row.temp_c, want, 6.0 * t->temp_noise_c + t->temp_quantum_c / 2.0 + 1e-9);
            assert_close(row.temp_c * 10.0, round(row.temp_c * 10.0), 1e-6); /* 0.1 °C steps */
            for (unsigned k = 0; k < 4u; ++k) {
                const double walk = info.thermal_offset_mm[k] - gen.thermal.offset_mm[k] -
                                    gen.thermal.coeff_mm_per_c[k] * (want - t->cal_temp_c);
                assert_close(walk, gen.thermal.walk_mm[k], 1e-9);
                const double r = row.range_mm[k] - info.ideal_mm[k] - info.thermal_offset_mm[k];
                resid2 += r * r;
                resid_n += 1.0;
            }
        }
        for (unsigned k = 0; k < 4u; ++k) {
            assert_true(fabs(gen.thermal.coeff_mm_per_c[k]) <= t->coeff_range_mm_per_c);
            walk2[k] += gen.thermal.walk_mm[k] * gen.thermal.walk_mm[k];
        }
        scene_gen_free(&gen);
    }
    /* the walk after `hours`: variance rate · t (µm² → mm²), 160 draws: within ±35 % */
    const double want_var = SCENE_THERMAL_WALK_UM2_H * 1e-6 * hours;
    const double got_var = (walk2[0] + walk2[1] + walk2[2] + walk2[3]) / (4.0 * SEEDS);
    print_message("walk variance after %.2f h: %.4f mm^2 (rate says %.4f); reading noise sd "
                  "%.3f mm\n",
                  hours, got_var, want_var, sqrt(resid2 / resid_n));
    assert_true(got_var > 0.65 * want_var && got_var < 1.35 * want_var);
    assert_close(sqrt(resid2 / resid_n), scene_quantised_sigma(2.0), 0.01);
}

/* Coefficient range 0 and no walk: the offsets are the stated ones exactly; a range R draws
 * coefficients over ±R and states them about the truth with the stated sd. */
static void test_coefficients(void **state) {
    (void)state;
    struct scene_thermal t;
    scene_thermal_defaults(&t);
    t.coeff_range_mm_per_c = 0.0;
    t.walk_um2_h = 0.0;
    t.coeff_sd_mm_per_c = 0.0;
    struct scene_thermal_head h;
    scene_thermal_draw(&h, &t, 7u);
    double off[4];
    double measured = 0.0;
    for (unsigned i = 0; i < 100u; ++i) {
        scene_thermal_row(&h, &t, i * 60.0, 60.0, off, &measured, NULL);
        for (unsigned k = 0; k < 4u; ++k) {
            assert_close(off[k], h.offset_mm[k], 0.0);
            assert_close(h.stated_mm_per_c[k], 0.0, 0.0);
        }
    }
    scene_thermal_defaults(&t);
    t.coeff_range_mm_per_c = 0.2; /* 8 mm over the 40 °C cycle */
    double z2 = 0.0;
    double max_k = 0.0;
    for (uint64_t seed = 1; seed <= 500u; ++seed) {
        scene_thermal_draw(&h, &t, seed);
        for (unsigned k = 0; k < 4u; ++k) {
            max_k = fmax(max_k, fabs(h.coeff_mm_per_c[k]));
            const double z = (h.stated_mm_per_c[k] - h.coeff_mm_per_c[k]) / t.coeff_sd_mm_per_c;
            z2 += z * z;
            assert_close(h.offset_mm[k] * 1e3, round(h.offset_mm[k] * 1e3), 1e-6);
        }
    }
    const double rms = sqrt(z2 / 2000.0);
    print_message("stated coefficients about the truth: RMS z %.3f over 2000; largest |k| %.4f\n",
                  rms, max_k);
    assert_true(rms > 0.9 && rms < 1.1);
    assert_true(max_k <= 0.2 && max_k > 0.19);
    const char *why = NULL;
    t.coeff_range_mm_per_c = 0.6;
    assert_non_null(why = scene_thermal_check(&t));
    t.coeff_range_mm_per_c = 0.2;
    t.amplitude_c = 70.0;
    assert_non_null(scene_thermal_check(&t));
}

/* The trace: temp_c column and the thermal calibration keys, read back by the one reader. */
static void test_trace_round_trip(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("orbit-thermal", &cfg), 0);
    assert_int_equal(scene_config_set_hours(&cfg, 0.02), 0);
    FILE *f = tmpfile();
    assert_non_null(f);
    char err[512] = "";
    assert_int_equal(scene_write_config(&cfg, 11u, f, "t.csv", err, sizeof err), 0);
    rewind(f);
    static struct trace_reader r;
    if (trace_reader_open(&r, f, "t.csv") != 0) {
        fail_msg("%s", trace_reader_error(&r));
    }
    const struct trace_v1_cal *c = &r.core.meta.cal;
    assert_true(c->calibrated && c->thermal);
    assert_int_equal(c->cal_temp_cdeg, 2000);
    struct scene_gen gen;
    assert_int_equal(scene_gen_init(&gen, &cfg, 11u, err, sizeof err), 0);
    for (unsigned k = 0; k < 4u; ++k) {
        assert_int_equal(c->offset_um[k], (int32_t)lround(gen.thermal.offset_mm[k] * 1e3));
        assert_int_equal(c->temp_coeff_nm_per_c[k],
                         (int32_t)lround(gen.thermal.stated_mm_per_c[k] * 1e6));
        assert_int_equal(c->temp_coeff_sd_nm_per_c[k], 1000);
    }
    struct scene_row want;
    struct scene_row got;
    unsigned rows = 0;
    while (scene_gen_next(&gen, &want, NULL, err, sizeof err) == 0) {
        assert_int_equal(trace_reader_next(&r, &got), 0);
        assert_true(got.has_temp);
        assert_close(got.temp_c, want.temp_c, 1e-9);
        assert_memory_equal(got.range_mm, want.range_mm, sizeof got.range_mm);
        rows++;
    }
    assert_int_equal(trace_reader_next(&r, &got), 1);
    assert_int_equal(rows, 72000u / 20u);
    scene_gen_free(&gen);
    fclose(f);

    /* a row's temperature outside the reader's range is refused, not clamped; none: empty */
    f = tmpfile();
    assert_non_null(f);
    assert_int_equal(trace_write_header_temp(f, 30.0, 20u, NULL, true), 0);
    struct scene_row row = {.t_ms = 0, .present = {true, true, true, true}};
    row.has_temp = true;
    row.temp_c = 200.5;
    assert_int_equal(trace_write_row_temp(f, &row, true), -1);
    row.has_temp = false;
    assert_int_equal(trace_write_row_temp(f, &row, true), 0);
    row.t_ms = 20;
    row.has_temp = true;
    row.temp_c = -12.346;
    assert_int_equal(trace_write_row_temp(f, &row, true), 0);
    rewind(f);
    assert_int_equal(trace_reader_open(&r, f, "u.csv"), 0);
    assert_int_equal(trace_reader_next(&r, &got), 0);
    assert_false(got.has_temp);
    assert_int_equal(trace_reader_next(&r, &got), 0);
    assert_true(got.has_temp);
    assert_close(got.temp_c, -12.35, 1e-12); /* written with 2 decimals */
    fclose(f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_rows_follow_the_cycle),
        cmocka_unit_test(test_coefficients),
        cmocka_unit_test(test_trace_round_trip),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
