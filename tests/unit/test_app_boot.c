/* The application boots on a platform with only a log, and on one with none. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "firmware/app.h"

struct capture {
    char text[256];
    size_t len;
};

static void capture_write(void *ctx, const char *text, size_t len) {
    struct capture *cap = ctx;
    assert_true(cap->len + len < sizeof cap->text);
    memcpy(cap->text + cap->len, text, len);
    cap->len += len;
    cap->text[cap->len] = '\0';
}

static const struct hal_log_ops capture_ops = {.write = capture_write};

static void test_boot_banner_names_firmware_and_board(void **state) {
    (void)state;
    struct capture cap = {0};
    const struct tof_platform platform = {.board_name = "unit",
                                          .log = {.ops = &capture_ops, .ctx = &cap}};
    assert_int_equal(tof_app_main(&platform), 0);
    assert_string_equal(cap.text, TOF_FW_NAME " " TOF_FW_VERSION "\nunit\n");
}

static void test_boot_without_log_is_silent_and_succeeds(void **state) {
    (void)state;
    const struct tof_platform platform = {.board_name = "silent"};
    assert_int_equal(tof_app_main(&platform), 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_boot_banner_names_firmware_and_board),
        cmocka_unit_test(test_boot_without_log_is_silent_and_succeeds),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
