/* Scene maths: geometry, PRNG, deterministic log, noise models, Cramér-Rao bound. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <math.h>

#include "scene/crb.h"
#include "scene/geometry.h"
#include "scene/noise.h"
#include "scene/rng.h"

static void assert_close(double got, double want, double tol) {
    if (!(fabs(got - want) <= tol)) {
        fail_msg("got %.17g, want %.17g (tolerance %.3g)", got, want, tol);
    }
}

/* docs/explanation/architecture.md with hand-computed numbers: a = 30, x̄ = 100, α = 5°, β = −2°. */
static void test_geometry_known_values(void **state) {
    (void)state;
    double d[SCENE_SENSORS];
    scene_ideal_distances(30.0, 100.0, 5.0, -2.0, d);
    /* 30·tan 5° = 2.6246599, 30·tan 2° = 1.0476231 */
    assert_close(d[SCENE_A], 100.0 - 2.6246599, 1e-6);
    assert_close(d[SCENE_C], 100.0 + 2.6246599, 1e-6);
    assert_close(d[SCENE_B], 100.0 - 1.0476231, 1e-6);
    assert_close(d[SCENE_D], 100.0 + 1.0476231, 1e-6);
    /* Flat plate: the parity residual x_A + x_C − x_B − x_D is zero. */
    assert_close(d[0] + d[2] - d[1] - d[3], 0.0, 1e-12);
}

static void test_geometry_round_trip(void **state) {
    (void)state;
    struct scene_rng rng;
    scene_rng_seed(&rng, 5, 0);
    for (int i = 0; i < 10000; ++i) {
        const double arm = scene_rng_range(&rng, 10.0, 100.0);
        const double mean = scene_rng_range(&rng, 20.0, 2000.0);
        const double alpha = scene_rng_range(&rng, -40.0, 40.0);
        const double beta = scene_rng_range(&rng, -40.0, 40.0);
        double d[SCENE_SENSORS];
        scene_ideal_distances(arm, mean, alpha, beta, d);
        double m = 0.0;
        double a = 0.0;
        double b = 0.0;
        scene_attitude_from_distances(arm, d, &m, &a, &b);
        assert_close(m, mean, 1e-9);
        assert_close(a, alpha, 1e-9);
        assert_close(b, beta, 1e-9);
    }
}

/* The published xoshiro256** output for state {1, 2, 3, 4} (reference
 * implementation at prng.di.unimi.it) proves the algorithm is the real one. */
static void test_xoshiro_reference_vector(void **state) {
    (void)state;
    struct scene_rng rng;
    memset(&rng, 0, sizeof rng);
    rng.s[0] = 1;
    rng.s[1] = 2;
    rng.s[2] = 3;
    rng.s[3] = 4;
    assert_true(scene_rng_u64(&rng) == 11520u);
    assert_true(scene_rng_u64(&rng) == 0u);
    assert_true(scene_rng_u64(&rng) == 1509978240u);
    assert_true(scene_rng_u64(&rng) == 1215971899390074240u);
}

/* Pinned outputs: a scene generated here is bit-identical on any IEEE-754
 * machine; a change in seeding or the normal generator breaks this test. */
static void test_rng_pinned_outputs(void **state) {
    (void)state;
    struct scene_rng rng;
    scene_rng_seed(&rng, 42, 3);
    assert_true(scene_rng_u64(&rng) == 0x44ad28f44a5c0633u);
    assert_true(scene_rng_u64(&rng) == 0xa9625f7b75117928u);
    assert_true(scene_rng_u64(&rng) == 0x509bf6cdd4be5f13u);
    scene_rng_seed(&rng, 42, 3);
    assert_true(scene_rng_normal(&rng) == -0x1.3d3e5d27f7d69p+0);
    assert_true(scene_rng_normal(&rng) == 0x1.ba9ea33286e43p-1);
    assert_true(scene_rng_normal(&rng) == -0x1.7fe97df0e6df8p-1);
}

