/* Trace v1 reader and writer (docs/reference/trace-format.md) and the range-source adapters. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "scene/rng.h"
#include "scene/row_source.h"
#include "scene/scenario.h"
#include "scene/trace.h"

static struct trace_reader reader; /* 66 KB: kept off the stack */

/* A FILE* holding exactly len bytes of text (tmpfile: standard C). */
static FILE *file_with(const char *text, size_t len) {
    FILE *f = tmpfile();
    assert_non_null(f);
    if (len > 0u) {
        assert_int_equal(fwrite(text, 1u, len, f), len);
    }
    rewind(f);
    return f;
}

/* Reads text as "t.csv" to its end; returns the number of rows, or -1 with
 * the reader's message left in reader.err. */
static long read_all(const char *text, size_t len) {
    FILE *f = file_with(text, len);
    long rows = 0;
    int rc = trace_reader_open(&reader, f, "t.csv");
    while (rc == 0) {
        struct scene_row row;
        const int got = trace_reader_next(&reader, &row);
        if (got == 1) {
            break;
        }
        if (got != 0) {
            rc = -1;
            break;
        }
        ++rows;
    }
    fclose(f);
    return rc == 0 ? rows : -1;
}

/* The text must be rejected with a message starting "t.csv:<where>: " and
 * containing what. */
static long read_all_mem(const char *text, size_t len) {
    long rows = 0;
    int rc = trace_reader_open_mem(&reader, text, len, "t.csv");
    while (rc == 0) {
        struct scene_row row;
        const int got = trace_reader_next(&reader, &row);
        if (got == 1) {
            break;
        }
        if (got != 0) {
            rc = -1;
            break;
        }
        ++rows;
    }
    return rc == 0 ? rows : -1;
}

/* Both the FILE and the memory reader must reject text with the same message. */
static void expect_error_n(const char *text, size_t len, const char *where, const char *what) {
    char prefix[64];
    snprintf(prefix, sizeof prefix, "t.csv:%s: ", where);
    for (int mem = 0; mem < 2; ++mem) {
        assert_int_equal(mem ? read_all_mem(text, len) : read_all(text, len), -1);
        const char *err = trace_reader_error(&reader);
        if (strncmp(err, prefix, strlen(prefix)) != 0 || strstr(err, what) == NULL) {
            fail_msg("%s reader: message '%s', want prefix '%s' and '%s'", mem ? "memory" : "FILE",
                     err, prefix, what);
        }
    }
}

static void expect_error(const char *text, const char *where, const char *what) {
    expect_error_n(text, strlen(text), where, what);
}

#define HEAD "# tof-trace v1\n# arm_mm=30\n"
#define COLS "t_ms,a_mm,b_mm,c_mm,d_mm\n"

static void test_happy_path(void **state) {
    (void)state;
    const char *text = "# tof-trace v1\n"
                       "# arm_mm=30.5\n"
                       "# period_ms=20\n"
                       "# note: a plain comment, not metadata\n"
                       "#  scenario = hand-made \n"
                       "d_mm, extra ,c_mm,t_ms,b_mm,a_mm,alpha_deg,b_st\n"
                       "100,zz,102,0,101,98,1.000,0\n"
                       "# a comment between rows\n"
                       "101,,103,20,99,97,,4\r\n"
                       "0,x,99,20,100,96,-2.5e-1,255\n"
                       "65535,-1,0,4294967295,0,65535,-90,0";
    FILE *f = file_with(text, strlen(text));
    assert_int_equal(trace_reader_open(&reader, f, "t.csv"), 0);
    assert_true(reader.meta.arm_mm == 30.5);
    assert_int_equal(reader.meta.period_ms, 20);
    assert_string_equal(trace_reader_meta(&reader, "scenario"), "hand-made");
    assert_null(trace_reader_meta(&reader, "note"));
    assert_int_equal(reader.meta.count, 3);
    struct scene_row row;
    assert_int_equal(trace_reader_next(&reader, &row), 0);
    assert_int_equal(row.t_ms, 0);
    assert_int_equal(row.range_mm[SCENE_A], 98);
    assert_int_equal(row.range_mm[SCENE_B], 101);
    assert_int_equal(row.range_mm[SCENE_C], 102);
    assert_int_equal(row.range_mm[SCENE_D], 100);
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        assert_int_equal(row.status[k], 0); /* absent *_st columns read as 0 */
        assert_true(row.present[k]);
    }
    assert_true(row.has_alpha && row.alpha_deg == 1.0);
    assert_false(row.has_beta); /* no beta_deg column */
    assert_int_equal(trace_reader_next(&reader, &row), 0);
    assert_int_equal(row.t_ms, 20);
    assert_int_equal(row.range_mm[SCENE_A], 97);
    assert_int_equal(row.status[SCENE_B], 4);
    assert_true(row.present[SCENE_B]);
    assert_false(row.has_alpha); /* empty truth */
    assert_int_equal(trace_reader_next(&reader, &row), 0);
    assert_int_equal(row.t_ms, 20);     /* equal time is non-decreasing */
    assert_false(row.present[SCENE_B]); /* status 255: no reading */
    assert_true(row.has_alpha && row.alpha_deg == -0.25);
    assert_int_equal(trace_reader_next(&reader, &row), 0); /* last line has no newline */
    assert_int_equal(row.t_ms, 4294967295u);
    assert_int_equal(row.range_mm[SCENE_A], 65535);
    assert_int_equal(row.range_mm[SCENE_C], 0);
    assert_true(row.alpha_deg == -90.0);
    assert_int_equal(trace_reader_next(&reader, &row), 1);
    assert_int_equal(trace_reader_next(&reader, &row), 1); /* stays ended */
    assert_int_equal(reader.rows, 4);
    fclose(f);
    assert_int_equal(read_all_mem(text, strlen(text)), 4);
}

