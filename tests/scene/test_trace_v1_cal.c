/* The trace v1 reader's head-calibration keys (trace/trace_v1.h, docs/reference/trace-format.md):
 * exact integers, whole-or-nothing, errors with line and column. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <stdio.h>

#include "trace/trace_v1.h"

static struct trace_v1_reader reader;
static unsigned char block[64];

struct text_input {
    const char *text;
    size_t len, pos;
};
static struct text_input input;

static int32_t read_text(void *ctx, unsigned char *buf, uint32_t len) {
    struct text_input *in = ctx;
    size_t n = in->len - in->pos;
    n = n < len ? n : len;
    memcpy(buf, in->text + in->pos, n);
    in->pos += n;
    return (int32_t)n;
}

#define HEAD "# tof-trace v1\n# arm_mm=30\n"
#define COLS "t_ms,a_mm,b_mm,c_mm,d_mm\n0,100,100,100,100\n"

static int open_meta(const char *meta) {
    static char text[2048];
    strcpy(text, HEAD);
    strcat(text, meta);
    strcat(text, COLS);
    input = (struct text_input){text, strlen(text), 0};
    return trace_v1_open(&reader, (struct trace_v1_input){read_text, &input}, block, sizeof block);
}

static void expect_error(const char *meta, uint32_t line, uint32_t col, const char *part) {
    assert_int_equal(open_meta(meta), -1);
    if (reader.err.line != line || reader.err.col != col || strstr(reader.err.msg, part) == NULL) {
        fail_msg("%u:%u: %s, wanted %u:%u: ...%s...", reader.err.line, reader.err.col,
                 reader.err.msg, line, col, part);
    }
    assert_int_equal(reader.err.line, line);
    assert_int_equal(reader.err.col, col);
    assert_non_null(strstr(reader.err.msg, part));
}

static void test_no_keys_is_uncalibrated(void **state) {
    (void)state;
    assert_int_equal(open_meta(""), 0);
    assert_false(reader.meta.cal.calibrated);
    assert_int_equal(reader.meta.cal.keys, 0);
    assert_int_equal(open_meta("# calibration=none\n"), 0);
    assert_false(reader.meta.cal.calibrated);
    assert_int_equal(reader.meta.cal.keys, TRACE_CAL_KEY_NONE);
}

static void test_inline_keys_exactly(void **state) {
    (void)state;
    assert_int_equal(open_meta("# offset_mm=-3.105,7.882,0.5165,-12.3404\n"
                               "# offset_sd_mm=0.028,0.029,0.0285,0\n"
                               "# gain=1.00410,0.99187,1.0000005,0.9999995\n"
                               "# gain_sd=0.00019,0.0002,1e-4,0.0000215\n"
                               "# offset_gain_corr=-0.93,1,-1,0.5\n"),
                     0);
    const struct trace_v1_cal *c = &reader.meta.cal;
    assert_true(c->calibrated);
    assert_true(c->has_gain);
    const int32_t off[4] = {-3105, 7882, 517, -12340}; /* half away from zero */
    const uint32_t off_sd[4] = {28, 29, 29, 0};
    const int32_t gain[4] = {4100, -8130, 1, -1}; /* ±0.5 ppm: away from zero */
    const uint32_t gain_sd[4] = {190, 200, 100, 22};
    const int16_t corr[4] = {-30474, 32767, -32768, 16384};
    for (unsigned i = 0; i < 4u; ++i) {
        assert_int_equal(c->offset_um[i], off[i]);
        assert_int_equal(c->offset_sd_um[i], off_sd[i]);
        assert_int_equal(c->gain_ppm[i], gain[i]);
        assert_int_equal(c->gain_sd_ppm[i], gain_sd[i]);
        assert_int_equal(c->corr_q15[i], corr[i]);
    }
}

static void test_offsets_only_take_the_parts_gain_spread(void **state) {
    (void)state;
    assert_int_equal(open_meta("# offset_mm=0,0,0,0\n# offset_sd_mm=0,0,0,0\n"), 0);
    const struct trace_v1_cal *c = &reader.meta.cal;
    assert_true(c->calibrated);
    assert_false(c->has_gain);
    for (unsigned i = 0; i < 4u; ++i) {
        assert_int_equal(c->offset_um[i], 0);
        assert_int_equal(c->gain_ppm[i], 0);
        assert_int_equal(c->gain_sd_ppm[i], TRACE_CAL_UNCAL_GAIN_SD_PPM);
    }
}

static void test_a_file_is_named_not_read(void **state) {
    (void)state;
    assert_int_equal(open_meta("# calibration=heads/h7.cal\n"), 0);
    assert_false(reader.meta.cal.calibrated);
    assert_int_equal(reader.meta.cal.keys, TRACE_CAL_KEY_FILE);
    assert_string_equal(trace_v1_meta(&reader, "calibration"), "heads/h7.cal");
}

static void test_bad_values_name_line_and_column(void **state) {
    (void)state;
    /* "# offset_mm=" is 12 bytes: the first value is at column 13 */
    expect_error("# offset_mm=1,2,x,4\n# offset_sd_mm=0,0,0,0\n", 3u, 17u, "not a plain decimal");
    expect_error("# offset_mm=1,2,3\n# offset_sd_mm=0,0,0,0\n", 3u, 18u, "fewer than four");
    expect_error("# offset_mm=1,2,3,4,5\n# offset_sd_mm=0,0,0,0\n", 3u, 20u, "more than four");
    expect_error("# offset_mm=1,2,3,100.001\n# offset_sd_mm=0,0,0,0\n", 3u, 19u, "-100..100 mm");
    expect_error("# offset_mm=1,2,3,4\n# offset_sd_mm=0,-0.1,0,0\n", 4u, 18u, "sd within");
    expect_error(
        "# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n# gain=1,1,1.2,1\n# gain_sd=0,0,0,0\n", 5u,
        12u, "0.9..1.1");
    expect_error(
        "# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n# gain=1,1,1,inf\n# gain_sd=0,0,0,0\n", 5u,
        14u, "not a plain decimal");
    expect_error("# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n# offset_gain_corr=0,0,1.5,0\n", 5u,
                 24u, "-1..1");
}