static void test_rng_determinism_and_streams(void **state) {
    (void)state;
    struct scene_rng a;
    struct scene_rng b;
    struct scene_rng c;
    struct scene_rng d;
    scene_rng_seed(&a, 7, 1);
    scene_rng_seed(&b, 7, 1);
    scene_rng_seed(&c, 8, 1);
    scene_rng_seed(&d, 7, 2);
    int same_c = 0;
    int same_d = 0;
    for (int i = 0; i < 1000; ++i) {
        const uint64_t x = scene_rng_u64(&a);
        assert_true(x == scene_rng_u64(&b));
        same_c += x == scene_rng_u64(&c);
        same_d += x == scene_rng_u64(&d);
    }
    assert_int_equal(same_c, 0);
    assert_int_equal(same_d, 0);
}

static void test_uniform_and_below(void **state) {
    (void)state;
    struct scene_rng rng;
    scene_rng_seed(&rng, 3, 0);
    double sum = 0.0;
    unsigned hist[7] = {0};
    const int n = 700000;
    for (int i = 0; i < n; ++i) {
        const double u = scene_rng_uniform(&rng);
        assert_true(u >= 0.0 && u < 1.0);
        sum += u;
        const uint32_t k = scene_rng_below(&rng, 7);
        assert_true(k < 7u);
        hist[k]++;
    }
    assert_close(sum / n, 0.5, 0.002);
    for (unsigned k = 0; k < 7u; ++k) { /* 100000 ± 5 standard deviations */
        assert_true(hist[k] > 100000u - 1500u && hist[k] < 100000u + 1500u);
    }
}

static void test_det_log_matches_libm(void **state) {
    (void)state;
    struct scene_rng rng;
    scene_rng_seed(&rng, 9, 0);
    for (int i = 0; i < 200000; ++i) {
        const double x =
            ldexp(scene_rng_range(&rng, 0.5, 1.0), (int)scene_rng_below(&rng, 120) - 100);
        const double want = log(x);
        assert_close(scene_det_log(x), want, 4e-16 * fabs(want) + 1e-300);
    }
    assert_true(scene_det_log(1.0) == 0.0);
    assert_close(scene_det_log(2.0), 0.69314718055994530942, 2e-16);
}

static void test_normal_statistics(void **state) {
    (void)state;
    struct scene_rng rng;
    scene_rng_seed(&rng, 11, 0);
    const int n = 400000;
    double s = 0.0;
    double s2 = 0.0;
    double s4 = 0.0;
    int beyond2 = 0;
    for (int i = 0; i < n; ++i) {
        const double x = scene_rng_normal(&rng);
        s += x;
        s2 += x * x;
        s4 += x * x * x * x;
        beyond2 += fabs(x) > 2.0;
    }
    const double mean = s / n;
    const double var = s2 / n - mean * mean;
    assert_close(mean, 0.0, 0.008);                    /* 5 σ of the mean: 5/sqrt(n) */
    assert_close(var, 1.0, 0.012);                     /* 5 σ of the variance: 5·sqrt(2/n) */
    assert_close(s4 / n, 3.0, 0.06);                   /* kurtosis of a normal */
    assert_close((double)beyond2 / n, 0.0455, 0.0017); /* P(|x| > 2) */
}

/* σ = 2 mm Gaussian, quantised: sample σ matches Sheppard's sqrt(σ² + 1/12). */
static void test_gaussian_quantised_sigma(void **state) {
    (void)state;
    struct scene_sensor_noise model = {.sigma_mm = 2.0};
    struct scene_rng rng;
    scene_rng_seed(&rng, 12, 0);
    const int n = 200000;
    double s = 0.0;
    double s2 = 0.0;
    for (int i = 0; i < n; ++i) {
        const double ideal = 97.0 + 0.37 * (double)(i % 10);
        const struct scene_noise_draw d = scene_noise_sample(&model, &rng, ideal, 0.0);
        assert_int_equal(d.status, 0);
        assert_false(d.outlier);
        uint16_t mm = 0;
        assert_int_equal(scene_quantise_mm(d.value_mm, &mm), 0);
        const double e = (double)mm - ideal;
        s += e;
        s2 += e * e;
    }
    const double mean = s / n;
    const double sd = sqrt(s2 / n - mean * mean);
    assert_close(mean, 0.0, 0.015);
    assert_close(sd, scene_quantised_sigma(2.0), 0.02); /* 2.0207 */
    assert_close(scene_quantised_sigma(2.0), 2.0207259, 1e-6);
}