static void test_empty_file(void **state) {
    (void)state;
    expect_error("", "1:1", "empty file");
}

static void test_wrong_version(void **state) {
    (void)state;
    expect_error("# tof-trace v2\n# arm_mm=30\n" COLS "0,1,2,3,4\n", "1:14",
                 "unsupported trace version 'v2'");
    expect_error("t_ms,a_mm,b_mm,c_mm,d_mm\n0,1,2,3,4\n", "1:1",
                 "the first line must be '# tof-trace v1'");
    expect_error("# tof-trace v1 \n# arm_mm=30\n" COLS "0,1,2,3,4\n", "1:14",
                 "unsupported trace version");
    /* A byte-order mark is skipped (test_real_logger_file); what follows it still counts. */
    expect_error("\xef\xbb\xbf# tof-trace v2\n", "1:14", "unsupported trace version 'v2'");
}

static void test_missing_arm(void **state) {
    (void)state;
    expect_error("# tof-trace v1\n# period_ms=20\n" COLS "0,1,2,3,4\n", "3:1",
                 "missing metadata arm_mm");
    expect_error("# tof-trace v1\n# arm_mm=abc\n" COLS "0,1,2,3,4\n", "2:10",
                 "arm_mm must be a positive number of millimetres, got 'abc'");
    expect_error("# tof-trace v1\n# arm_mm=\n" COLS "0,1,2,3,4\n", "2:10", "arm_mm must be");
    expect_error("# tof-trace v1\n# arm_mm=-3\n" COLS "0,1,2,3,4\n", "2:10", "arm_mm must be");
    /* Positive text whose value rounds to 0 µm (strtod underflows 3e-400 to 0.0). */
    expect_error("# tof-trace v1\n# arm_mm=3e-400\n" COLS "0,1,2,3,4\n", "2:10",
                 "arm_mm must be a positive number of millimetres, got '3e-400'");
    expect_error("# tof-trace v1\n# arm_mm=0.0004\n" COLS "0,1,2,3,4\n", "2:10",
                 "arm_mm must be a positive number of millimetres, got '0.0004'");
    expect_error("# tof-trace v1\n# arm_mm=30\n# arm_mm=31\n" COLS "0,1,2,3,4\n", "3:3",
                 "duplicate metadata key 'arm_mm'");
    expect_error(HEAD "# period_ms=0\n" COLS "0,1,2,3,4\n", "3:13", "period_ms must be");
}

static void test_missing_column(void **state) {
    (void)state;
    expect_error(HEAD "t_ms,a_mm,b_mm,d_mm\n0,1,2,3\n", "3:1",
                 "header lacks required column 'c_mm'");
    expect_error(HEAD "a_mm,b_mm,c_mm,d_mm\n1,2,3,4\n", "3:1",
                 "header lacks required column 't_ms'");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,a_mm\n", "3:26", "duplicate column 'a_mm'");
    expect_error(HEAD "t_ms,a_mm,,b_mm,c_mm,d_mm\n", "3:11", "empty column name");
    expect_error(HEAD, "3:1", "end of file before the header line");
}

static void test_short_row(void **state) {
    (void)state;
    expect_error(HEAD COLS "0,1,2,3\n", "4:8", "short row: 4 fields, the header has 5");
    expect_error(HEAD COLS "0,1,2,3,4\n20\n", "5:3", "short row: 1 fields");
}

