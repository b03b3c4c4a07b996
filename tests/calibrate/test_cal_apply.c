/* A replay's head calibration (calibrate/cal_apply.h): a HEAD.cal's thermal keys read in the
 * trace reader's integers and mapped into the estimator's calibration_head in its units. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <stdio.h>

#include "calibrate/cal_apply.h"
#include "estimator/calibration.h"

/* Writes text to a temporary file; its path in path. */
static void write_file(const char *text, char *path, size_t len) {
    snprintf(path, len, "test_cal_apply_%u.cal", (unsigned)strlen(text));
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fputs(text, f) >= 0, 1);
    assert_int_equal(fclose(f), 0);
}

static void test_thermal_keys_mapped(void **state) {
    (void)state;
    char path[64];
    write_file("# tof-head-cal v1\n# offset_mm=1,2,3,4\n# offset_sd_mm=0.1,0.1,0.1,0.1\n"
               "# cal_temp_c=24.985\n# temp_coeff_mm_per_c=0.023468,-0.002228,1,-1\n"
               "# temp_coeff_sd_mm_per_c=0.001145,0.000001,0,0.5\n",
               path, sizeof path);
    struct trace_v1_cal cal;
    char err[512] = "";
    if (cal_apply_load(path, &cal, NULL, err, sizeof err) != 0) {
        fail_msg("%s", err);
    }
    remove(path);
    assert_true(cal.calibrated && cal.thermal);
    struct calibration_head head;
    cal_apply_head(&cal, &head);
    assert_true(head.calibrated && head.thermal);
    assert_int_equal(head.cal_temp_cdeg, 2499); /* 0.01 °C, half away from zero */
    const int32_t k[4] = {23468, -2228, 1000000, -1000000};
    const uint32_t sd[4] = {1145, 1, 0, 500000};
    for (unsigned i = 0; i < 4u; ++i) {
        assert_int_equal(head.temp_coeff_nm_per_c[i], k[i]); /* nm per °C */
        assert_int_equal(head.temp_coeff_sd_nm_per_c[i], sd[i]);
        assert_int_equal(head.offset_um[i], (int32_t)(1000u * (i + 1u)));
    }
}

static void test_without_thermal_keys(void **state) {
    (void)state;
    char path[64];
    write_file("# tof-head-cal v1\n# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n", path,
               sizeof path);
    struct trace_v1_cal cal;
    char err[512] = "";
    assert_int_equal(cal_apply_load(path, &cal, NULL, err, sizeof err), 0);
    remove(path);
    struct calibration_head head;
    cal_apply_head(&cal, &head);
    assert_true(head.calibrated);
    assert_false(head.thermal);
    assert_int_equal(head.cal_temp_cdeg, 0);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_int_equal(head.temp_coeff_nm_per_c[i], 0);
        assert_int_equal(head.temp_coeff_sd_nm_per_c[i], 0);
    }
    /* an incomplete set is an error naming the file and line */
    write_file("# tof-head-cal v1\n# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n"
               "# cal_temp_c=20\n# temp_coeff_mm_per_c=0,0,0,0\n",
               path, sizeof path);
    assert_int_equal(cal_apply_load(path, &cal, NULL, err, sizeof err), -1);
    remove(path);
    assert_non_null(strstr(err, ":4: cal_temp_c without all of"));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_thermal_keys_mapped),
        cmocka_unit_test(test_without_thermal_keys),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
