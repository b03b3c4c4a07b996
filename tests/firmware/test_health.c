/* Fault manager: per-sensor health state machine transitions and timeouts. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "firmware/health.h"

static const struct tof_health_config cfg = {
    .errors_to_lost = 3,
    .good_to_healthy = 2,
    .silence_to_lost_ms = 100,
    .reinit_backoff_ms = 50,
    .recovery_timeout_ms = 200,
    .suspect_timeout_ms = 300,
    .trouble_errors = 5,
};

/* One flap: an error at t (SUSPECT), then two good readings (HEALTHY again). */
static void flap(struct tof_health *h, uint32_t t, enum tof_error_scope scope) {
    tof_health_on_error(h, &cfg, t, scope);
    assert_int_equal(h->state, TOF_HEALTH_SUSPECT);
    tof_health_on_good(h, &cfg, t + 10u);
    tof_health_on_good(h, &cfg, t + 20u);
    assert_int_equal(h->state, TOF_HEALTH_HEALTHY);
}

static void test_single_error_makes_suspect_then_good_reads_heal(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    tof_health_on_error(&h, &cfg, 10, TOF_ERROR_SENSOR);
    assert_int_equal(h.state, TOF_HEALTH_SUSPECT);
    assert_true(tof_health_usable(&h));
    tof_health_on_good(&h, &cfg, 30);
    assert_int_equal(h.state, TOF_HEALTH_SUSPECT); /* needs two in a row */
    tof_health_on_good(&h, &cfg, 50);
    assert_int_equal(h.state, TOF_HEALTH_HEALTHY);
    assert_int_equal(h.transitions, 2);
}

static void test_consecutive_errors_lose_and_ask_for_reinit(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    for (uint32_t t = 1; t <= 3; ++t) {
        tof_health_on_error(&h, &cfg, t, TOF_ERROR_SENSOR);
    }
    assert_int_equal(h.state, TOF_HEALTH_LOST);
    assert_false(tof_health_usable(&h));
    assert_int_equal(h.losses, 1);
    assert_int_equal(tof_health_poll(&h, &cfg, 3), TOF_HEALTH_ACT_REINIT);
}

/* The sensor reports its own hardware fault (VL53 raw 1, 2, 3, 17 -> HAL_ERR_DEVICE): one
 * is enough, and what it asks for is a re-init of that sensor. */
static void test_device_fault_loses_the_sensor_at_once(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    tof_health_on_error(&h, &cfg, 5, TOF_ERROR_DEVICE);
    assert_int_equal(h.state, TOF_HEALTH_LOST);
    assert_int_equal(h.losses, 1);
    assert_int_equal(tof_health_poll(&h, &cfg, 5), TOF_HEALTH_ACT_REINIT);
    /* From SUSPECT too. */
    tof_health_init(&h, 0);
    tof_health_on_error(&h, &cfg, 1, TOF_ERROR_SENSOR);
    assert_int_equal(h.state, TOF_HEALTH_SUSPECT);
    tof_health_on_error(&h, &cfg, 2, TOF_ERROR_DEVICE);
    assert_int_equal(h.state, TOF_HEALTH_LOST);
}

static void test_interleaved_good_read_resets_error_count(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    tof_health_on_error(&h, &cfg, 1, TOF_ERROR_SENSOR);
    tof_health_on_error(&h, &cfg, 2, TOF_ERROR_SENSOR);
    tof_health_on_good(&h, &cfg, 3);
    tof_health_on_error(&h, &cfg, 4, TOF_ERROR_SENSOR);
    tof_health_on_error(&h, &cfg, 5, TOF_ERROR_SENSOR);
    assert_int_equal(h.state, TOF_HEALTH_SUSPECT);
}

static void test_silence_loses_sensor(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 1000);
    assert_int_equal(tof_health_poll(&h, &cfg, 1100), TOF_HEALTH_ACT_NONE);
    assert_int_equal(tof_health_poll(&h, &cfg, 1101), TOF_HEALTH_ACT_REINIT);
    assert_int_equal(h.state, TOF_HEALTH_LOST);
}

static void test_failed_reinit_backs_off_then_retries(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    assert_int_equal(tof_health_poll(&h, &cfg, 101), TOF_HEALTH_ACT_REINIT);
    tof_health_on_reinit_done(&h, &cfg, 102, false);
    assert_int_equal(h.state, TOF_HEALTH_LOST);
    assert_int_equal(tof_health_poll(&h, &cfg, 151), TOF_HEALTH_ACT_NONE);
    assert_int_equal(tof_health_poll(&h, &cfg, 152), TOF_HEALTH_ACT_REINIT);
    tof_health_on_reinit_done(&h, &cfg, 153, true);
    assert_int_equal(h.state, TOF_HEALTH_RECOVERING);
    tof_health_on_good(&h, &cfg, 180);
    assert_int_equal(h.state, TOF_HEALTH_HEALTHY);
}