static void test_outliers_and_flags(void **state) {
    (void)state;
    struct scene_sensor_noise model = {.sigma_mm = 2.0,
                                       .outlier_rate = 0.02,
                                       .outlier_min_mm = 20.0,
                                       .outlier_max_mm = 80.0,
                                       .flag_rate = 0.05,
                                       .flag_error_mm = 60.0};
    struct scene_rng rng;
    scene_rng_seed(&rng, 13, 0);
    const int n = 200000;
    int outliers = 0;
    int flagged = 0;
    int positive = 0;
    for (int i = 0; i < n; ++i) {
        const struct scene_noise_draw d = scene_noise_sample(&model, &rng, 500.0, 0.0);
        if (d.outlier) {
            ++outliers;
            if (d.status == 0u) {
                /* magnitude 20..80 plus the jitter (|jitter| < 6σ = 12 mm) */
                const double off = fabs(d.value_mm - 500.0);
                assert_true(off > 20.0 - 12.0 && off < 80.0 + 12.0);
            }
            positive += d.value_mm > 500.0;
        }
        if (d.status != 0u) {
            assert_int_equal(d.status, SCENE_STATUS_FLAGGED);
            ++flagged;
        }
    }
    assert_close((double)outliers / n, 0.02, 0.0016); /* 5 binomial σ */
    assert_close((double)flagged / n, 0.05, 0.0025);
    assert_close((double)positive / outliers, 0.5, 0.04); /* sign random */
}

/* Changing a rate must not shift the Gaussian draws (fixed consumption). */
static void test_fixed_consumption(void **state) {
    (void)state;
    struct scene_sensor_noise plain = {.sigma_mm = 2.0};
    struct scene_sensor_noise busy = plain;
    busy.outlier_rate = 0.5;
    busy.outlier_min_mm = 20.0;
    busy.outlier_max_mm = 80.0;
    struct scene_rng a;
    struct scene_rng b;
    scene_rng_seed(&a, 14, 0);
    scene_rng_seed(&b, 14, 0);
    for (int i = 0; i < 1000; ++i) {
        const struct scene_noise_draw da = scene_noise_sample(&plain, &a, 100.0, 0.0);
        const struct scene_noise_draw db = scene_noise_sample(&busy, &b, 100.0, 0.0);
        if (!db.outlier) {
            assert_true(da.value_mm == db.value_mm);
        }
    }
}

static void test_quantise_rejects_out_of_range(void **state) {
    (void)state;
    uint16_t mm = 7;
    assert_int_equal(scene_quantise_mm(-0.6, &mm), -1);
    assert_int_equal(mm, 7);
    assert_int_equal(scene_quantise_mm(65535.6, &mm), -1);
    assert_int_equal(scene_quantise_mm((double)NAN, &mm), -1);
    assert_int_equal(scene_quantise_mm(-0.4, &mm), 0);
    assert_int_equal(mm, 0);
    assert_int_equal(scene_quantise_mm(65535.4, &mm), 0);
    assert_int_equal(mm, 65535);
    assert_int_equal(scene_quantise_mm(99.5, &mm), 0);
    assert_int_equal(mm, 100);
}

/* Hand computation: equal σ, n per sensor, J = (n/σ²)·diag(4, 2a², 2a²), so
 * sd(tan α) = σ/(a·sqrt(2n)) = 2/(30·sqrt(200)) = 0.00471405 and, at α = 0,
 * sd(α) = 0.270095°. */
