/* The trace v1 reader in its own integers (trace/trace_v1.h) and the distance-mode policy. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "trace/trace_v1.h"

static struct trace_v1_reader reader;

struct text_input {
    const char *text;
    size_t len, pos;
};

/* A read function that hands out at most 7 bytes a call, so lines cross blocks. */
static int32_t read_text(void *ctx, unsigned char *buf, uint32_t len) {
    struct text_input *in = ctx;
    size_t n = in->len - in->pos;
    n = n < len ? n : len;
    n = n < 7u ? n : 7u;
    memcpy(buf, in->text + in->pos, n);
    in->pos += n;
    return (int32_t)n;
}

static unsigned char block[16];
static struct text_input input;

static int open_text(const char *text) {
    input = (struct text_input){text, strlen(text), 0};
    return trace_v1_open(&reader, (struct trace_v1_input){read_text, &input}, block, sizeof block);
}

#define HEAD "# tof-trace v1\n# arm_mm=29.5\n# period_ms=50\n"

/* Truth in µdeg and µm, exact when the text has no finer digit; the offset of the text. */
static void test_fixed_point_truth(void **state) {
    (void)state;
    assert_int_equal(open_text(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,d_st,alpha_deg,beta_deg,distance_mm\n"
                                    "0,1,2,3,0,255,-1.250000,2.5e-1,100.125\n"
                                    "20,1,2,3,4,0,0.1234567,-0,\n"),
                     0);
    assert_int_equal(reader.meta.arm_um, 29500);
    assert_true(reader.meta.arm_exact);
    assert_int_equal(reader.meta.period_ms, 50);
    struct trace_v1_row row;
    assert_int_equal(trace_v1_next(&reader, &row), 0);
    assert_true(row.has[TRACE_TRUTH_ALPHA] && row.exact[TRACE_TRUTH_ALPHA]);
    assert_int_equal(row.truth[TRACE_TRUTH_ALPHA], -1250000);
    assert_int_equal(row.truth[TRACE_TRUTH_BETA], 250000);
    assert_int_equal(row.truth[TRACE_TRUTH_DISTANCE], 100125);
    assert_true(row.exact[TRACE_TRUTH_DISTANCE]);
    assert_false(row.present[3]);
    assert_int_equal(trace_v1_next(&reader, &row), 0);
    assert_false(row.exact[TRACE_TRUTH_ALPHA]); /* a seventh decimal */
    assert_int_equal(row.truth[TRACE_TRUTH_ALPHA], 123457);
    assert_string_equal(reader.line + row.truth_at[TRACE_TRUTH_ALPHA], "0.1234567,-0,");
    assert_false(row.exact[TRACE_TRUTH_BETA]); /* "-0": the sign is the text's */
    assert_int_equal(row.truth[TRACE_TRUTH_BETA], 0);
    assert_false(row.has[TRACE_TRUTH_DISTANCE]);
    assert_int_equal(trace_v1_next(&reader, &row), 1);
}

static void expect_failure(const char *text, uint32_t line, uint32_t col, const char *what) {
    int rc = open_text(text);
    struct trace_v1_row row;
    while (rc == 0) {
        rc = trace_v1_next(&reader, &row);
    }
    assert_int_equal(rc, -1);
    assert_int_equal(reader.err.line, line);
    assert_int_equal(reader.err.col, col);
    if (strstr(reader.err.msg, what) == NULL) {
        fail_msg("message '%s', want '%s'", reader.err.msg, what);
    }
}

/* temp_c in 0.01 °C, rounded half away from zero; empty is no temperature; a value beyond
 * −100..200 °C or not a number is an error at its line and column. A readings-only pass
 * still reads it (the unit measures it with its readings). */
static void test_temperature_column(void **state) {
    (void)state;
    assert_int_equal(open_text(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,temp_c\n"
                                    "0,1,2,3,4,23.456\n"
                                    "20,1,2,3,4,\n"
                                    "40,1,2,3,4,-20.005\n"
                                    "60,1,2,3,4,200\n"),
                     0);
    trace_v1_readings_only(&reader);
    struct trace_v1_row row;
    assert_int_equal(trace_v1_next(&reader, &row), 0);
    assert_true(row.temp_present);
    assert_int_equal(row.temp_cdeg, 2346);
    assert_int_equal(trace_v1_next(&reader, &row), 0);
    assert_false(row.temp_present);
    assert_int_equal(trace_v1_next(&reader, &row), 0);
    assert_true(row.temp_present);
    assert_int_equal(row.temp_cdeg, -2001);
    assert_int_equal(trace_v1_next(&reader, &row), 0);
    assert_int_equal(row.temp_cdeg, 20000);
    assert_int_equal(trace_v1_next(&reader, &row), 1);
    expect_failure(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,temp_c\n0,1,2,3,4,200.01\n", 5, 11,
                   "temp_c: '200.01' out of range -100..200 degrees C");
    expect_failure(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,temp_c\n0,1,2,3,4,-100.5\n", 5, 11,
                   "out of range -100..200");
    expect_failure(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,temp_c\n0,1,2,3,4,warm\n", 5, 11,
                   "temp_c: expected a number, got 'warm'");
}

