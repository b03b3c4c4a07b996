/* hal_err_name: every code has a distinct name; unknown codes say so. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "hal/hal_err.h"

static void test_every_code_has_a_distinct_name(void **state) {
    (void)state;
    const char *names[HAL_ERR_COUNT + 1];
    for (int code = 0; code >= HAL_ERR_LAST; --code) {
        const char *name = hal_err_name(code);
        assert_non_null(name);
        assert_string_not_equal(name, "UNKNOWN");
        for (int prev = 0; prev > code; --prev) {
            assert_string_not_equal(names[-prev], name);
        }
        names[-code] = name;
    }
    assert_string_equal(hal_err_name(HAL_ERR_TIMEOUT), "TIMEOUT");
}

static void test_unknown_code(void **state) {
    (void)state;
    assert_string_equal(hal_err_name(HAL_ERR_LAST - 1), "UNKNOWN");
    assert_string_equal(hal_err_name(1), "UNKNOWN");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_code_has_a_distinct_name),
        cmocka_unit_test(test_unknown_code),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
