/*
 * A thermal calibration inside the estimator (estimator/calibration.h): each offset corrected
 * to the rows' temperature, the sliding window's sums exact across the correction's steps, the
 * sd carrying what the coefficients leave, and without a temperature the calibration
 * temperature's offsets and the sd of a calibration without coefficients.
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

#define TEST_PI 3.14159265358979323846
#define ARM_MM  30.0

static struct test_rng rng;
static struct attitude_state st;
static struct attitude_state fresh;
static struct attitude_output out;
static const uint8_t all_ok[4] = {0, 0, 0, 0};
static const bool all_present[4] = {true, true, true, true};

/* The head's parts: offsets move by these per °C (mm) from the calibration temperature. */
static const double coeff_mm_per_c[4] = {0.050, -0.030, 0.020, -0.040};
#define CAL_TEMP_C 20.0

/* True distances of sensors A..D at (α, β) degrees and x̄ mm. */
static void geometry(double alpha_deg, double beta_deg, double xbar, double x[4]) {
    const double ta = tan(alpha_deg * TEST_PI / 180);
    const double tb = tan(beta_deg * TEST_PI / 180);
    x[0] = xbar - ARM_MM * ta;
    x[1] = xbar + ARM_MM * tb;
    x[2] = xbar + ARM_MM * ta;
    x[3] = xbar - ARM_MM * tb;
}

/* Exact offsets and gains at the calibration temperature, these coefficients with sd_nm. */
static void thermal_config(struct attitude_config *cfg, uint32_t sd_nm, bool thermal) {
    attitude_config_default(cfg);
    cfg->calibration = (struct calibration_head){.calibrated = true};
    cfg->calibration.thermal = thermal;
    cfg->calibration.cal_temp_cdeg = (int16_t)lround(CAL_TEMP_C * 100);
    for (unsigned k = 0; k < 4u; ++k) {
        cfg->calibration.temp_coeff_nm_per_c[k] = (int32_t)lround(coeff_mm_per_c[k] * 1e6);
        cfg->calibration.temp_coeff_sd_nm_per_c[k] = sd_nm;
    }
}

/* One row of the head at temp_c (σ mm noise, whole mm), told temperature `told` (NaN: none). */
static bool row(struct attitude_state *s, const double x[4], double temp_c, double told,
                double sigma, uint16_t raw_out[4]) {
    uint16_t raw[4];
    for (unsigned k = 0; k < 4u; ++k) {
        const double v =
            x[k] + coeff_mm_per_c[k] * (temp_c - CAL_TEMP_C) + sigma * test_gauss(&rng);
        raw[k] = (uint16_t)lround(v);
        if (raw_out != NULL) {
            raw_out[k] = raw[k];
        }
    }
    attitude_set_temperature(s, !isnan(told), isnan(told) ? 0 : (int16_t)lround(told * 100));
    return attitude_push_sample(s, raw, all_ok, all_present, &out);
}

static double alpha_deg(const struct attitude_estimate *e) {
    return e->alpha_udeg / 1e6;
}

/* At 40 °C the offsets are 0.4–1.0 mm from the calibration's: corrected, the consensus α and β
 * are within 3 sd of the truth over 20 windows of σ 1 mm, N 250; without the temperature the
 * same rows put α half a degree off, and the sd still covers it. */
