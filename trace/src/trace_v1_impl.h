/*
 * The trace v1 reader's own parts (not for its users): the message builder
 * (trace_v1_msg.c, the bottom), the field scanners and the row parser (trace_v1_row.c),
 * both called by the reader proper (trace_v1.c) and never calling it.
 */
#ifndef SIM_TRACE_V1_IMPL_H
#define SIM_TRACE_V1_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include "trace/trace_v1.h"

/* ---- messages (trace_v1_msg.c) ---- */

/* A message being built into r->err.msg; always NUL-terminated, cut at its end. */
struct trace_msg {
    char *s;
    uint32_t len, cap;
};

/* Starts the failure at line, col: clears r->err.msg and sets its place. */
struct trace_msg trace_msg_begin(struct trace_v1_reader *r, uint32_t line, uint32_t col);
void trace_msg_str(struct trace_msg *m, const char *s);
void trace_msg_u64(struct trace_msg *m, uint64_t v);
/* A bounded, printable quote of untrusted text: 40 bytes at most, then "..."; bytes
 * outside printable ASCII as '?'. */
void trace_msg_quote(struct trace_msg *m, const char *s, size_t len);
/* Fails the reader. Returns -1. */
int trace_msg_fail(struct trace_v1_reader *r);

/* The whole message what at line, col. Returns -1. */
int trace_v1_fail(struct trace_v1_reader *r, uint32_t line, uint32_t col, const char *what);
/* before + 'quote of s[0..len)' + after at line, col. Returns -1. */
int trace_v1_fail_q(struct trace_v1_reader *r, uint32_t line, uint32_t col, const char *before,
                    const char *s, size_t len, const char *after);

/* ---- fields and rows (trace_v1_row.c) ---- */

extern const char *const trace_v1_column_names[TRACE_COL_COUNT];

/* A field of a line: s after leading blanks, len without trailing blanks, col the 1-based
 * column of s (of the field start if it is blank). */
struct trace_field {
    const char *s;
    size_t len;
    size_t col;
};

struct trace_field trace_v1_make_field(const char *line, size_t start, size_t end);

/* A whole metadata value as one unsigned integer in 1..max: 0, or -1 (not one). */
int trace_v1_meta_uint(const struct trace_field *f, uint64_t max, uint64_t *out);

/* A whole metadata value as a positive decimal in units of 10^-decimals: 0 with *units
 * (saturated at INT32_MAX) and *exact, or -1 (not a positive number, or one that rounds
 * to 0 units). */
int trace_v1_meta_positive(const struct trace_field *f, unsigned decimals, int32_t *units,
                           bool *exact);

/* One decimal of a comma-separated list at *pp (blanks around it allowed) in units of
 * 10^-decimals, rounded half away from zero: 0 with *units and *pp at its ',' or the end, or
 * -1 (not a plain decimal, or beyond ±max_units). */
int trace_v1_list_decimal(const char **pp, unsigned decimals, int64_t max_units, int64_t *units);

/* ---- the head's calibration keys (trace_v1_cal.c) ---- */

/* Reads key=val into r->meta.cal when key is one of the calibration keys
 * (docs/reference/trace-format.md). 0 (read, or not such a key), or -1 failed (line and column of
 * the value). */
int trace_v1_cal_key(struct trace_v1_reader *r, const char *key, const struct trace_field *val);

/* After the last metadata line: the keys come as a whole (offsets with their sd, gains with
 * theirs, inline keys or a file or none). 0, or -1 failed. */
int trace_v1_cal_finish(struct trace_v1_reader *r);

/* Parses r->line as the next row (checks, timing notes, counters). 0, or -1 failed. */
int trace_v1_parse_row(struct trace_v1_reader *r, struct trace_v1_row *row);

#endif /* SIM_TRACE_V1_IMPL_H */