static void test_long_row(void **state) {
    (void)state;
    expect_error(HEAD COLS "0,1,2,3,4,5\n", "4:11", "long row: more than the header's 5 fields");
    expect_error(HEAD COLS "0,1,2,3,4,\n", "4:11", "long row");
}

static void test_non_numeric(void **state) {
    (void)state;
    expect_error(HEAD COLS "0,1,x2,3,4\n", "4:5", "b_mm: expected an integer, got 'x2'");
    expect_error(HEAD COLS "0,1,2,3.5,4\n", "4:7", "c_mm: expected an integer, got '3.5'");
    expect_error(HEAD COLS "0x10,1,2,3,4\n", "4:1", "t_ms: expected an integer");
    expect_error(HEAD COLS "0,1,2,3,\n", "4:9", "d_mm: empty value");
    expect_error(HEAD COLS "0,1,2,3,1 2\n", "4:9", "d_mm: expected an integer, got '1 2'");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg\n0,1,2,3,4,nan\n", "4:11",
                 "alpha_deg: expected a number, got 'nan'");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,beta_deg\n0,1,2,3,4,1e\n", "4:11",
                 "beta_deg: expected a number");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,a_st\n0,1,2,3,4,ok\n", "4:11",
                 "a_st: expected an integer");
}

static void test_overflow(void **state) {
    (void)state;
    expect_error(HEAD COLS "0,65536,2,3,4\n", "4:3", "a_mm: '65536' out of range 0..65535");
    expect_error(HEAD COLS "4294967296,1,2,3,4\n", "4:1",
                 "t_ms: '4294967296' out of range 0..4294967295");
    expect_error(HEAD COLS "0,1,2,3,99999999999999999999999999\n", "4:9",
                 "d_mm: '99999999999999999999999999' out of range");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,c_st\n0,1,2,3,4,256\n", "4:11",
                 "c_st: '256' out of range 0..255");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg\n0,1,2,3,4,1e999\n", "4:11",
                 "alpha_deg: '1e999' out of range -90..90 degrees");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg\n0,1,2,3,4,90.5\n", "4:11",
                 "out of range -90..90");
}

static void test_negative_range(void **state) {
    (void)state;
    expect_error(HEAD COLS "0,-5,2,3,4\n", "4:3", "a_mm: negative range '-5'");
    expect_error(HEAD COLS "-20,1,2,3,4\n", "4:1", "t_ms: negative value '-20'");
    /* "-0" is zero, not negative */
    assert_int_equal(read_all(HEAD COLS "0,-0,2,3,4\n", strlen(HEAD COLS "0,-0,2,3,4\n")), 1);
}

static void test_time_backwards(void **state) {
    (void)state;
    expect_error(HEAD COLS "0,1,2,3,4\n20,1,2,3,4\n10,1,2,3,4\n", "6:1",
                 "t_ms 10 is earlier than the previous row's 20");
    expect_error(HEAD "a_mm,b_mm,t_ms,c_mm,d_mm\n1,2,5,3,4\n1,2,  4,3,4\n", "5:7",
                 "t_ms 4 is earlier");
}

static void test_nul_byte(void **state) {
    (void)state;
    static const char text[] = HEAD COLS "0,1,2\0,3,4\n";
    expect_error_n(text, sizeof text - 1u, "4:6", "NUL byte");
    static const char in_header[] = "# tof-trace v1\n# arm\0_mm=30\n";
    expect_error_n(in_header, sizeof in_header - 1u, "2:6", "NUL byte");
}

static void test_line_too_long(void **state) {
    (void)state;
    /* A 5000-byte row, and a 3 MB line with no newline at all: both end at
     * column 1025 without reading on or truncating. */
    const size_t big = 3u << 20;
    char *text = malloc(big + 64u);
    assert_non_null(text);
    const size_t head = strlen(HEAD COLS);
    memcpy(text, HEAD COLS, head);
    memset(text + head, '7', 5000u);
    memcpy(text + head + 5000u, "\n", 1u);
    expect_error_n(text, head + 5001u, "4:1025", "line longer than 1024 bytes");
    memset(text + head, '1', big);
    expect_error_n(text, head + big, "4:1025", "line longer than 1024 bytes");
    /* Exactly 1024 bytes is fine as a line length (then it is a syntax error
     * here, which proves it was read whole), also with a CRLF ending. */
    memcpy(text + head, "0,1,2,3,", 8u);
    memset(text + head + 8u, '9', 1016u);
    memcpy(text + head + 1024u, "\r\n", 2u);
    expect_error_n(text, head + 1026u, "4:9", "d_mm: '9999");
    memset(text + 14, 'x', 2000u); /* an over-long first line */
    expect_error_n(text, 2100u, "1:1025", "line longer than 1024 bytes");
    free(text);
}

