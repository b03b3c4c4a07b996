/*
 * estimator/angles: Eq. 1 and its β mirror against double precision, the
 * sensor masks, the residual, and the extreme readings 0 and 65535 mm.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <cmocka.h>

#include "estimator/angles.h"

#define TEST_PI 3.14159265358979323846

static double ref_udeg(double dx_mm, double arm_mm) {
    return atan(dx_mm / arm_mm) * (180e6 / TEST_PI);
}

static void expect_close(fix_udeg_t got, double want, double tol) {
    if (fabs((double)got - want) > tol) {
        fail_msg("angle %d udeg, expected %.1f (+-%.1f)", got, want, tol);
    }
}

static void check_sample(const uint16_t r[4], int32_t arm_um) {
    struct angles_sample s;
    angles_compute(r, ANGLES_ALL_SENSORS, arm_um, &s);
    const double a = arm_um / 1000.0;
    const double xa = r[0], xb = r[1], xc = r[2], xd = r[3];
    const double alpha[5] = {ref_udeg(xb - xa, a), ref_udeg(xd - xa, a), ref_udeg(xc - xb, a),
                             ref_udeg(xc - xd, a), ref_udeg(xc - xa, 2 * a)};
    const double beta[5] = {ref_udeg(xa - xd, a), ref_udeg(xc - xd, a), ref_udeg(xb - xa, a),
                            ref_udeg(xb - xc, a), ref_udeg(xb - xd, 2 * a)};
    for (unsigned i = 0; i < 5; ++i) {
        expect_close(s.alpha_udeg[i], alpha[i], 3.0);
        expect_close(s.beta_udeg[i], beta[i], 3.0);
    }
    assert_int_equal(s.alpha_valid, 0x1F);
    assert_int_equal(s.beta_valid, 0x1F);
    assert_true(s.flatness_valid);
    assert_int_equal(s.flatness_mm, (int32_t)r[0] + r[2] - r[1] - r[3]);
}

static void test_known_tilts(void **state) {
    (void)state;
    /* a = 30 mm, x̄ = 100 mm, α = 5°, β = 0: x_A = 100 − 30 tan 5° = 97.38 → 97 */
    const uint16_t r[4] = {97, 100, 103, 100};
    struct angles_sample s;
    angles_compute(r, ANGLES_ALL_SENSORS, 30000, &s);
    /* α5 = atan(6/60) = 5.710593° */
    expect_close(s.alpha_udeg[4], 5710593.1, 1.5);
    /* α1 = atan(3/30) */
    expect_close(s.alpha_udeg[0], 5710593.1, 1.5);
    assert_int_equal(s.beta_udeg[4], 0);
    assert_int_equal(s.flatness_mm, 0);
    check_sample(r, 30000);
}

static void test_random_samples_against_double(void **state) {
    (void)state;
    srand(12345);
    for (int i = 0; i < 20000; ++i) {
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = (uint16_t)(rand() % 65536);
        }
        const int32_t arm = ANGLES_ARM_MIN_UM + rand() % (ANGLES_ARM_MAX_UM - ANGLES_ARM_MIN_UM);
        check_sample(r, arm);
    }
}

static void test_extreme_ranges(void **state) {
    (void)state;
    static const uint16_t cases[][4] = {
        {0, 0, 0, 0},         {65535, 65535, 65535, 65535}, {0, 65535, 65535, 0},
        {65535, 0, 0, 65535}, {0, 4000, 65535, 4000},       {4000, 0, 4000, 65535},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        check_sample(cases[c], ANGLES_ARM_MIN_UM);
        check_sample(cases[c], 30000);
        check_sample(cases[c], ANGLES_ARM_MAX_UM);
    }
    /* 65535 mm over a 1 mm arm is 89.9991°, still below 90° */
    struct angles_sample s;
    const uint16_t r[4] = {0, 65535, 65535, 0};
    angles_compute(r, ANGLES_ALL_SENSORS, ANGLES_ARM_MIN_UM, &s);
    assert_true(s.alpha_udeg[0] < FIX_UDEG_90 && s.alpha_udeg[0] > 89999000);
    assert_int_equal(s.flatness_mm, -0 + 65535 - 65535 - 0);
}

static void test_symmetry_alpha_beta(void **state) {
    (void)state;
    /* Turning the plate 90° (A→D, B→A, C→B, D→C) turns α into β exactly. */
    srand(99);
    for (int i = 0; i < 5000; ++i) {
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = (uint16_t)(rand() % 5000);
        }
        /* new readings: the sensor that now sits at D reads what A read, etc. */
        const uint16_t turned[4] = {r[1], r[2], r[3], r[0]};
        struct angles_sample s, t;
        angles_compute(r, ANGLES_ALL_SENSORS, 25000, &s);
        angles_compute(turned, ANGLES_ALL_SENSORS, 25000, &t);
        for (unsigned k = 0; k < 5; ++k) {
            assert_int_equal(t.beta_udeg[k], s.alpha_udeg[k]);
        }
    }
}

