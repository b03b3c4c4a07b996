/* The head-calibration file v1 (docs/reference/calibration-file.md): reading, its errors with line
 * and column, writing and reading back. */
#define _POSIX_C_SOURCE 200809L /* fmemopen */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>

#include "calibrate/head_cal.h"

#define V1         "# tof-head-cal v1\n"
#define OFFSETS    "# offset_mm=-3.105,7.882,0.516,-12.340\n"
#define OFFSET_SDS "# offset_sd_mm=0.028,0.029,0.028,0.030\n"
#define GAINS      "# gain=1.00410,0.99187,1.01202,0.99655\n"
#define GAIN_SDS   "# gain_sd=0.00019,0.00020,0.00019,0.00021\n"

static int parse(const char *text, struct head_cal *cal, char *err, size_t len) {
    return head_cal_parse(text, strlen(text), "HEAD.cal", cal, err, len);
}

static void expect_error(const char *text, const char *want) {
    struct head_cal cal;
    char err[HEAD_CAL_ERR_MAX] = "";
    assert_int_equal(parse(text, &cal, err, sizeof err), -1);
    if (strcmp(err, want) != 0) {
        fail_msg("error\n  '%s'\nwanted\n  '%s'", err, want);
    }
}

static void test_design_example(void **state) {
    (void)state;
    struct head_cal cal;
    char err[HEAD_CAL_ERR_MAX] = "";
    assert_int_equal(parse(V1 OFFSETS OFFSET_SDS GAINS GAIN_SDS, &cal, err, sizeof err), 0);
    assert_true(cal.has_gain);
    assert_true(cal.offset_mm[0] == -3.105 && cal.offset_mm[3] == -12.34);
    assert_true(cal.offset_sd_mm[1] == 0.029);
    assert_true(cal.gain[2] == 1.01202 && cal.gain_sd[3] == 0.00021);
}

static void test_offsets_only_and_extras(void **state) {
    (void)state;
    struct head_cal cal;
    char err[HEAD_CAL_ERR_MAX] = "";
    const char *text = "\xEF\xBB\xBF# tof-head-cal v1\r\n# a comment line\r\n\r\n"
                       "#offset_mm = 1, 2 ,3,4\r\n# offset_sd_mm=0,0,0,0\r\n"
                       "# fit=offsets\r\n# stations=20\r\n";
    assert_int_equal(parse(text, &cal, err, sizeof err), 0);
    assert_false(cal.has_gain);
    for (unsigned k = 0; k < 4u; ++k) {
        assert_true(cal.offset_mm[k] == k + 1.0);
        assert_true(cal.gain[k] == 1.0 && cal.gain_sd[k] == 0.0);
    }
    assert_string_equal(head_cal_extra(&cal, "fit"), "offsets");
    assert_string_equal(head_cal_extra(&cal, "stations"), "20");
    assert_null(head_cal_extra(&cal, "nothing"));
}

static void test_errors(void **state) {
    (void)state;
    expect_error("", "HEAD.cal:1:1: empty file (expected '# tof-head-cal v1')");
    expect_error("# tof-trace v1\n",
                 "HEAD.cal:1:1: expected '# tof-head-cal v1' as the first line");
    expect_error(V1 OFFSETS, "HEAD.cal: missing required key offset_sd_mm (a line "
                             "'# offset_sd_mm=A,B,C,D')");
    expect_error(V1 OFFSET_SDS, "HEAD.cal: missing required key offset_mm (a line "
                                "'# offset_mm=A,B,C,D')");
    expect_error(V1 OFFSETS OFFSET_SDS GAINS,
                 "HEAD.cal:4: gain without gain_sd (they come together or not at all)");
    expect_error(V1 OFFSETS OFFSET_SDS GAIN_SDS,
                 "HEAD.cal:4: gain_sd without gain (they come together or not at all)");
    expect_error(V1 "# offset_mm=1,2,3\n" OFFSET_SDS,
                 "HEAD.cal:2:18: offset_mm: 3 values, expected 4 (A, B, C, D)");
    expect_error(V1 "# offset_mm=1,2,3,4,5\n" OFFSET_SDS,
                 "HEAD.cal:2:21: offset_mm: more than 4 values (sensors A, B, C, D)");
    expect_error(V1 "# offset_mm=1,2,x3,4\n" OFFSET_SDS,
                 "HEAD.cal:2:17: offset_mm: value 3 (sensor C): expected a decimal number, got "
                 "'x3'");
    expect_error(V1 "# offset_mm=1,,3,4\n" OFFSET_SDS,
                 "HEAD.cal:2:15: offset_mm: value 2 (sensor B): expected a decimal number, got ''");
    expect_error(V1 "# offset_mm=1,2,3,inf\n" OFFSET_SDS,
                 "HEAD.cal:2:19: offset_mm: value 4 (sensor D): expected a decimal number, got "
                 "'inf'");
    expect_error(V1 OFFSETS "# offset_sd_mm=0.1,-0.1,0.1,0.1\n",
                 "HEAD.cal:3:20: offset_sd_mm: sensor B: an sd cannot be negative, got '-0.1'");
    expect_error(V1 OFFSETS OFFSET_SDS "# gain=1,0,1,1\n" GAIN_SDS,
                 "HEAD.cal:4:10: gain: sensor B: must be positive, got '0'");
    expect_error(V1 OFFSETS OFFSETS, "HEAD.cal:3: duplicate key 'offset_mm' (first on line 2)");
    expect_error(V1 OFFSETS "offset_sd_mm=1,1,1,1\n",
                 "HEAD.cal:3:1: expected '# key=value' or a comment line");
    expect_error(V1 OFFSETS "# offset_sd_mm=1,1,1,1\rx\n", "HEAD.cal:3:23: CR byte in the line");
}