static void test_keys_come_as_a_whole(void **state) {
    (void)state;
    expect_error("# offset_mm=1,2,3,4\n", 3u, 1u, "offset_sd_mm");
    expect_error("# offset_sd_mm=1,2,3,4\n", 3u, 1u, "offset_mm");
    expect_error("# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n# gain=1,1,1,1\n", 3u, 1u,
                 "gain and gain_sd");
    expect_error("# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n# offset_gain_corr=0,0,0,0\n", 3u,
                 1u, "without gain");
    expect_error("# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n# calibration=h.cal\n", 3u, 1u,
                 "give one");
    expect_error("# calibration=\n", 3u, 15u, "none");
}

#define CAL "# offset_mm=1,2,3,4\n# offset_sd_mm=0,0,0,0\n"

static void test_thermal_keys_exactly(void **state) {
    (void)state;
    assert_int_equal(open_meta(CAL "# cal_temp_c=24.985\n"
                                   "# temp_coeff_mm_per_c=0.0234675,-0.002228,-1,1\n"
                                   "# temp_coeff_sd_mm_per_c=0.001145,0,0.0000005,1\n"),
                     0);
    const struct trace_v1_cal *c = &reader.meta.cal;
    assert_true(c->calibrated);
    assert_true(c->thermal);
    assert_int_equal(c->cal_temp_cdeg, 2499); /* half away from zero */
    const int32_t k[4] = {23468, -2228, -1000000, 1000000};
    const uint32_t sd[4] = {1145, 0, 1, 1000000};
    for (unsigned i = 0; i < 4u; ++i) {
        assert_int_equal(c->temp_coeff_nm_per_c[i], k[i]);
        assert_int_equal(c->temp_coeff_sd_nm_per_c[i], sd[i]);
    }
    assert_int_equal(c->line[7], 5u); /* cal_temp_c's line, its bit's slot */
    assert_int_equal(open_meta(CAL "# cal_temp_c=-100\n# temp_coeff_mm_per_c=0,0,0,0\n"
                                   "# temp_coeff_sd_mm_per_c=0,0,0,0\n"),
                     0);
    assert_int_equal(reader.meta.cal.cal_temp_cdeg, -10000);
    assert_int_equal(open_meta(CAL), 0);
    assert_false(reader.meta.cal.thermal);
}

static void test_thermal_errors(void **state) {
    (void)state;
    const char *both = "# temp_coeff_mm_per_c=0,0,0,0\n# temp_coeff_sd_mm_per_c=0,0,0,0\n";
    char meta[512];
    /* "# cal_temp_c=" is 13 bytes: the value is at column 14 */
    snprintf(meta, sizeof meta, CAL "# cal_temp_c=200.01\n%s", both);
    expect_error(meta, 5u, 14u, "-100..200 C");
    snprintf(meta, sizeof meta, CAL "# cal_temp_c=-100.01\n%s", both);
    expect_error(meta, 5u, 14u, "-100..200 C");
    snprintf(meta, sizeof meta, CAL "# cal_temp_c=20,21\n%s", both);
    expect_error(meta, 5u, 16u, "one value");
    snprintf(meta, sizeof meta, CAL "# cal_temp_c=warm\n%s", both);
    expect_error(meta, 5u, 14u, "not a plain decimal");
    /* "# temp_coeff_mm_per_c=" is 22 bytes */
    expect_error(CAL "# cal_temp_c=20\n# temp_coeff_mm_per_c=0,1.000001,0,0\n"
                     "# temp_coeff_sd_mm_per_c=0,0,0,0\n",
                 6u, 25u, "-1..1 mm/C");
    expect_error(CAL "# cal_temp_c=20\n# temp_coeff_mm_per_c=0,0,0\n"
                     "# temp_coeff_sd_mm_per_c=0,0,0,0\n",
                 6u, 28u, "fewer than four");
    expect_error(CAL "# cal_temp_c=20\n# temp_coeff_mm_per_c=0,0,0,0\n"
                     "# temp_coeff_sd_mm_per_c=0,0,-0.001,0\n",
                 7u, 30u, "0..1 mm/C");
    /* all three or none, only with offsets, not with calibration=FILE */
    expect_error(CAL "# cal_temp_c=20\n# temp_coeff_mm_per_c=0,0,0,0\n", 5u, 1u, "come together");
    expect_error(CAL "# temp_coeff_sd_mm_per_c=0,0,0,0\n", 5u, 1u, "come together");
    expect_error("# cal_temp_c=20\n# temp_coeff_mm_per_c=0,0,0,0\n"
                 "# temp_coeff_sd_mm_per_c=0,0,0,0\n",
                 3u, 1u, "offset_mm and offset_sd_mm");
    expect_error("# calibration=h.cal\n# cal_temp_c=20\n", 3u, 1u, "give one");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_keys_is_uncalibrated),
        cmocka_unit_test(test_inline_keys_exactly),
        cmocka_unit_test(test_offsets_only_take_the_parts_gain_spread),
        cmocka_unit_test(test_a_file_is_named_not_read),
        cmocka_unit_test(test_bad_values_name_line_and_column),
        cmocka_unit_test(test_keys_come_as_a_whole),
        cmocka_unit_test(test_thermal_keys_exactly),
        cmocka_unit_test(test_thermal_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
