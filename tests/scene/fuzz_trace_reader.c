/*
 * libFuzzer target for the trace v1 reader (hostlib/scene/src/trace.c): any
 * byte string must end in rows or in one well-formed error, never a crash, a
 * hang or an over-read (built with ASan/UBSan). Checked invariants:
 *   - an error reads "t.csv:<line>:<column>: <message>" with line, column ≥ 1;
 *   - accepted rows have non-decreasing t_ms and |truth| ≤ 90°, and absent
 *     sensors are exactly those with status 255;
 *   - the end and a failure are sticky;
 *   - the timing notes agree with the rows: every repeated t_ms and every step of
 *     more than two periods is counted, the first TRACE_TIMING_NOTES kept in order.
 * Run: see docs/reference/trace-format.md, "Fuzzing".
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "scene/trace.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static struct trace_reader reader;

static void check_error_format(const char *err) {
    const size_t n = strlen("t.csv:");
    if (strncmp(err, "t.csv:", n) != 0) {
        abort();
    }
    const char *p = err + n;
    for (int part = 0; part < 2; ++part) {
        if (*p < '1' || *p > '9') { /* 1-based, no leading zero */
            abort();
        }
        while (*p >= '0' && *p <= '9') {
            ++p;
        }
        if (*p++ != ':') {
            abort();
        }
    }
    if (p[0] != ' ' || p[1] == '\0') {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (trace_reader_open_mem(&reader, data, size, "t.csv") != 0) {
        check_error_format(trace_reader_error(&reader));
        return 0;
    }
    if (!(reader.meta.arm_mm > 0.0)) {
        abort();
    }
    uint32_t last_t = 0;
    uint64_t rows = 0;
    uint64_t repeats = 0, jumps = 0;
    const struct trace_timing *tm = trace_reader_timing(&reader);
    if (tm->period_ms == 0u || tm->period_from_meta != (reader.meta.period_ms != 0u)) {
        abort();
    }
    /* Bounded: every row consumes at least one input byte. */
    for (size_t guard = 0; guard <= size + 1u; ++guard) {
        struct scene_row row = {0};
        const int got = trace_reader_next(&reader, &row);
        if (got == 1) {
            if (rows == 0u || trace_reader_next(&reader, &row) != 1) {
                abort();
            }
            const uint64_t irregular = repeats + jumps;
            if (tm->repeats != repeats || tm->jumps != jumps ||
                tm->note_count !=
                    (irregular < TRACE_TIMING_NOTES ? irregular : TRACE_TIMING_NOTES)) {
                abort();
            }
            for (unsigned i = 1; i < tm->note_count; ++i) {
                if (tm->notes[i].line <= tm->notes[i - 1u].line) {
                    abort();
                }
            }
            return 0;
        }
        if (got != 0) {
            check_error_format(trace_reader_error(&reader));
            if (trace_reader_next(&reader, &row) != -1) {
                abort();
            }
            return 0;
        }
        if (rows > 0u && row.t_ms < last_t) {
            abort();
        }
        if (rows > 0u && row.t_ms == last_t) {
            ++repeats;
        } else if (rows > 0u && (uint64_t)row.t_ms - last_t > 2u * (uint64_t)tm->period_ms) {
            ++jumps;
        }
        if ((row.has_alpha && !(row.alpha_deg >= -90.0 && row.alpha_deg <= 90.0)) ||
            (row.has_beta && !(row.beta_deg >= -90.0 && row.beta_deg <= 90.0))) {
            abort();
        }
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            if (row.present[k] != (row.status[k] != SCENE_STATUS_NO_READING)) {
                abort();
            }
        }
        last_t = row.t_ms;
        ++rows;
    }
    abort(); /* more rows than bytes: the reader looped */
}