static void test_write_reads_back(void **state) {
    (void)state;
    struct head_cal cal = {.has_gain = true,
                           .offset_mm = {-3.1054321, 7.882, 0.516, -12.34},
                           .offset_sd_mm = {0.0281, 0.029, 0.028, 0.03},
                           .gain = {1.0041, 0.99187, 1.01202, 0.99655},
                           .gain_sd = {0.00019, 0.0002, 0.00019, 0.00021}};
    char buf[2048];
    FILE *f = fmemopen(buf, sizeof buf, "w");
    assert_non_null(f);
    const char *extra[] = {"fit=offsets+gains", "stations=20", NULL};
    assert_int_equal(head_cal_write(f, &cal, extra), 0);
    const long len = ftell(f);
    fclose(f);
    struct head_cal back;
    char err[HEAD_CAL_ERR_MAX] = "";
    assert_int_equal(head_cal_parse(buf, (size_t)len, "w.cal", &back, err, sizeof err), 0);
    assert_true(back.has_gain);
    for (unsigned k = 0; k < 4u; ++k) {
        assert_true(fabs(back.offset_mm[k] - cal.offset_mm[k]) <= 1e-9 * fabs(cal.offset_mm[k]));
        assert_true(fabs(back.gain[k] - cal.gain[k]) <= 1e-9);
        assert_true(fabs(back.gain_sd[k] - cal.gain_sd[k]) <= 1e-12);
    }
    assert_string_equal(head_cal_extra(&back, "stations"), "20");
    assert_true(back.checksummed);
    /* Its checksum line catches a cut and an edit, naming the line
     * (docs/reference/calibration-file.md). */
    assert_int_equal(head_cal_parse(buf, (size_t)len - 3u, "w.cal", &back, err, sizeof err), -1);
    assert_non_null(strstr(err, "the file was cut"));
    char *digit = strstr(buf, "offset_mm=-3.");
    assert_non_null(digit);
    digit[11] = '4'; /* -3.1 -> -4.1: the same length, a different head */
    assert_int_equal(head_cal_parse(buf, (size_t)len, "w.cal", &back, err, sizeof err), -1);
    assert_non_null(strstr(err, "does not match the content before it"));
    assert_true(strncmp(err, "w.cal:8:", 8u) == 0);
    /* a file without one (written before checksums) reads as it stands */
    static const char v1[] = "# tof-head-cal v1\n# offset_mm=1,2,3,4\n# offset_sd_mm=1,1,1,1\n";
    assert_int_equal(head_cal_parse(v1, sizeof v1 - 1u, "v1.cal", &back, err, sizeof err), 0);
    assert_false(back.checksummed);
    /* Offsets only: no gain keys are written. */
    cal.has_gain = false;
    f = fmemopen(buf, sizeof buf, "w");
    assert_int_equal(head_cal_write(f, &cal, NULL), 0);
    fputc('\0', f);
    fclose(f);
    assert_null(strstr(buf, "gain"));
    const char *bad[] = {"no equals sign", NULL};
    f = fmemopen(buf, sizeof buf, "w");
    assert_int_equal(head_cal_write(f, &cal, bad), -1);
    fclose(f);
}

/* Keys from another source (a trace's metadata): the same checks, the line only. */
static void test_keys_one_by_one(void **state) {
    (void)state;
    struct head_cal_reader r;
    head_cal_begin(&r, "T.csv");
    assert_int_equal(head_cal_key(&r, "offset_mm", "1,2,3,4", 3u, 0u), 0);
    assert_int_equal(head_cal_key(&r, "offset_sd_mm", "1,2,3", 4u, 0u), -1);
    assert_string_equal(r.err, "T.csv:4: offset_sd_mm: 3 values, expected 4 (A, B, C, D)");
    assert_int_equal(head_cal_finish(&r), -1);
    assert_string_equal(r.err, "T.csv: missing required key offset_sd_mm (a line "
                               "'# offset_sd_mm=A,B,C,D')");
}