static void test_no_samples(void **state) {
    (void)state;
    expect_error(HEAD COLS, "4:1", "no samples after the header (line 3)");
    expect_error(HEAD COLS "# only a comment\n", "5:1", "no samples");
    expect_error(HEAD COLS "\n", "5:1", "no samples after the header (line 3)");
    expect_error(HEAD COLS "0,1,2,3,4\n\n1,1,2,3,4\n", "5:1", "empty line (expected a sample row)");
    expect_error(HEAD COLS "0,1,2,3,4\n\n\n# late\n", "5:1", "empty line (expected a sample row)");
    expect_error(HEAD "\n" COLS, "3:1", "empty line where the header was expected");
}

/* What real loggers write: a byte-order mark, CRLF, a trailing empty line or two. */
static void test_real_logger_file(void **state) {
    (void)state;
    const char *text = "\xef\xbb\xbf# tof-trace v1\r\n# arm_mm=30\r\n" COLS "0,1,2,3,4\r\n"
                       "20,1,2,3,4\r\n\r\n\n";
    assert_int_equal(read_all(text, strlen(text)), 2);
    assert_true(reader.bom);
    assert_int_equal(read_all_mem(text, strlen(text)), 2);
    /* A BOM anywhere but at the very start is not skipped. */
    expect_error(HEAD "\xef\xbb\xbf" COLS "0,1,2,3,4\n", "3:1", "header lacks required column");
}

/* CR-only line endings are named as such, short files and long ones alike. */
static void test_cr_only_endings(void **state) {
    (void)state;
    expect_error("# tof-trace v1\r# arm_mm=30\r" COLS, "1:15", "CR-only line endings");
    expect_error(HEAD COLS "0,1,2\r3,4\n", "4:6", "CR-only line endings");
    /* A whole CR-only file is one "line" longer than the limit: still named as CR-only. */
    static char big[8192];
    size_t n = 0;
    n += (size_t)snprintf(big + n, sizeof big - n, "# tof-trace v1\r# arm_mm=30\r%.*s\r",
                          (int)strlen(COLS) - 1, COLS);
    while (n + 16u < sizeof big) {
        n += (size_t)snprintf(big + n, sizeof big - n, "%u,1,2,3,4\r", (unsigned)n);
    }
    expect_error_n(big, n, "1:15", "CR-only line endings");
    /* CRLF split across the reader's 64 KB blocks is an ordinary CRLF. */
    static char blocks[TRACE_IO_BLOCK + 4096u];
    n = (size_t)snprintf(blocks, sizeof blocks, "%s", HEAD COLS);
    unsigned t = 0;
    while (n < TRACE_IO_BLOCK + 1024u) {
        n += (size_t)snprintf(blocks + n, sizeof blocks - n, "%u,1,2,3,4\r\n", t++);
    }
    assert_int_equal(read_all(blocks, n), (long)t);
}

/* Repeated time stamps and jumps of more than two periods are noted with their line. */
static void test_timing_irregularities(void **state) {
    (void)state;
    const char *text =
        "# tof-trace v1\n# arm_mm=30\n# period_ms=10\n" COLS "0,1,2,3,4\n" /* line 5 */
        "10,1,2,3,4\n"                                                     /* 6 */
        "10,1,2,3,4\n"                                                     /* 7: repeat */
        "30,1,2,3,4\n"  /* 8: 20 ms = two periods, not a jump */
        "61,1,2,3,4\n"  /* 9: 31 ms, a jump */
        "161,1,2,3,4\n" /* 10: 100 ms, the largest jump */
        "171,1,2,3,4\n";
    assert_int_equal(read_all_mem(text, strlen(text)), 7);
    const struct trace_timing *tm = trace_reader_timing(&reader);
    assert_int_equal(tm->period_ms, 10);
    assert_true(tm->period_from_meta);
    assert_int_equal(tm->repeats, 1);
    assert_int_equal(tm->jumps, 2);
    assert_int_equal(tm->max_jump_ms, 100);
    assert_int_equal(tm->max_jump_line, 10);
    assert_int_equal(tm->note_count, 3);
    assert_int_equal(tm->notes[0].line, 7);
    assert_int_equal(tm->notes[0].kind, TRACE_TIME_REPEAT);
    assert_int_equal(tm->notes[1].line, 9);
    assert_int_equal(tm->notes[1].kind, TRACE_TIME_JUMP);
    assert_int_equal(tm->notes[1].prev_t_ms, 30);
    assert_int_equal(tm->notes[1].t_ms, 61);
    /* Without period_ms the default time base is used, and said to be the default. */
    const char *no_period = HEAD COLS "0,1,2,3,4\n40,1,2,3,4\n41,1,2,3,4\n";
    assert_int_equal(read_all_mem(no_period, strlen(no_period)), 3);
    tm = trace_reader_timing(&reader);
    assert_false(tm->period_from_meta);
    assert_int_equal(tm->period_ms, TRACE_DEFAULT_PERIOD_MS);
    assert_int_equal(tm->jumps, 0); /* 40 ms is two periods of 20 */
    assert_int_equal(tm->repeats, 0);
    /* More irregular rows than notes: all counted, the first ones kept. */
    static char many[4096];
    size_t n = (size_t)snprintf(many, sizeof many, "%s", HEAD COLS);
    for (unsigned i = 0; i < 40u; ++i) {
        n += (size_t)snprintf(many + n, sizeof many - n, "%u,1,2,3,4\n", (i / 2u) * 20u);
    }
    assert_int_equal(read_all_mem(many, n), 40);
    tm = trace_reader_timing(&reader);
    assert_int_equal(tm->repeats, 20);
    assert_int_equal(tm->note_count, TRACE_TIMING_NOTES);
    assert_int_equal(tm->notes[TRACE_TIMING_NOTES - 1u].line, 3u + 2u * TRACE_TIMING_NOTES);
    /* The metadata's lines are kept for messages about their values. */
    assert_int_equal(read_all_mem(text, strlen(text)), 7);
    assert_int_equal(trace_reader_meta_line(&reader, "period_ms"), 3);
    assert_int_equal(trace_reader_meta_line(&reader, "arm_mm"), 2);
    assert_int_equal(trace_reader_meta_line(&reader, "absent"), 0);
}