static void test_crb_equal_noise(void **state) {
    (void)state;
    const double sigma[4] = {2.0, 2.0, 2.0, 2.0};
    const uint32_t n[4] = {100, 100, 100, 100};
    struct scene_crb crb;
    assert_int_equal(scene_crb(30.0, sigma, n, 0.0, 0.0, &crb), 0);
    assert_close(crb.sd_tan_alpha, 0.0047140452, 1e-9);
    assert_close(crb.sd_tan_beta, 0.0047140452, 1e-9);
    assert_close(crb.sd_mean_mm, 0.1, 1e-12); /* σ/sqrt(4n) */
    assert_close(crb.sd_alpha_deg, 0.27009489, 1e-7);
    /* At α = 5° the atan derivative shrinks it by 1/(1 + tan²5°) = 0.992404. */
    assert_int_equal(scene_crb(30.0, sigma, n, 5.0, -3.0, &crb), 0);
    assert_close(crb.sd_alpha_deg, 0.27009489 * 0.99240388, 1e-7);
    assert_close(crb.sd_beta_deg,
                 0.27009489 / (1.0 + tan(3.0 * SCENE_PI / 180.0) * tan(3.0 * SCENE_PI / 180.0)),
                 1e-7);
}

/* σ_A = 6: with w_k = n/σ_k², J₀₀ = Σw, J₀₁ = a(w_C − w_A), J₁₁ = a²(w_A + w_C)
 * and β decoupled, var(tan α) = J₀₀/(J₀₀J₁₁ − J₀₁²); by hand with n = 100, a = 30:
 * w_A = 2.7778, w_B = w_C = w_D = 25, J₀₀ = 77.7778, J₀₁ = 666.667,
 * J₁₁ = 25000, var = 77.7778/(1944444 − 444444) = 5.18519e-5, sd = 0.00720082. */
static void test_crb_hetero(void **state) {
    (void)state;
    const double sigma[4] = {6.0, 2.0, 2.0, 2.0};
    const uint32_t n[4] = {100, 100, 100, 100};
    struct scene_crb crb;
    assert_int_equal(scene_crb(30.0, sigma, n, 0.0, 0.0, &crb), 0);
    assert_close(crb.sd_tan_alpha, 0.0072008229, 1e-8);
    /* J₀₂ = a(w_B − w_D) = 0 and J₁₂ = 0: β decouples and keeps its bound. */
    assert_close(crb.sd_tan_beta, 0.0047140452, 1e-9);
}

static void test_crb_missing_sensors(void **state) {
    (void)state;
    const double sigma[4] = {2.0, 2.0, 2.0, 2.0};
    struct scene_crb crb;
    const uint32_t three[4] = {100, 100, 100, 0};
    assert_int_equal(scene_crb(30.0, sigma, three, 0.0, 0.0, &crb), 0);
    /* D missing, w = n/σ² = 25: J₁₁ = 2a²w and α stays decoupled, so sd(tan α)
     * is unchanged; x̄ and tan β share [[3w, aw], [aw, a²w]] whose inverse gives
     * var(tan β) = 3w/(3a²w² − a²w²) = 1.5/(a²w), sd = 2/30·sqrt(1.5/100). */
    assert_close(crb.sd_tan_alpha, 0.0047140452, 1e-9);
    assert_close(crb.sd_tan_beta, 2.0 / 30.0 * sqrt(1.5 / 100.0), 1e-9);
    const uint32_t two[4] = {100, 0, 100, 0};
    assert_int_equal(scene_crb(30.0, sigma, two, 0.0, 0.0, &crb), -1);
    const uint32_t ab[4] = {100, 100, 0, 0};
    assert_int_equal(scene_crb(30.0, sigma, ab, 0.0, 0.0, &crb), -1);
    const double bad_sigma[4] = {0.0, 2.0, 2.0, 2.0};
    const uint32_t all[4] = {1, 1, 1, 1};
    assert_int_equal(scene_crb(30.0, bad_sigma, all, 0.0, 0.0, &crb), -1);
    assert_int_equal(scene_crb(0.0, sigma, all, 0.0, 0.0, &crb), -1);
}

/* White σ plus a per-window offset σ_o: each sensor's window mean has variance
 * σ²/n + σ_o², so with σ = 2, n = 100, σ_o = 0.3: sd(tan α) = sqrt(0.13/(2·30²))
 * = 0.0084984; σ_o = 0 is the plain bound. */