#define THERMAL                                                                                    \
    "# cal_temp_c=24.98\n# temp_coeff_mm_per_c=0.023468,-0.002228,0.034379,-0.013438\n"            \
    "# temp_coeff_sd_mm_per_c=0.001145,0.001094,0.001107,0.001367\n"

static void test_thermal_keys(void **state) {
    (void)state;
    struct head_cal cal;
    char err[HEAD_CAL_ERR_MAX] = "";
    assert_int_equal(parse(V1 OFFSETS OFFSET_SDS GAINS GAIN_SDS THERMAL, &cal, err, sizeof err), 0);
    assert_true(cal.thermal);
    assert_true(cal.cal_temp_c == 24.98);
    assert_true(cal.temp_coeff_mm_per_c[1] == -0.002228 &&
                cal.temp_coeff_sd_mm_per_c[3] == 0.001367);
    assert_int_equal(parse(V1 OFFSETS OFFSET_SDS, &cal, err, sizeof err), 0);
    assert_false(cal.thermal);
    /* written and read back: the same values, the checksum over them */
    static char buf[8192];
    FILE *f = fmemopen(buf, sizeof buf, "w");
    assert_non_null(f);
    struct head_cal w = {.has_gain = false, .thermal = true, .cal_temp_c = -12.5};
    for (unsigned k = 0; k < 4u; ++k) {
        w.offset_mm[k] = k;
        w.temp_coeff_mm_per_c[k] = 0.2 * k - 0.3;
        w.temp_coeff_sd_mm_per_c[k] = 0.000125 * k;
    }
    assert_int_equal(head_cal_write(f, &w, NULL), 0);
    fclose(f);
    assert_non_null(strstr(buf, "# cal_temp_c=-12.50\n"));
    assert_int_equal(parse(buf, &cal, err, sizeof err), 0);
    assert_true(cal.checksummed && cal.thermal && cal.cal_temp_c == -12.5);
    for (unsigned k = 0; k < 4u; ++k) {
        assert_true(fabs(cal.temp_coeff_mm_per_c[k] - w.temp_coeff_mm_per_c[k]) < 1e-12);
        assert_true(fabs(cal.temp_coeff_sd_mm_per_c[k] - w.temp_coeff_sd_mm_per_c[k]) < 1e-12);
    }
    /* an edited coefficient breaks the checksum */
    char *at = strstr(buf, "temp_coeff_mm_per_c=-0.3");
    assert_non_null(at);
    at[strlen("temp_coeff_mm_per_c=-0.")] = '4';
    assert_int_equal(parse(buf, &cal, err, sizeof err), -1);
    assert_non_null(strstr(err, "checksum"));
}

static void test_thermal_errors(void **state) {
    (void)state;
    expect_error(V1 OFFSETS OFFSET_SDS "# cal_temp_c=20\n",
                 "HEAD.cal:4: cal_temp_c without all of cal_temp_c, temp_coeff_mm_per_c, "
                 "temp_coeff_sd_mm_per_c (they come together or not at all)");
    expect_error(V1 OFFSETS OFFSET_SDS "# temp_coeff_sd_mm_per_c=0,0,0,0\n",
                 "HEAD.cal:4: temp_coeff_sd_mm_per_c without all of cal_temp_c, "
                 "temp_coeff_mm_per_c, temp_coeff_sd_mm_per_c (they come together or not at all)");
    expect_error(V1 OFFSETS OFFSET_SDS "# cal_temp_c=20,21\n",
                 "HEAD.cal:4:17: cal_temp_c: one value (the head's), not a list");
    expect_error(V1 OFFSETS OFFSET_SDS "# cal_temp_c=250\n",
                 "HEAD.cal:4:14: cal_temp_c: within -100..200 C, got '250'");
    expect_error(V1 OFFSETS OFFSET_SDS "# temp_coeff_mm_per_c=0,0,1.5,0\n",
                 "HEAD.cal:4:27: temp_coeff_mm_per_c: sensor C: within -1..1 mm/C (no VL53 "
                 "part's beyond), got '1.5'");
    expect_error(V1 OFFSETS OFFSET_SDS "# temp_coeff_sd_mm_per_c=0,-0.1,0,0\n",
                 "HEAD.cal:4:28: temp_coeff_sd_mm_per_c: sensor B: an sd cannot be negative, got "
                 "'-0.1'");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_design_example),  cmocka_unit_test(test_offsets_only_and_extras),
        cmocka_unit_test(test_errors),          cmocka_unit_test(test_write_reads_back),
        cmocka_unit_test(test_keys_one_by_one), cmocka_unit_test(test_thermal_keys),
        cmocka_unit_test(test_thermal_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