/* One row parser: blanks, signs, exponents, leading zeros and unused columns all go
 * through the same pass, and a row with the wrong field count says so first. */
static void test_one_row_parser(void **state) {
    (void)state;
    const char *text = HEAD "t_ms,a_mm,x,b_mm,c_mm,d_mm,alpha_deg,beta_deg\n"
                            " 007 ,+1,anything, 2,-0,0004,  1.5e0 ,-.25\n"
                            "8,1,,2,3,4,,\n";
    assert_int_equal(trace_reader_open_mem(&reader, text, strlen(text), "t.csv"), 0);
    struct scene_row row;
    assert_int_equal(trace_reader_next(&reader, &row), 0);
    assert_int_equal(row.t_ms, 7);
    assert_int_equal(row.range_mm[SCENE_A], 1);
    assert_int_equal(row.range_mm[SCENE_B], 2);
    assert_int_equal(row.range_mm[SCENE_C], 0);
    assert_int_equal(row.range_mm[SCENE_D], 4);
    assert_true(row.has_alpha && row.alpha_deg == 1.5);
    assert_true(row.has_beta && row.beta_deg == -0.25);
    assert_int_equal(trace_reader_next(&reader, &row), 0);
    assert_false(row.has_alpha || row.has_beta);
    assert_int_equal(trace_reader_next(&reader, &row), 1);
    /* Wrong field count wins over a bad value; the leftmost bad value is named. */
    expect_error(HEAD COLS "0,x,2\n", "4:6", "short row: 3 fields, the header has 5");
    expect_error(HEAD COLS "0,x,2,3,4,5\n", "4:11", "long row");
    expect_error(HEAD COLS "0,x,y,3,4\n", "4:3", "a_mm: expected an integer, got 'x'");
    expect_error(HEAD COLS "0,1 2,2,3,4\n", "4:3", "a_mm: expected an integer, got '1 2'");
    expect_error(HEAD COLS "0,+,2,3,4\n", "4:3", "a_mm: expected an integer, got '+'");
    expect_error(HEAD COLS "0,-5x,2,3,4\n", "4:3", "a_mm: expected an integer");
    expect_error(HEAD COLS "0,  ,2,3,4\n", "4:3", "a_mm: empty value");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg\n0,1,2,3,4,1e\n", "4:11",
                 "alpha_deg: expected a number, got '1e'");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg\n0,1,2,3,4,.\n", "4:11",
                 "alpha_deg: expected a number");
    expect_error(HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg\n0,1,2,3,4,90.0000001\n", "4:11",
                 "out of range -90..90 degrees");
    expect_error("# tof-trace v1\n# arm_mm=30,5\n" COLS "0,1,2,3,4\n", "2:10",
                 "arm_mm must be a positive number");
    expect_error("# tof-trace v1\n# arm_mm=30\n# period_ms=20,5\n" COLS "0,1,2,3,4\n", "3:13",
                 "period_ms must be an integer");
}

/* The reader's decimal fast path gives exactly strtod's double for truth
 * values in every notation the writer or a person might use. */
