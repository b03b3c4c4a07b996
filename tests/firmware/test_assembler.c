/* Sample assembly by time slot: completeness, deadlines, gaps, late and duplicate readings. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "firmware/assembler.h"

#define MAX_OUT 64
struct sink {
    struct tof_sample out[MAX_OUT];
    unsigned n;
};

static void collect(void *ctx, const struct tof_sample *s) {
    struct sink *k = ctx;
    assert_true(k->n < MAX_OUT);
    k->out[k->n++] = *s;
}

static const struct tof_assembler_config cfg = {
    .period_us = 20000, .max_skew_us = 5000, .max_emit_per_call = 8};

/* The sink collecting into k. */
#define SINK(k) (&(struct tof_sample_sink){.emit = collect, .ctx = (k)})

static void add4(struct tof_assembler *a, struct sink *k, uint64_t t, uint16_t base) {
    for (unsigned i = 0; i < 4; ++i) {
        tof_assembler_add(a, &cfg, i, t + i * 300u, (uint16_t)(base + i), 0, SINK(k));
    }
}

static void test_complete_slots_are_emitted_in_order_at_once(void **state) {
    (void)state;
    struct tof_assembler a;
    struct sink k = {0};
    tof_assembler_init(&a, 1000);
    add4(&a, &k, 1000 + 15000, 100);
    add4(&a, &k, 1000 + 35000, 200);
    assert_int_equal(k.n, 2);
    assert_int_equal(k.out[0].index, 0);
    assert_int_equal(k.out[0].present_mask, 0xF);
    assert_int_equal(k.out[0].range_mm[3], 103);
    assert_int_equal(k.out[0].t_us, 21000);
    assert_int_equal(k.out[1].index, 1);
    assert_int_equal(k.out[1].range_mm[0], 200);
    assert_int_equal(a.counters.incomplete, 0);
}

static void test_missing_sensor_emitted_after_deadline_only(void **state) {
    (void)state;
    struct tof_assembler a;
    struct sink k = {0};
    tof_assembler_init(&a, 0);
    for (unsigned i = 0; i < 3; ++i) {
        tof_assembler_add(&a, &cfg, i, 10000, 50, 0, SINK(&k));
    }
    tof_assembler_poll(&a, &cfg, 25000, SINK(&k)); /* slot end 20000 + skew 5000: not yet */
    assert_int_equal(k.n, 0);
    tof_assembler_poll(&a, &cfg, 25001, SINK(&k));
    assert_int_equal(k.n, 1);
    assert_int_equal(k.out[0].present_mask, 0x7);
    assert_int_equal(a.counters.incomplete, 1);
}

static void test_empty_slots_keep_alignment(void **state) {
    (void)state;
    struct tof_assembler a;
    struct sink k = {0};
    tof_assembler_init(&a, 0);
    tof_assembler_poll(&a, &cfg, 3u * 20000u + 5001u, SINK(&k));
    assert_int_equal(k.n, 3);
    assert_int_equal(k.out[2].index, 2);
    assert_int_equal(k.out[2].present_mask, 0);
    add4(&a, &k, 3u * 20000u + 100u, 7);
    assert_int_equal(k.n, 4);
    assert_int_equal(k.out[3].index, 3);
}

static void test_late_and_duplicate_readings_are_counted_not_used(void **state) {
    (void)state;
    struct tof_assembler a;
    struct sink k = {0};
    tof_assembler_init(&a, 0);
    add4(&a, &k, 1000, 10);
    tof_assembler_add(&a, &cfg, 2, 5000, 99, 0, SINK(&k)); /* slot 0 already emitted */
    assert_int_equal(a.counters.late, 1);
    tof_assembler_add(&a, &cfg, 1, 21000, 11, 0, SINK(&k));
    tof_assembler_add(&a, &cfg, 1, 22000, 12, 0, SINK(&k));
    assert_int_equal(a.counters.duplicates, 1);
    assert_int_equal(k.n, 1);
}

static void test_reading_far_ahead_flushes_older_slots(void **state) {
    (void)state;
    struct tof_assembler a;
    struct sink k = {0};
    tof_assembler_init(&a, 0);
    tof_assembler_add(&a, &cfg, 0, 1000, 10, 0, SINK(&k));
    tof_assembler_add(&a, &cfg, 0, 3u * 20000u + 10u, 13, 3, SINK(&k));
    assert_int_equal(k.n, 2); /* slots 0 and 1 emitted, 2 and 3 pending */
    assert_int_equal(k.out[0].present_mask, 0x1);
    assert_int_equal(k.out[1].present_mask, 0x0);
    tof_assembler_poll(&a, &cfg, 5u * 20000u, SINK(&k));
    assert_int_equal(k.n, 4);
    assert_int_equal(k.out[3].index, 3);
    assert_int_equal(k.out[3].status[0], 3);
}

static void test_emission_per_call_is_bounded(void **state) {
    (void)state;
    struct tof_assembler a;
    struct sink k = {0};
    tof_assembler_init(&a, 0);
    tof_assembler_poll(&a, &cfg, 100u * 20000u, SINK(&k));
    assert_int_equal(k.n, cfg.max_emit_per_call);
    tof_assembler_add(&a, &cfg, 0, 100u * 20000u, 1, 0, SINK(&k)); /* too far: counted */
    assert_int_equal(a.counters.late, 1);
    assert_int_equal(k.n, 2u * cfg.max_emit_per_call);
}

static void test_bad_sensor_and_pre_origin_readings_are_counted(void **state) {
    (void)state;
    struct tof_assembler a;
    struct sink k = {0};
    tof_assembler_init(&a, 50000);
    tof_assembler_add(&a, &cfg, 4, 60000, 1, 0, SINK(&k));
    tof_assembler_add(&a, &cfg, 0, 40000, 1, 0, SINK(&k));
    assert_int_equal(a.counters.late, 2);
    assert_int_equal(k.n, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_complete_slots_are_emitted_in_order_at_once),
        cmocka_unit_test(test_missing_sensor_emitted_after_deadline_only),
        cmocka_unit_test(test_empty_slots_keep_alignment),
        cmocka_unit_test(test_late_and_duplicate_readings_are_counted_not_used),
        cmocka_unit_test(test_reading_far_ahead_flushes_older_slots),
        cmocka_unit_test(test_emission_per_call_is_bounded),
        cmocka_unit_test(test_bad_sensor_and_pre_origin_readings_are_counted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