static void test_correction_follows_the_temperature(void **state) {
    (void)state;
    rng.state = 11u;
    struct attitude_config cfg;
    thermal_config(&cfg, 0u, true);
    cfg.window = 250;
    cfg.max_rate_mdeg_s = 0;
    double x[4];
    geometry(2.0, -1.0, 150.0, x);
    for (int told_on = 1; told_on >= 0; --told_on) {
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
        double worst_z = 0;
        double mean_err = 0;
        for (unsigned w = 0; w < 20u; ++w) {
            bool ready = false;
            for (unsigned r = 0; r < cfg.window; ++r) {
                ready = row(&st, x, 40.0, told_on ? 40.0 : (double)NAN, 1.0, NULL);
            }
            assert_true(ready);
            const struct attitude_estimate *e = &out.est[ATTITUDE_EST_CONSENSUS];
            assert_true(e->alpha_valid && e->beta_valid);
            const double err_a = alpha_deg(e) - 2.0;
            const double err_b = e->beta_udeg / 1e6 + 1.0;
            const double za = fabs(err_a) / (e->alpha_sd_udeg / 1e6);
            const double zb = fabs(err_b) / (e->beta_sd_udeg / 1e6);
            worst_z = fmax(worst_z, fmax(za, zb));
            mean_err += err_a / 20.0;
        }
        printf("told %s: mean α error %.3f°, worst |error|/sd %.2f\n", told_on ? "40 °C" : "none",
               mean_err, worst_z);
        if (told_on) {
            assert_true(worst_z < 3.0);
            assert_true(fabs(mean_err) < 0.05);
        } else {
            /* the offsets moved by 0.4–1.0 mm: α about half a degree off, which the sd
             * covers (the parts may be anywhere in their operating range) */
            assert_true(mean_err < -0.4);
            assert_true(worst_z < 3.0);
        }
    }
}

/* A sliding window across a 40 °C ramp (the correction steps every few rows), then N rows at
 * a constant temperature: the same estimate, to the micro-degree, as a fresh estimator given
 * only those N rows. A row dropped subtracts exactly what it added whatever steps came between. */
static void test_sliding_sums_stay_exact_across_steps(void **state) {
    (void)state;
    rng.state = 12u;
    struct attitude_config cfg;
    thermal_config(&cfg, 1000u, true);
    cfg.window = 50;
    cfg.mode = ATTITUDE_SLIDING;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    assert_int_equal(attitude_init(&fresh, &cfg), ATTITUDE_ERR_NONE);
    double x[4];
    geometry(-3.0, 2.5, 120.0, x);
    for (unsigned r = 0; r < 600u; ++r) {
        const double t = 20.0 + 40.0 * r / 600.0;
        (void)row(&st, x, t, t, 1.5, NULL);
    }
    struct attitude_output last_fresh;
    for (unsigned r = 0; r < cfg.window; ++r) {
        uint16_t raw[4];
        assert_true(row(&st, x, 60.0, 60.0, 1.5, raw));
        attitude_set_temperature(&fresh, true, 6000);
        const bool ready = attitude_push_sample(&fresh, raw, all_ok, all_present, &last_fresh);
        assert_int_equal(ready, r + 1u == cfg.window);
    }
    const struct attitude_estimate *a = &out.est[ATTITUDE_EST_CONSENSUS];
    const struct attitude_estimate *b = &last_fresh.est[ATTITUDE_EST_CONSENSUS];
    assert_int_equal(a->alpha_udeg, b->alpha_udeg);
    assert_int_equal(a->beta_udeg, b->beta_udeg);
    assert_int_equal(a->distance_um, b->distance_um);
    assert_int_equal(a->flatness_residual_um, b->flatness_residual_um);
}

/* The sd: at the calibration temperature a coefficient sd adds nothing but the temperature's
 * own error times the coefficient; 40 °C away, 2 µm/°C of coefficient sd adds 80 µm per
 * sensor, (40 µm)² to the distance's variance; with no temperature ever measured it carries
 * the coefficients over the parts' whole operating range. */
static void test_sd_carries_what_the_coefficients_leave(void **state) {
    (void)state;
    struct attitude_config cfg;
    double x[4];
    geometry(0.5, 0.5, 100.0, x);
    int32_t dist_sd[4];
    int32_t alpha_sd[4];
    const double temps[3] = {20.0, 60.0, (double)NAN};
    for (unsigned c = 0; c < 4u; ++c) {
        rng.state = 13u; /* the same rows for every case */
        thermal_config(&cfg, 2000u, c < 3u);
        cfg.window = 100;
        cfg.max_rate_mdeg_s = 0; /* a still plate: the sd is the calibration's and the noise's */
        assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
        const double t = c < 3u ? temps[c] : (double)NAN;
        bool ready = false;
        for (unsigned r = 0; r < cfg.window; ++r) {
            ready = row(&st, x, isnan(t) ? 20.0 : t, t, 0.5, NULL);
        }
        assert_true(ready);
        dist_sd[c] = out.est[ATTITUDE_EST_CONSENSUS].distance_sd_um;
        alpha_sd[c] = out.est[ATTITUDE_EST_CONSENSUS].alpha_sd_udeg;
        printf("case %u: distance sd %d um, alpha sd %d udeg\n", c, dist_sd[c], alpha_sd[c]);
    }
    /* 80 µm per sensor, independent: the mean of four adds (40 µm)² */
    const double added_um2 = (double)dist_sd[1] * dist_sd[1] - (double)dist_sd[0] * dist_sd[0];
    assert_true(added_um2 > 1200 && added_um2 < 2200);
    assert_true(alpha_sd[1] > alpha_sd[0]); /* and the angles feel it */
    /* never a temperature: the parts may be anywhere in their operating range, 65 °C from
     * the calibration's 20 °C: 50 µm/°C · 65 °C = 3.25 mm on A, 1.3–2.6 mm on the others */
    assert_true(dist_sd[2] > 1000);
    assert_true(alpha_sd[2] > 10 * alpha_sd[3]);
}