static void test_truth_values_match_strtod(void **state) {
    (void)state;

    const size_t n_rows = 4000u;
    char *text = malloc(n_rows * 64u + 128u);
    char(*values)[40] = malloc(n_rows * sizeof *values);
    assert_non_null(text);
    assert_non_null(values);
    size_t len = (size_t)sprintf(text, HEAD "t_ms,a_mm,b_mm,c_mm,d_mm,alpha_deg\n");
    struct scene_rng rng;
    scene_rng_seed(&rng, 99, 0);
    for (size_t i = 0; i < n_rows; ++i) {
        double v = scene_rng_range(&rng, -90.0, 90.0);
        if (i % 5u == 0u) {
            v = ldexp(v, -(int)scene_rng_below(&rng, 40)); /* small magnitudes */
        }
        switch (i % 8u) { /* literal formats, for -Wformat-nonliteral */
        case 0u:
            snprintf(values[i], sizeof values[i], "%.6f", v);
            break;
        case 1u:
            snprintf(values[i], sizeof values[i], "%.3f", v);
            break;
        case 2u:
            snprintf(values[i], sizeof values[i], "%.0f", v);
            break;
        case 3u:
            snprintf(values[i], sizeof values[i], "%.15g", v);
            break;
        case 4u:
            snprintf(values[i], sizeof values[i], "%.17g", v);
            break;
        case 5u:
            snprintf(values[i], sizeof values[i], "%.10e", v);
            break;
        case 6u:
            snprintf(values[i], sizeof values[i], "%.2E", v);
            break;
        default:
            snprintf(values[i], sizeof values[i], "%.16f", v);
            break;
        }
        len += (size_t)sprintf(text + len, "%zu,1,2,3,4,%s\n", i, values[i]);
    }
    assert_int_equal(trace_reader_open_mem(&reader, text, len, "v.csv"), 0);
    for (size_t i = 0; i < n_rows; ++i) {
        struct scene_row row;
        assert_int_equal(trace_reader_next(&reader, &row), 0);
        const double want = strtod(values[i], NULL);
        if (!(row.has_alpha && row.alpha_deg == want)) {
            fail_msg("'%s' read as %.17g, strtod gives %.17g", values[i], row.alpha_deg, want);
        }
    }
    free(text);
    free(values);
}

static void test_errors_are_sticky(void **state) {
    (void)state;
    const char *text = HEAD COLS "0,1,2,3,4\n0,x,2,3,4\n20,1,2,3,4\n";
    FILE *f = file_with(text, strlen(text));
    assert_int_equal(trace_reader_open(&reader, f, "t.csv"), 0);
    struct scene_row row;
    assert_int_equal(trace_reader_next(&reader, &row), 0);
    assert_int_equal(trace_reader_next(&reader, &row), -1);
    assert_int_equal(trace_reader_next(&reader, &row), -1);
    assert_non_null(strstr(trace_reader_error(&reader), "t.csv:5:3: a_mm"));
    fclose(f);
}

/* Generated rows (dropouts, flags, truth) survive writer → reader unchanged. */
static void test_round_trip(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("dropout", &cfg), 0);
    cfg.noise[1].flag_rate = 0.1;
    cfg.beta_random_deg = 3.0;
    struct scene_gen gen;
    char err[512];
    assert_int_equal(scene_gen_init(&gen, &cfg, 21, err, sizeof err), 0);
    FILE *f = tmpfile();
    assert_non_null(f);
    const char *const meta[] = {"scenario=dropout", "seed=21", NULL};
    assert_int_equal(trace_write_header(f, cfg.arm_mm, cfg.period_ms, meta), 0);
    struct scene_row *rows = calloc(10000u, sizeof *rows);
    assert_non_null(rows);
    size_t n = 0;
    while (scene_gen_next(&gen, &rows[n], NULL, err, sizeof err) == 0) {
        assert_int_equal(trace_write_row(f, &rows[n]), 0);
        ++n;
    }
    assert_int_equal(n, 10000);
    rewind(f);
    assert_int_equal(trace_reader_open(&reader, f, "rt.csv"), 0);
    assert_true(reader.meta.arm_mm == 30.0);
    assert_int_equal(reader.meta.period_ms, 20);
    assert_string_equal(trace_reader_meta(&reader, "seed"), "21");
    size_t absent = 0;
    size_t flagged = 0;
    for (size_t i = 0; i < n; ++i) {
        struct scene_row got;
        assert_int_equal(trace_reader_next(&reader, &got), 0);
        assert_int_equal(got.t_ms, rows[i].t_ms);
        assert_memory_equal(got.range_mm, rows[i].range_mm, sizeof got.range_mm);
        assert_memory_equal(got.status, rows[i].status, sizeof got.status);
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            assert_int_equal(got.present[k], rows[i].present[k]);
            absent += !got.present[k];
            flagged += got.present[k] && got.status[k] != 0u;
        }
        assert_true(got.has_alpha && got.has_beta);
        assert_true(fabs(got.alpha_deg - rows[i].alpha_deg) <= 5e-7);
        assert_true(fabs(got.beta_deg - rows[i].beta_deg) <= 5e-7);
    }
    struct scene_row end;
    assert_int_equal(trace_reader_next(&reader, &end), 1);
    assert_true(absent > 0u && flagged > 0u);
    fclose(f);
    free(rows);
    scene_gen_free(&gen);
}

