/* Integer text formatting: exact digits, signs, fixed decimals, overflow flag. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <cmocka.h>

#include "firmware/text.h"

static void test_integers(void **state) {
    (void)state;
    char buf[64];
    struct tof_text t;
    tof_text_init(&t, buf, sizeof buf);
    tof_text_i64(&t, INT64_MIN);
    tof_text_str(&t, ",");
    tof_text_u64(&t, UINT64_MAX);
    tof_text_str(&t, ",");
    tof_text_i64(&t, 0);
    assert_string_equal(buf, "-9223372036854775808,18446744073709551615,0");
    assert_false(t.overflow);
}

static void test_fixed_matches_printf_over_a_sweep(void **state) {
    (void)state;
    for (int64_t v = -2000003; v <= 2000003; v += 977) {
        char buf[32];
        char ref[32];
        struct tof_text t;
        tof_text_init(&t, buf, sizeof buf);
        tof_text_fixed(&t, v, 6);
        snprintf(ref, sizeof ref, "%s%lld.%06lld", v < 0 ? "-" : "",
                 (long long)(v < 0 ? -v : v) / 1000000, (long long)(v < 0 ? -v : v) % 1000000);
        assert_string_equal(buf, ref);
    }
    char buf[16];
    struct tof_text t;
    tof_text_init(&t, buf, sizeof buf);
    tof_text_fixed(&t, -1500, 3);
    assert_string_equal(buf, "-1.500");
    tof_text_init(&t, buf, sizeof buf);
    tof_text_fixed(&t, 42, 0);
    assert_string_equal(buf, "42");
    tof_text_init(&t, buf, sizeof buf);
    tof_text_fixed(&t, 5, 10);
    assert_true(t.overflow);
}

static void test_overflow_is_flagged_and_text_stays_terminated(void **state) {
    (void)state;
    char buf[6];
    struct tof_text t;
    tof_text_init(&t, buf, sizeof buf);
    tof_text_str(&t, "abcdefgh");
    assert_true(t.overflow);
    assert_string_equal(buf, "abcde");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_integers),
        cmocka_unit_test(test_fixed_matches_printf_over_a_sweep),
        cmocka_unit_test(test_overflow_is_flagged_and_text_stays_terminated),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