/* A head at 60 °C whose temperature stops being measured: the offsets stay those of 60 °C (no
 * jump back to the calibration temperature's, 2 mm on sensor A) and the sd widens with the
 * time without one, by 2 °C/min times each coefficient, window after window. */
static void test_a_lost_temperature_holds_the_offsets_and_widens(void **state) {
    (void)state;
    rng.state = 14u;
    struct attitude_config cfg;
    thermal_config(&cfg, 0u, true);
    cfg.window = 250;
    cfg.max_rate_mdeg_s = 0;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    double x[4];
    geometry(1.0, -2.0, 150.0, x);
    for (unsigned r = 0; r < 5u * cfg.window; ++r) {
        (void)row(&st, x, 60.0, 60.0, 1.0, NULL);
    }
    int32_t last_sd = out.est[ATTITUDE_EST_CONSENSUS].alpha_sd_udeg;
    for (unsigned w = 0; w < 10u; ++w) {
        for (unsigned r = 0; r < cfg.window; ++r) {
            (void)row(&st, x, 60.0, (double)NAN, 1.0, NULL);
        }
        const struct attitude_estimate *e = &out.est[ATTITUDE_EST_CONSENSUS];
        const double z = fabs(alpha_deg(e) - 1.0) / (e->alpha_sd_udeg / 1e6);
        printf("window %u without a temperature: alpha error %.3f deg, sd %.3f deg\n", w,
               alpha_deg(e) - 1.0, e->alpha_sd_udeg / 1e6);
        assert_true(z < 3.0);
        assert_true(fabs(alpha_deg(e) - 1.0) < 0.25); /* held, not 0.57° off */
        assert_true(e->alpha_sd_udeg > last_sd);
        last_sd = e->alpha_sd_udeg;
    }
}

/* Coefficients beyond 1 mm/°C, a calibration temperature beyond −100..200 °C or a temperature
 * sd beyond 100 °C are refused as a configuration error; an uncalibrated head's are ignored. */
static void test_thermal_fields_are_checked(void **state) {
    (void)state;
    struct attitude_config cfg;
    thermal_config(&cfg, 0u, true);
    cfg.calibration.temp_coeff_nm_per_c[2] = CALIBRATION_TEMP_COEFF_MAX_NM_PER_C + 1;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_CALIBRATION);
    thermal_config(&cfg, CALIBRATION_TEMP_COEFF_MAX_NM_PER_C + 1u, true);
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_CALIBRATION);
    thermal_config(&cfg, 0u, true);
    cfg.calibration.cal_temp_cdeg = CALIBRATION_TEMP_MAX_CDEG + 1;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_CALIBRATION);
    thermal_config(&cfg, 0u, true);
    cfg.temp_sd_cdeg = 10001u;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_CALIBRATION);
    thermal_config(&cfg, 0u, true);
    cfg.calibration.calibrated = false;
    cfg.calibration.temp_coeff_nm_per_c[0] = INT32_MAX;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_correction_follows_the_temperature),
        cmocka_unit_test(test_sliding_sums_stay_exact_across_steps),
        cmocka_unit_test(test_sd_carries_what_the_coefficients_leave),
        cmocka_unit_test(test_a_lost_temperature_holds_the_offsets_and_widens),
        cmocka_unit_test(test_thermal_fields_are_checked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