static void test_writer_rejects_bad_input(void **state) {
    (void)state;
    FILE *f = tmpfile();
    assert_non_null(f);
    const char *const newline[] = {"note=a\nb", NULL};
    assert_int_equal(trace_write_header(f, 30.0, 20, newline), -1);
    const char *const dup[] = {"arm_mm=31", NULL};
    assert_int_equal(trace_write_header(f, 30.0, 20, dup), -1);
    assert_int_equal(trace_write_header(f, 0.0, 20, NULL), -1);
    struct scene_row row;
    memset(&row, 0, sizeof row);
    row.present[0] = row.present[1] = row.present[2] = row.present[3] = true;
    row.status[2] = SCENE_STATUS_NO_READING; /* would read back as absent */
    assert_int_equal(trace_write_row(f, &row), -1);
    row.status[2] = 0;
    row.has_alpha = true;
    row.alpha_deg = (double)NAN;
    assert_int_equal(trace_write_row(f, &row), -1);
    fclose(f);
}

static void test_load_file(void **state) {
    (void)state;
    const char *path = "scene_test_load.csv";
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs(HEAD COLS "0,1,2,3,4\n20,5,6,7,8\n40,9,10,11,12\n", f);
    fclose(f);
    struct scene_row *rows = NULL;
    size_t n = 0;
    struct trace_meta meta;
    char err[TRACE_ERR_MAX];
    assert_int_equal(trace_load_file(path, 10, &rows, &n, &meta, err, sizeof err), 0);
    assert_int_equal(n, 3);
    assert_int_equal(rows[2].range_mm[3], 12);
    assert_true(meta.arm_mm == 30.0);
    free(rows);
    assert_int_equal(trace_load_file(path, 2, &rows, &n, NULL, err, sizeof err), -1);
    assert_non_null(strstr(err, "scene_test_load.csv:6:1: more than 2 rows"));
    assert_null(rows);
    remove(path);
    assert_int_equal(trace_load_file(path, 2, &rows, &n, NULL, err, sizeof err), -1);
    assert_non_null(strstr(err, "cannot open"));
}

static void test_array_source(void **state) {
    (void)state;
    struct scene_row rows[3];
    memset(rows, 0, sizeof rows);
    for (unsigned i = 0; i < 3u; ++i) {
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            rows[i].range_mm[k] = (uint16_t)(100u * i + k);
            rows[i].present[k] = true;
        }
    }
    rows[1].present[2] = false;
    rows[1].status[2] = SCENE_STATUS_NO_READING;
    rows[2].status[0] = 4;
    struct scene_row_array arr = {rows, 3};
    const struct sim_range_source src = scene_row_array_source(&arr);
    struct sim_range r;
    assert_int_equal(src.ops->next(src.ctx, 3, 0, &r), 0);
    assert_int_equal(r.distance_mm, 3);
    assert_true(r.present);
    assert_int_equal(src.ops->next(src.ctx, 2, 1, &r), 0);
    assert_false(r.present);
    assert_int_equal(src.ops->next(src.ctx, 0, 2, &r), 0);
    assert_int_equal(r.range_status, 4);
    assert_int_equal(r.distance_mm, 200);
    assert_int_equal(src.ops->next(src.ctx, 0, 3, &r), 1);
    assert_int_equal(src.ops->next(src.ctx, 4, 0, &r), SCENE_SOURCE_ERR);
}

/* A scenario streamed through the ring gives exactly the generator's rows,
 * with the four sensors asking a few samples apart; a row that has left the
 * ring is an error, not a stale reading. */