static void test_crb_with_offset(void **state) {
    (void)state;
    const double sigma[4] = {2.0, 2.0, 2.0, 2.0};
    const double zero[4] = {0.0, 0.0, 0.0, 0.0};
    const double offset[4] = {0.3, 0.3, 0.3, 0.3};
    const uint32_t n[4] = {100, 100, 100, 100};
    struct scene_crb plain;
    struct scene_crb same;
    struct scene_crb drift;
    assert_int_equal(scene_crb(30.0, sigma, n, 1.0, 2.0, &plain), 0);
    assert_int_equal(scene_crb_with_offset(30.0, sigma, zero, n, 1.0, 2.0, &same), 0);
    assert_close(same.sd_alpha_deg, plain.sd_alpha_deg, 1e-15);
    assert_close(same.sd_beta_deg, plain.sd_beta_deg, 1e-15);
    assert_int_equal(scene_crb_with_offset(30.0, sigma, offset, n, 0.0, 0.0, &drift), 0);
    assert_close(drift.sd_tan_alpha, 0.0084983659, 1e-9);
    const double negative[4] = {0.3, -0.1, 0.3, 0.3};
    assert_int_equal(scene_crb_with_offset(30.0, sigma, negative, n, 0.0, 0.0, &drift), -1);
}

/* The per-row form agrees with the counted form and skips invalid readings. */
static void test_crb_rows(void **state) {
    (void)state;
    struct scene_row rows[100];
    double sig[100][SCENE_SENSORS];
    memset(rows, 0, sizeof rows);
    for (int i = 0; i < 100; ++i) {
        rows[i].has_alpha = rows[i].has_beta = true;
        rows[i].alpha_deg = 2.0 + 0.02 * (i - 49.5); /* mean 2.0 */
        rows[i].beta_deg = -1.0;
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            rows[i].present[k] = true;
            sig[i][k] = 2.0;
        }
        if (i < 20) {
            rows[i].status[SCENE_C] = 4; /* flagged: not counted */
        }
        if (i >= 90) {
            rows[i].present[SCENE_B] = false;
            rows[i].status[SCENE_B] = SCENE_STATUS_NO_READING;
        }
    }
    struct scene_crb by_rows;
    struct scene_crb by_count;
    assert_int_equal(scene_crb_rows(30.0, rows, sig, 100, &by_rows), 0);
    const double sigma[4] = {2.0, 2.0, 2.0, 2.0};
    const uint32_t n[4] = {100, 90, 80, 100};
    assert_int_equal(scene_crb(30.0, sigma, n, 2.0, -1.0, &by_count), 0);
    assert_close(by_rows.sd_alpha_deg, by_count.sd_alpha_deg, 1e-12);
    assert_close(by_rows.sd_beta_deg, by_count.sd_beta_deg, 1e-12);
    rows[5].has_alpha = false;
    assert_int_equal(scene_crb_rows(30.0, rows, sig, 100, &by_rows), -1);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_geometry_known_values),
        cmocka_unit_test(test_geometry_round_trip),
        cmocka_unit_test(test_xoshiro_reference_vector),
        cmocka_unit_test(test_rng_pinned_outputs),
        cmocka_unit_test(test_rng_determinism_and_streams),
        cmocka_unit_test(test_uniform_and_below),
        cmocka_unit_test(test_det_log_matches_libm),
        cmocka_unit_test(test_normal_statistics),
        cmocka_unit_test(test_gaussian_quantised_sigma),
        cmocka_unit_test(test_outliers_and_flags),
        cmocka_unit_test(test_fixed_consumption),
        cmocka_unit_test(test_quantise_rejects_out_of_range),
        cmocka_unit_test(test_crb_equal_noise),
        cmocka_unit_test(test_crb_hetero),
        cmocka_unit_test(test_crb_missing_sensors),
        cmocka_unit_test(test_crb_with_offset),
        cmocka_unit_test(test_crb_rows),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
