/*
 * The calibration's age as an input (attitude_config.calibration_age_s): a unit booted long
 * after its calibration carries the prior offset walk of that whole time in every sd, from its
 * first window, as a unit that had run all that time would (the walk's variance grows with the
 * time since calibration: docs/explanation/estimators.md, "Drift since the start").
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "estimator/attitude.h"
#include "test_calibration.h"
#include "test_rand.h"

#define TEST_PI   3.14159265358979323846
#define PERIOD_US 20000u
#define ARM_MM    30.0

/* The consensus α sd (µdeg) of the first window over the same noisy static rows, for a head
 * calibrated `age_s` seconds before the start. */
static double first_sd_udeg(uint32_t age_s) {
    static struct attitude_state st;
    static struct attitude_output out;
    static const uint8_t ok[4] = {0, 0, 0, 0};
    static const bool present[4] = {true, true, true, true};
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    test_calibration_exact(&cfg.calibration);
    cfg.period_us = PERIOD_US;
    cfg.estimators = ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS);
    cfg.calibration_age_s = age_s;
    assert_int_equal(attitude_init(&st, &cfg), ATTITUDE_ERR_NONE);
    struct test_rng rng = {.state = 7u};
    for (unsigned i = 0; i < 10u * cfg.window; ++i) {
        uint16_t r[4];
        for (unsigned k = 0; k < 4u; ++k) {
            r[k] = (uint16_t)lround(500.0 + 2.0 * test_gauss(&rng));
        }
        if (attitude_push_sample(&st, r, ok, present, &out)) {
            const struct attitude_estimate *e = &out.est[ATTITUDE_EST_CONSENSUS];
            assert_true(e->alpha_valid);
            return e->alpha_sd_udeg;
        }
    }
    fail_msg("no window ended");
    return 0.0;
}

/* Over decades of age (1 h .. 10,000 h): the sd's square grows by the walk's variance over that
 * time, offset_walk · age on each of A and C, α = (x_C − x_A) / 2a
 * (docs/explanation/architecture.md): within 5 %. */
static void test_the_age_adds_its_walk_from_the_first_window(void **state) {
    (void)state;
    const double base = first_sd_udeg(0u);
    double last = base;
    static const uint32_t hours[] = {1u, 10u, 100u, 1000u, 10000u};
    for (size_t k = 0; k < sizeof hours / sizeof hours[0]; ++k) {
        const double sd = first_sd_udeg(hours[k] * 3600u);
        const double walk_mm2 = ATTITUDE_OFFSET_WALK_UM2_H_DEFAULT * 1e-6 * hours[k];
        const double want_rad2 = 2.0 * walk_mm2 / (4.0 * ARM_MM * ARM_MM);
        const double want_udeg = sqrt(want_rad2) * 180.0 / TEST_PI * 1e6;
        const double added = sqrt(sd * sd - base * base);
        print_message("age %5u h: alpha sd %.0f udeg (at 0 h: %.0f), added %.0f, walk alone %.0f\n",
                      hours[k], sd, base, added, want_udeg);
        assert_true(sd > last);
        if (want_udeg > base) { /* where the walk dominates, it is all of what is added */
            assert_true(fabs(added / want_udeg - 1.0) < 0.05);
        }
        last = sd;
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_the_age_adds_its_walk_from_the_first_window),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
