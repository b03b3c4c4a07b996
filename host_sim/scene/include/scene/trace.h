/*
 * Recorded trace format v1 (DESIGN.md §5): reader and writer.
 *
 *   # tof-trace v1
 *   # arm_mm=30.0
 *   # period_ms=20
 *   t_ms,a_mm,b_mm,c_mm,d_mm,a_st,b_st,c_st,d_st,alpha_deg,beta_deg
 *   0,98,101,102,100,0,0,0,0,1.000,0.000
 *
 * The reader streams from a FILE* one row at a time with a bounded line buffer
 * and rejects, never repairs: every malformed input ends with an error message
 * "file:line:column: what" (grammar and rules in docs/traces.md). A status of
 * 255 (SCENE_STATUS_NO_READING) marks a sensor that gave no reading: the row
 * then has present[k] = false.
 */
#ifndef SCENE_TRACE_H
#define SCENE_TRACE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "scene/row.h"

#define TRACE_LINE_MAX    1024u /* bytes per line without the newline; longer is an error */
#define TRACE_MAX_COLUMNS 64u   /* header fields */
#define TRACE_MAX_META    32u   /* "# key=value" lines */
#define TRACE_KEY_MAX     32u   /* bytes of a key, including the terminator */
#define TRACE_VALUE_MAX   128u  /* bytes of a value, including the terminator */
#define TRACE_ERR_MAX     1024u
#define TRACE_IO_BLOCK    65536u
/* The time base when a trace has no period_ms: the scenarios' and the shared
 * recording's 20 ms (docs/traces.md). host_sim replay uses the same default. */
#define TRACE_DEFAULT_PERIOD_MS 20u
#define TRACE_TIMING_NOTES      8u /* irregular time stamps kept with their line */

/* Columns the reader knows, in trace_column order. */
enum trace_column {
    TRACE_COL_T_MS,
    TRACE_COL_A_MM,
    TRACE_COL_B_MM,
    TRACE_COL_C_MM,
    TRACE_COL_D_MM,
    TRACE_COL_A_ST,
    TRACE_COL_B_ST,
    TRACE_COL_C_ST,
    TRACE_COL_D_ST,
    TRACE_COL_ALPHA,
    TRACE_COL_BETA,
    TRACE_COL_COUNT
};

struct trace_meta {
    double arm_mm;      /* required: a, mm, finite and > 0 */
    uint32_t period_ms; /* optional, > 0; 0 when absent */
    unsigned count;     /* every key=value line, arm_mm and period_ms included */
    char key[TRACE_MAX_META][TRACE_KEY_MAX];
    char value[TRACE_MAX_META][TRACE_VALUE_MAX];
    unsigned long line[TRACE_MAX_META]; /* line of each key=value, for messages */
};

/* Irregular time stamps: t_ms equal to the previous row's, or more than two periods
 * after it. Not errors (real loggers skip and stall); the replay reports them. */
enum trace_timing_kind { TRACE_TIME_REPEAT = 1, TRACE_TIME_JUMP = 2 };

struct trace_timing_note {
    unsigned long line;
    uint32_t t_ms, prev_t_ms;
    uint8_t kind; /* enum trace_timing_kind */
};

struct trace_timing {
    uint32_t period_ms;    /* the time base checked against: period_ms, else the default */
    bool period_from_meta; /* false: TRACE_DEFAULT_PERIOD_MS, the trace has no period_ms */
    uint64_t repeats;      /* rows whose t_ms equals the previous row's */
    uint64_t jumps;        /* rows more than 2 * period_ms after the previous row */
    uint32_t max_jump_ms;  /* the largest such step, and its line */
    unsigned long max_jump_line;
    unsigned note_count; /* the first TRACE_TIMING_NOTES irregular rows, in line order */
    struct trace_timing_note notes[TRACE_TIMING_NOTES];
};

struct trace_reader {
    /* input: a FILE, or a memory buffer when file is NULL */
    FILE *file;
    const unsigned char *mem;
    size_t mem_len, mem_pos;
    char name[256]; /* for messages (truncated with "..." if longer) */
    unsigned char block[TRACE_IO_BLOCK];
    size_t block_len, block_pos;
    bool eof;
    /* current line */
    char line[TRACE_LINE_MAX + 1u];
    size_t line_len;
    unsigned long line_no;
    /* header */
    struct trace_meta meta;
    unsigned n_columns;                    /* fields in the header */
    int column_of[TRACE_COL_COUNT];        /* field index of each known column, -1 if absent */
    uint8_t column_use[TRACE_MAX_COLUMNS]; /* per field: its trace_column + 1, 0 if unknown */
    unsigned long header_line;
    /* rows */
    uint64_t rows; /* rows returned so far */
    uint32_t last_t_ms;
    unsigned long last_row_line; /* line of the last row returned */
    struct trace_timing timing;
    bool bom;                 /* the file began with a UTF-8 byte-order mark (skipped) */
    unsigned long empty_line; /* first empty line seen after the header; 0 = none */
    int state;                /* 0 reading, 1 ended, -1 failed */
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

/* Writes one row: absent sensors as range 0, status 255; truth with 6
 * decimals, or empty fields if the row has none. Returns 0 or -1. */
int trace_write_row(FILE *f, const struct scene_row *row);

#endif /* SCENE_TRACE_H */