static void test_recovery_without_data_times_out(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    (void)tof_health_poll(&h, &cfg, 101);
    tof_health_on_reinit_done(&h, &cfg, 110, true);
    assert_int_equal(tof_health_poll(&h, &cfg, 310), TOF_HEALTH_ACT_NONE);
    assert_int_equal(tof_health_poll(&h, &cfg, 311), TOF_HEALTH_ACT_REINIT);
    assert_int_equal(h.state, TOF_HEALTH_LOST);
    assert_int_equal(h.losses, 2);
}

static void test_suspect_for_too_long_is_lost(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    /* errors keep interleaving with good readings: never two good in a row */
    for (uint32_t t = 10; t <= 300; t += 20) {
        tof_health_on_error(&h, &cfg, t, TOF_ERROR_SENSOR);
        tof_health_on_good(&h, &cfg, t + 10u);
        assert_int_equal(tof_health_poll(&h, &cfg, t + 10u), TOF_HEALTH_ACT_NONE);
    }
    assert_int_equal(h.state, TOF_HEALTH_SUSPECT);
    tof_health_on_error(&h, &cfg, 310, TOF_ERROR_SENSOR);
    assert_int_equal(tof_health_poll(&h, &cfg, 311), TOF_HEALTH_ACT_REINIT);
    assert_int_equal(h.state, TOF_HEALTH_LOST);
}

/* A data-ready line stuck high: a stale read (error) between every two good readings, so
 * the sensor flips SUSPECT -> HEALTHY -> SUSPECT. The trouble lasts: LOST after 300 ms. */
static void test_flapping_sensor_is_lost(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    uint32_t t = 10;
    for (; t <= 300; t += 30) {
        flap(&h, t, TOF_ERROR_SENSOR);
        assert_int_equal(tof_health_poll(&h, &cfg, t + 20u), TOF_HEALTH_ACT_NONE);
    }
    tof_health_on_error(&h, &cfg, t, TOF_ERROR_SENSOR);
    assert_int_equal(tof_health_poll(&h, &cfg, t + 1u), TOF_HEALTH_ACT_REINIT);
    assert_int_equal(h.state, TOF_HEALTH_LOST);
    /* the re-init starts a fresh episode */
    tof_health_on_reinit_done(&h, &cfg, t + 5u, true);
    tof_health_on_good(&h, &cfg, t + 25u);
    assert_int_equal(h.state, TOF_HEALTH_HEALTHY);
    assert_int_equal(tof_health_poll(&h, &cfg, t + 26u), TOF_HEALTH_ACT_NONE);
}

/* Isolated errors, each followed by a clean stretch longer than 300 ms: never LOST. */
static void test_isolated_errors_with_clean_stretches_stay_usable(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    for (uint32_t t = 10; t < 5000u; t += 20) {
        if (t % 400u == 10u) {
            tof_health_on_error(&h, &cfg, t, TOF_ERROR_SENSOR);
        } else {
            tof_health_on_good(&h, &cfg, t);
        }
        assert_int_equal(tof_health_poll(&h, &cfg, t), TOF_HEALTH_ACT_NONE);
    }
    assert_int_equal(h.losses, 0);
}

/* Four sporadic errors 250 ms apart chain into one 750 ms episode (no 300 ms clean
 * stretch), but four is below trouble_errors: usable throughout; a fifth makes it LOST. */
static void test_sparse_chained_errors_need_the_error_count(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    for (uint32_t t = 10; t <= 1000u; t += 10) {
        if (t % 250u == 0u) {
            tof_health_on_error(&h, &cfg, t, TOF_ERROR_SENSOR);
        } else {
            tof_health_on_good(&h, &cfg, t);
        }
        assert_int_equal(tof_health_poll(&h, &cfg, t), TOF_HEALTH_ACT_NONE);
    }
    assert_true(h.in_trouble);
    assert_int_equal(h.trouble_error_count, 4);
    tof_health_on_error(&h, &cfg, 1010, TOF_ERROR_SENSOR);
    assert_int_equal(tof_health_poll(&h, &cfg, 1010), TOF_HEALTH_ACT_REINIT);
    assert_int_equal(h.state, TOF_HEALTH_LOST);
}

/* A burst of 5 errors in 90 ms, each followed by a good reading, then clean: the errors
 * span less than the timeout, so the sensor stays usable however long the run goes on. */
static void test_burst_then_clean_stays_usable(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    for (uint32_t t = 10; t <= 90u; t += 20) {
        tof_health_on_error(&h, &cfg, t, TOF_ERROR_SENSOR);
        tof_health_on_good(&h, &cfg, t + 5u);
        tof_health_on_good(&h, &cfg, t + 10u);
    }
    for (uint32_t t = 110; t <= 1000u; t += 10) {
        tof_health_on_good(&h, &cfg, t);
        assert_int_equal(tof_health_poll(&h, &cfg, t), TOF_HEALTH_ACT_NONE);
    }
    assert_int_equal(h.state, TOF_HEALTH_HEALTHY);
    assert_int_equal(h.losses, 0);
}

