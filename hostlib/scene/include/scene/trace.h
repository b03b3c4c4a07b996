/*
 * Recorded trace format v1 (docs/reference/trace-format.md): host_sim's reader and the writer.
 *
 *   # tof-trace v1
 *   # arm_mm=30.0
 *   # period_ms=20
 *   t_ms,a_mm,b_mm,c_mm,d_mm,a_st,b_st,c_st,d_st,alpha_deg,beta_deg
 *   0,98,101,102,100,0,0,0,0,1.000,0.000
 *
 * The reader is the one trace v1 reader of trace/ (trace/trace_v1.h: integer C, every
 * target) with the host's parts around it: a FILE* or a memory buffer as its input, a
 * 64 KB block, the file name in front of its messages ("file:line:column: what") and its
 * fixed-point values as doubles (the same doubles strtod gives for the text). A status of
 * 255 (SCENE_STATUS_NO_READING) marks a sensor that gave no reading: the row then has
 * present[k] = false.
 */
#ifndef SCENE_TRACE_H
#define SCENE_TRACE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "scene/row.h"
#include "trace/trace_v1.h"

#define TRACE_ERR_MAX  1024u
#define TRACE_IO_BLOCK 65536u

/* The metadata with arm_mm as a double (what host_sim computes with). */
struct trace_meta {
    double arm_mm;      /* required: a, mm, finite and > 0 */
    uint32_t period_ms; /* optional, > 0; 0 when absent */
    unsigned count;     /* every key=value line, arm_mm and period_ms included */
    char key[TRACE_MAX_META][TRACE_KEY_MAX];
    char value[TRACE_MAX_META][TRACE_VALUE_MAX];
    uint32_t line[TRACE_MAX_META]; /* line of each key=value, for messages */
};

struct trace_reader {
    struct trace_v1_reader core; /* the reader proper */
    /* input: a FILE, or a memory buffer when file is NULL */
    FILE *file;
    const unsigned char *mem;
    size_t mem_len, mem_pos;
    char name[256]; /* for messages (truncated with "..." if longer) */
    unsigned char block[TRACE_IO_BLOCK];
    struct trace_meta meta;
    /* copies of the core's, kept current for the host's users */
    uint64_t rows;               /* rows returned so far */
    unsigned long last_row_line; /* line of the last row returned */
    bool bom;                    /* the file began with a UTF-8 byte-order mark (skipped) */
    char err[TRACE_ERR_MAX];
};

/*
 * Starts reading file (opened by the caller, binary mode; name is for
 * messages): checks the version line, reads the metadata and the header.
 * Returns 0, or -1 with "name:line:col: message" in trace_reader_error().
 */
int trace_reader_open(struct trace_reader *r, FILE *file, const char *name);

/* Like trace_reader_open, reading the len bytes at data (which must outlive
 * the reader) instead of a file. */
int trace_reader_open_mem(struct trace_reader *r, const void *data, size_t len, const char *name);

/*
 * Next sample. Returns 0 with *row filled, 1 after the last sample, or -1 with
 * the message in trace_reader_error(). After 1 or -1 it keeps returning that.
 * A file with no sample at all is an error ("no samples"), not an empty end.
 */
int trace_reader_next(struct trace_reader *r, struct scene_row *row);

/* Message of the last failure ("" if none). */
const char *trace_reader_error(const struct trace_reader *r);

/* Value of metadata key (NULL if absent). */
const char *trace_reader_meta(const struct trace_reader *r, const char *key);

/* Line of metadata key (0 if absent), for messages about its value. */
unsigned long trace_reader_meta_line(const struct trace_reader *r, const char *key);

/* The time base and the irregular time stamps seen so far (complete after the end). */
const struct trace_timing *trace_reader_timing(const struct trace_reader *r);

/*
 * Reads the whole file at path into a heap array (*rows, *count; release with
 * free()), at most max_rows rows (more is an error). meta may be NULL. Returns
 * 0 or -1 with the message in err.
 */
int trace_load_file(const char *path, size_t max_rows, struct scene_row **rows, size_t *count,
                    struct trace_meta *meta, char *err, size_t errlen);

/* ---- writer ---- */

/*
 * Writes the version line, "# arm_mm=", "# period_ms=" (if period_ms > 0), each
 * extra "key=value" string of extra_meta (NULL-terminated list, may be NULL)
 * and the full header. Returns 0, or -1 on a write error or a bad key/value.
 */
int trace_write_header(FILE *f, double arm_mm, uint32_t period_ms, const char *const *extra_meta);

/* trace_write_header with, when temp_column, the optional column temp_c after beta_deg. */
int trace_write_header_temp(FILE *f, double arm_mm, uint32_t period_ms,
                            const char *const *extra_meta, bool temp_column);

/* Writes one row: absent sensors as range 0, status 255; truth with 6
 * decimals, or empty fields if the row has none. Returns 0 or -1. */
int trace_write_row(FILE *f, const struct scene_row *row);

/* trace_write_row for a header written with temp_column: the row's temp_c with 2 decimals,
 * or an empty field without one (has_temp false). -1 also for a temperature outside
 * -100..200 °C (the reader's range), which is never clamped. */
int trace_write_row_temp(FILE *f, const struct scene_row *row, bool temp_column);

#endif /* SCENE_TRACE_H */