/* The operating range: readings within an arm of each other (every slope within ±45°),
 * where the prepared arm and the atan table work: within 1 udeg of double for every arm,
 * angles_compute_all() equal to angles_compute_prepared(), angles_compute() equal to both,
 * and exactly 45° and beyond handled by the CORDIC on the exact operands. */
static void test_prepared_table_range(void **state) {
    (void)state;
    srand(4242);
    double worst = 0.0;
    for (int i = 0; i < 200000; ++i) {
        const int32_t arm = ANGLES_ARM_MIN_UM + rand() % (ANGLES_ARM_MAX_UM - ANGLES_ARM_MIN_UM);
        const int32_t a_mm = arm / 1000;
        uint16_t r[4];
        const int32_t base = 1000 + rand() % 30000;
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = (uint16_t)(base + (a_mm > 0 ? rand() % (a_mm + 1) : 0) - a_mm / 2);
        }
        struct angles_arm prep;
        angles_arm_prepare(&prep, arm);
        struct angles_sample s;
        struct angles_sample t;
        angles_compute_prepared(r, ANGLES_ALL_SENSORS, &prep, &s);
        angles_compute(r, ANGLES_ALL_SENSORS, arm, &t);
        fix_udeg_t al[5];
        fix_udeg_t b5;
        angles_compute_all(r, &prep, al, &b5);
        for (unsigned k = 0; k < 5; ++k) {
            assert_int_equal(s.alpha_udeg[k], t.alpha_udeg[k]);
            assert_int_equal(s.beta_udeg[k], t.beta_udeg[k]);
            assert_int_equal(al[k], s.alpha_udeg[k]);
        }
        assert_int_equal(b5, s.beta_udeg[4]);
        const double a = arm / 1000.0;
        const double want[5] = {atan((r[1] - r[0]) / a), atan((r[3] - r[0]) / a),
                                atan((r[2] - r[1]) / a), atan((r[2] - r[3]) / a),
                                atan((r[2] - r[0]) / (2 * a))};
        for (unsigned k = 0; k < 5; ++k) {
            const double err = fabs(s.alpha_udeg[k] - want[k] * 180e6 / TEST_PI);
            worst = err > worst ? err : worst;
        }
    }
    printf("prepared angles within ±45°: worst |fixed − double| %.3f udeg\n", worst);
    assert_true(worst <= 1.0);
    /* exactly 45° (d = a) and just around it, both spans */
    struct angles_arm prep;
    angles_arm_prepare(&prep, 30000);
    for (int d = 28; d <= 62; ++d) {
        for (unsigned span = 1; span <= 2; ++span) {
            const uint16_t hi = (uint16_t)(1000 + d);
            const double want = atan(d / (30.0 * span)) * 180e6 / TEST_PI;
            const fix_udeg_t got = angles_pair_prepared_udeg(hi, 1000, &prep, span);
            assert_true(fabs(got - want) <= 1.1);
            assert_int_equal(angles_pair_prepared_udeg(1000, hi, &prep, span), -got);
        }
    }
}

static void test_masks_and_missing_sensors(void **state) {
    (void)state;
    assert_int_equal(angles_alpha_mask(ANGLES_ALL_SENSORS), 0x1F);
    assert_int_equal(angles_alpha_mask(0), 0);
    /* B missing: α2 (A,D), α4 (C,D), α5 (A,C) remain */
    assert_int_equal(angles_alpha_mask(0x0D), (1u << 1) | (1u << 3) | (1u << 4));
    /* β with B missing: β1 (A,D), β2 (C,D) */
    assert_int_equal(angles_beta_mask(0x0D), (1u << 0) | (1u << 1));
    /* two missing (A, C): no α at all */
    assert_int_equal(angles_alpha_mask(0x0A), 0);
    assert_int_equal(angles_beta_mask(0x0A), 1u << 4);

    const uint16_t r[4] = {97, 100, 103, 100};
    struct angles_sample s;
    angles_compute(r, 0x0D, 30000, &s);
    assert_int_equal(s.alpha_valid, 0x1A);
    assert_int_equal(s.alpha_udeg[0], 0); /* not computed */
    assert_false(s.flatness_valid);
    assert_int_equal(s.flatness_mm, 0);
    expect_close(s.alpha_udeg[4], 5710593.1, 1.5);
}

static void test_arm_validation(void **state) {
    (void)state;
    assert_true(angles_arm_valid(30000));
    assert_true(angles_arm_valid(ANGLES_ARM_MIN_UM));
    assert_true(angles_arm_valid(ANGLES_ARM_MAX_UM));
    assert_false(angles_arm_valid(ANGLES_ARM_MIN_UM - 1));
    assert_false(angles_arm_valid(0));
    assert_false(angles_arm_valid(-30000));
    assert_false(angles_arm_valid(ANGLES_ARM_MAX_UM + 1));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_known_tilts),
        cmocka_unit_test(test_random_samples_against_double),
        cmocka_unit_test(test_extreme_ranges),
        cmocka_unit_test(test_symmetry_alpha_beta),
        cmocka_unit_test(test_prepared_table_range),
        cmocka_unit_test(test_masks_and_missing_sensors),
        cmocka_unit_test(test_arm_validation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