static void test_stream_source_from_scenario(void **state) {
    (void)state;
    struct scene_config cfg;
    assert_int_equal(scene_config_named("dropout", &cfg), 0);
    cfg.n_positions = 2000u; /* 200,000 rows */
    static struct scene_gen gen_stream;
    static struct scene_gen gen_check;
    char err[256];
    assert_int_equal(scene_gen_init(&gen_stream, &cfg, 5, err, sizeof err), 0);
    assert_int_equal(scene_gen_init(&gen_check, &cfg, 5, err, sizeof err), 0);
    static struct scene_row_stream stream;
    scene_row_stream_init(&stream, scene_pull_scenario, &gen_stream);
    const struct sim_range_source src = scene_row_stream_source(&stream);
    static const uint32_t lag[SCENE_SENSORS] = {0, 3, 1, 7}; /* sensors out of step */
    const uint32_t total = 200000u;
    struct scene_row want[8];
    for (uint32_t i = 0; i < total + 7u; ++i) {
        if (i < total) {
            assert_int_equal(scene_gen_next(&gen_check, &want[i % 8u], NULL, err, sizeof err), 0);
        }
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            if (i < lag[k] || i - lag[k] >= total) {
                continue;
            }
            const uint32_t idx = i - lag[k];
            struct sim_range r;
            assert_int_equal(src.ops->next(src.ctx, k, idx, &r), 0);
            const struct scene_row *w = &want[idx % 8u];
            assert_int_equal(r.distance_mm, w->range_mm[k]);
            assert_int_equal(r.range_status, w->status[k]);
            assert_int_equal(r.present, w->present[k]);
        }
    }
    struct sim_range r;
    assert_int_equal(src.ops->next(src.ctx, 0, total, &r), 1);
    assert_int_equal(src.ops->next(src.ctx, 0, total - 1u, &r), 0);
    assert_int_equal(src.ops->next(src.ctx, 0, total - SCENE_STREAM_RING - 1u, &r),
                     SCENE_SOURCE_ERR);
    assert_non_null(strstr(scene_row_stream_error(&stream), "left the 256-row stream buffer"));
    scene_gen_free(&gen_stream);
    scene_gen_free(&gen_check);
}

/* A trace streamed through the ring; its bad row surfaces as a source error
 * at that sample index, with the reader's file:line:column message. */
static void test_stream_source_from_trace(void **state) {
    (void)state;
    char text[8192];
    size_t len = (size_t)snprintf(text, sizeof text, HEAD COLS);
    for (unsigned i = 0; i < 300u; ++i) {
        len += (size_t)snprintf(text + len, sizeof text - len, "%u,%u,%u,%u,%u\n", 20u * i, i,
                                i + 1u, i + 2u, i + 3u);
    }
    len += (size_t)snprintf(text + len, sizeof text - len, "6000,1,2,x,4\n");
    FILE *f = file_with(text, len);
    assert_int_equal(trace_reader_open(&reader, f, "s.csv"), 0);
    static struct scene_row_stream stream;
    scene_row_stream_init(&stream, scene_pull_trace, &reader);
    const struct sim_range_source src = scene_row_stream_source(&stream);
    for (uint32_t i = 0; i < 300u; ++i) {
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            struct sim_range r;
            assert_int_equal(src.ops->next(src.ctx, k, i, &r), 0);
            assert_int_equal(r.distance_mm, i + k);
        }
    }
    struct sim_range r;
    assert_int_equal(src.ops->next(src.ctx, 0, 300, &r), SCENE_SOURCE_ERR);
    if (strstr(trace_reader_error(&reader), "s.csv:304:10: c_mm: expected an integer") == NULL) {
        fail_msg("%s", trace_reader_error(&reader));
    }
    assert_int_equal(src.ops->next(src.ctx, 1, 300, &r), SCENE_SOURCE_ERR);
    fclose(f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_happy_path),
        cmocka_unit_test(test_empty_file),
        cmocka_unit_test(test_wrong_version),
        cmocka_unit_test(test_missing_arm),
        cmocka_unit_test(test_missing_column),
        cmocka_unit_test(test_short_row),
        cmocka_unit_test(test_long_row),
        cmocka_unit_test(test_non_numeric),
        cmocka_unit_test(test_overflow),
        cmocka_unit_test(test_negative_range),
        cmocka_unit_test(test_time_backwards),
        cmocka_unit_test(test_nul_byte),
        cmocka_unit_test(test_line_too_long),
        cmocka_unit_test(test_no_samples),
        cmocka_unit_test(test_real_logger_file),
        cmocka_unit_test(test_cr_only_endings),
        cmocka_unit_test(test_timing_irregularities),
        cmocka_unit_test(test_one_row_parser),
        cmocka_unit_test(test_truth_values_match_strtod),
        cmocka_unit_test(test_errors_are_sticky),
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_writer_rejects_bad_input),
        cmocka_unit_test(test_load_file),
        cmocka_unit_test(test_array_source),
        cmocka_unit_test(test_stream_source_from_scenario),
        cmocka_unit_test(test_stream_source_from_trace),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