/* A readings-only pass (host_sim's distance-mode evidence) skips the truth unread: the same
 * ranges, statuses and presence, no truth, and a truth value it skipped is no error there. */
static void test_readings_only(void **state) {
    (void)state;
    assert_int_equal(open_text(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,d_st,alpha_deg,beta_deg,distance_mm\n"
                                    "0,1,2,3,0,255,-1.250000,2.5e-1,100.125\n"
                                    "20,1,2,3,4,0,not-a-number,-0,\n"),
                     0);
    trace_v1_readings_only(&reader);
    struct trace_v1_row row;
    assert_int_equal(trace_v1_next(&reader, &row), 0);
    assert_false(row.has[TRACE_TRUTH_ALPHA] || row.has[TRACE_TRUTH_BETA] ||
                 row.has[TRACE_TRUTH_DISTANCE]);
    assert_int_equal(row.range_mm[2], 3);
    assert_false(row.present[3]);
    assert_int_equal(trace_v1_next(&reader, &row), 0);
    assert_true(row.present[3]);
    assert_int_equal(row.range_mm[3], 4);
    assert_int_equal(trace_v1_next(&reader, &row), 1);
}

static void test_errors_without_a_file_name(void **state) {
    (void)state;
    expect_failure(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,distance_mm\n0,1,2,3,4,-5\n", 5, 11,
                   "distance_mm: '-5' out of range 0..65535 mm");
    expect_failure(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,distance_mm\n0,1,2,3,4,x\n", 5, 11,
                   "distance_mm: expected a number, got 'x'");
    expect_failure(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg\n0,1,2,3,4,-90.0000001\n", 5, 11,
                   "out of range -90..90 degrees");
    expect_failure("# tof-trace v1\n# arm_mm=1e15\nt_ms,a_mm,b_mm,c_mm,d_mm\n", 2, 10,
                   "arm_mm must be a positive number");
    expect_failure(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm\n0,1,2,3,4\n0,1,2,3,4,5\n", 6, 11,
                   "long row: more than the header's 5 fields");
}

/* A value finer than a micrometre is kept, flagged: a host converts its text. */
static void test_arm_finer_than_a_micrometre(void **state) {
    (void)state;
    assert_int_equal(open_text("# tof-trace v1\n# arm_mm=30.0004\nt_ms,a_mm,b_mm,c_mm,d_mm\n"
                               "0,1,2,3,4\n"),
                     0);
    assert_int_equal(reader.meta.arm_um, 30000);
    assert_false(reader.meta.arm_exact);
}

static void test_distance_mode_policy(void **state) {
    (void)state;
    struct trace_mode_evidence ev = {.short_max_mm = 1360, .long_max_mm = 4000};
    struct trace_v1_row row = {.range_mm = {1360, 4001, 1361, 2000},
                               .present = {true, true, true, false}};
    trace_mode_evidence_add(&ev, &row, 7);
    assert_int_equal(ev.count, 1); /* 1360 is short's, 4001 nobody's, D absent */
    assert_int_equal(ev.first_line, 7);
    assert_int_equal(ev.first_sensor, 2);
    struct trace_mode_choice c =
        trace_mode_choose(TRACE_MODE_UNSTATED, TRACE_MODE_UNSTATED, &ev, true);
    assert_int_equal(c.mode, TRACE_MODE_LONG);
    assert_int_equal(c.why, TRACE_MODE_BY_READINGS);
    c = trace_mode_choose(TRACE_MODE_UNSTATED, TRACE_MODE_UNSTATED, &ev, false);
    assert_int_equal(c.mode, TRACE_MODE_SHORT);
    assert_int_equal(c.why, TRACE_MODE_NO_BUDGET);
    c = trace_mode_choose(TRACE_MODE_UNSTATED, TRACE_MODE_SHORT, &ev, true);
    assert_int_equal(c.mode, TRACE_MODE_SHORT);
    assert_int_equal(c.why, TRACE_MODE_BY_TRACE);
    c = trace_mode_choose(TRACE_MODE_LONG, TRACE_MODE_SHORT, NULL, false);
    assert_int_equal(c.mode, TRACE_MODE_LONG);
    assert_int_equal(c.why, TRACE_MODE_BY_OPTION);
    c = trace_mode_choose(TRACE_MODE_UNSTATED, TRACE_MODE_UNSTATED, NULL, true);
    assert_int_equal(c.mode, TRACE_MODE_SHORT);
    assert_int_equal(c.why, TRACE_MODE_NOT_READ_AHEAD);
    ev.count = 0;
    c = trace_mode_choose(TRACE_MODE_UNSTATED, TRACE_MODE_UNSTATED, &ev, true);
    assert_int_equal(c.why, TRACE_MODE_NO_EVIDENCE);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fixed_point_truth),
        cmocka_unit_test(test_readings_only),
        cmocka_unit_test(test_temperature_column),
        cmocka_unit_test(test_errors_without_a_file_name),
        cmocka_unit_test(test_arm_finer_than_a_micrometre),
        cmocka_unit_test(test_distance_mode_policy),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