/* An error after a clean stretch longer than the timeout starts a new episode even when
 * no poll ran in between (the main loop reads sensors before it manages them). */
static void test_error_after_clean_stretch_starts_a_new_episode(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    for (uint32_t t = 10; t <= 250u; t += 60) { /* 5 errors spanning 240 ms */
        flap(&h, t, TOF_ERROR_SENSOR);
    }
    tof_health_on_error(&h, &cfg, 600, TOF_ERROR_SENSOR); /* 350 ms clean, no poll: a new episode */
    assert_int_equal(h.trouble_since_ms, 600);
    assert_int_equal(h.trouble_error_count, 1);
    tof_health_on_good(&h, &cfg, 610);
    tof_health_on_good(&h, &cfg, 620);
    assert_int_equal(tof_health_poll(&h, &cfg, 620), TOF_HEALTH_ACT_NONE);
}

/* The trouble rule across the 32-bit millisecond wrap. */
static void test_trouble_across_the_clock_wrap(void **state) {
    (void)state;
    struct tof_health h;
    const uint32_t start = UINT32_MAX - 100u;
    tof_health_init(&h, start);
    uint32_t t = start;
    for (unsigned i = 0; i < 11u; ++i, t += 30u) { /* errors over 300 ms, wrapping */
        flap(&h, t, TOF_ERROR_SENSOR);
        const enum tof_health_action want = i == 10u ? TOF_HEALTH_ACT_REINIT : TOF_HEALTH_ACT_NONE;
        assert_int_equal(tof_health_poll(&h, &cfg, t + 20u), want);
    }
    assert_int_equal(h.state, TOF_HEALTH_LOST);
}

/* Bus-wide errors (SDA stuck, bus busy) flapping with good readings: bus recovery's job,
 * not a re-init's, so they never make a trouble episode (consecutive ones still count). */
static void test_bus_errors_are_not_trouble(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, 0);
    for (uint32_t t = 10; t <= 1000u; t += 30) {
        flap(&h, t, TOF_ERROR_BUS);
        assert_int_equal(tof_health_poll(&h, &cfg, t + 20u), TOF_HEALTH_ACT_NONE);
    }
    assert_false(h.in_trouble);
    for (uint32_t t = 1010; t <= 1030u; t += 10) {
        tof_health_on_error(&h, &cfg, t, TOF_ERROR_BUS);
    }
    assert_int_equal(h.state, TOF_HEALTH_LOST); /* errors_to_lost in a row */
}

static void test_timestamps_wrap(void **state) {
    (void)state;
    struct tof_health h;
    tof_health_init(&h, UINT32_MAX - 10u);
    assert_int_equal(tof_health_poll(&h, &cfg, 50), TOF_HEALTH_ACT_NONE);   /* 61 ms later */
    assert_int_equal(tof_health_poll(&h, &cfg, 90), TOF_HEALTH_ACT_REINIT); /* 101 ms later */
}

static void test_config_validation(void **state) {
    (void)state;
    assert_true(tof_health_config_valid(&cfg));
    struct tof_health_config bad = cfg;
    bad.errors_to_lost = 0;
    assert_false(tof_health_config_valid(&bad));
    bad = cfg;
    bad.silence_to_lost_ms = 0;
    assert_false(tof_health_config_valid(&bad));
    bad = cfg;
    bad.trouble_errors = 0;
    assert_false(tof_health_config_valid(&bad));
    assert_string_equal(tof_health_name(TOF_HEALTH_RECOVERING), "recovering");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_single_error_makes_suspect_then_good_reads_heal),
        cmocka_unit_test(test_consecutive_errors_lose_and_ask_for_reinit),
        cmocka_unit_test(test_interleaved_good_read_resets_error_count),
        cmocka_unit_test(test_silence_loses_sensor),
        cmocka_unit_test(test_failed_reinit_backs_off_then_retries),
        cmocka_unit_test(test_recovery_without_data_times_out),
        cmocka_unit_test(test_suspect_for_too_long_is_lost),
        cmocka_unit_test(test_flapping_sensor_is_lost),
        cmocka_unit_test(test_bus_errors_are_not_trouble),
        cmocka_unit_test(test_device_fault_loses_the_sensor_at_once),
        cmocka_unit_test(test_burst_then_clean_stays_usable),
        cmocka_unit_test(test_error_after_clean_stretch_starts_a_new_episode),
        cmocka_unit_test(test_trouble_across_the_clock_wrap),
        cmocka_unit_test(test_sparse_chained_errors_need_the_error_count),
        cmocka_unit_test(test_isolated_errors_with_clean_stretches_stay_usable),
        cmocka_unit_test(test_timestamps_wrap),
        cmocka_unit_test(test_config_validation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
