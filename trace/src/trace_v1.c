/* Trace format v1 reader: lines, metadata, header and the row stream (trace/trace_v1.h). */
#include "trace/trace_v1.h"

#include <string.h>

#include "trace_v1_impl.h"

/* ---- lines ---- */

static int cr_only(struct trace_v1_reader *r, uint32_t line, uint32_t col) {
    return trace_v1_fail(r, line, col,
                         "CR-only line endings (a carriage return inside a line, as old Mac "
                         "files end lines): lines must end in LF or CRLF");
}

static int too_long(struct trace_v1_reader *r, uint32_t line) {
    struct trace_msg m = trace_msg_begin(r, line, TRACE_LINE_MAX + 1u);
    trace_msg_str(&m, "line longer than ");
    trace_msg_u64(&m, TRACE_LINE_MAX);
    trace_msg_str(&m, " bytes");
    return trace_msg_fail(r);
}

/* Refills the block. 1 with bytes, 0 at the end of the input, -1 on a read error. */
static int refill(struct trace_v1_reader *r) {
    const int32_t n = r->in.read(r->in.ctx, r->block, r->block_size);
    r->block_pos = 0;
    r->block_len = n > 0 ? (uint32_t)n : 0u;
    if (n > 0) {
        return 1;
    }
    r->eof = true;
    return n < 0 ? trace_v1_fail(r, r->line_no + 1u, 1u, "read error") : 0;
}

/* A segment that does not fit the line, or holds a NUL: which error it is. */
static int line_overflow(struct trace_v1_reader *r, const unsigned char *seg, size_t seg_len,
                         const unsigned char *nul) {
    if (nul != NULL && r->line_len + (size_t)(nul - seg) < TRACE_LINE_MAX) {
        return trace_v1_fail(r, r->line_no + 1u, r->line_len + (uint32_t)(nul - seg) + 1u,
                             "NUL byte");
    }
    /* A file with CR-only endings reads as one long line: say so, not "too long". */
    const size_t in_line = r->line_len < TRACE_LINE_MAX ? r->line_len : TRACE_LINE_MAX;
    const size_t in_seg = TRACE_LINE_MAX - in_line < seg_len ? TRACE_LINE_MAX - in_line : seg_len;
    const char *cr = memchr(r->line, '\r', in_line);
    const unsigned char *cr_seg = cr == NULL ? memchr(seg, '\r', in_seg) : NULL;
    if (cr != NULL || cr_seg != NULL) {
        const size_t at =
            cr != NULL ? (size_t)(cr - r->line) : r->line_len + (size_t)(cr_seg - seg);
        return cr_only(r, r->line_no + 1u, (uint32_t)at + 1u);
    }
    return too_long(r, r->line_no + 1u);
}

/* Reads the next line into r->line. Returns 1 with a line, 0 at the end of the input,
 * -1 (failed) on a NUL byte, an over-long line or a read error. Bounded: each turn
 * consumes a block or ends the line, and a line holds at most TRACE_LINE_MAX + 1 bytes. */
static int next_line(struct trace_v1_reader *r) {
    r->line_len = 0;
    bool any = false;
    for (;;) {
        if (r->block_pos == r->block_len) {
            const int got = r->eof ? 0 : refill(r);
            if (got < 0) {
                return -1;
            }
            if (got == 0) {
                break;
            }
        }
        /* The rest of this line inside the current block, found with memchr. */
        const unsigned char *seg = r->block + r->block_pos;
        const size_t avail = r->block_len - r->block_pos;
        const unsigned char *nl = memchr(seg, '\n', avail);
        const size_t seg_len = nl != NULL ? (size_t)(nl - seg) : avail;
        any = true;
        const unsigned char *nul = memchr(seg, '\0', seg_len);
        /* Room for TRACE_LINE_MAX bytes plus the '\r' of a CRLF ending (checked below). */
        if (nul != NULL || r->line_len + seg_len > TRACE_LINE_MAX + 1u) {
            return line_overflow(r, seg, seg_len, nul);
        }
        memcpy(r->line + r->line_len, seg, seg_len);
        r->line_len += (uint32_t)seg_len;
        r->block_pos += (uint32_t)seg_len;
        if (nl != NULL) {
            r->block_pos++; /* the newline */
            break;
        }
    }
    if (!any) {
        return 0;
    }
    r->line_no++;
    if (r->line_len > 0u && r->line[r->line_len - 1u] == '\r') {
        r->line_len--;
    }
    if (r->line_len > TRACE_LINE_MAX) { /* byte 1025 was not the '\r' of a CRLF ending */
        return too_long(r, r->line_no);
    }
    r->line[r->line_len] = '\0';
    /* Before the header, a CR inside a line is named here; in rows, only when the row
     * fails (trace_v1_next), which keeps the search off the hot path. */
    if (r->header_line == 0u) {
        const char *cr = memchr(r->line, '\r', r->line_len);
        if (cr != NULL) {
            return cr_only(r, r->line_no, (uint32_t)(cr - r->line) + 1u);
        }
    }
    return 1;
}

/* ---- header part ---- */

static bool is_blank(char c) {
    return c == ' ' || c == '\t';
}

bool trace_v1_key_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
}

/* arm_mm and period_ms, the keys the reader itself reads. 0, or -1 (failed). */
static int read_known_key(struct trace_v1_reader *r, const char *key,
                          const struct trace_field *val) {
    if (strcmp(key, "arm_mm") == 0) {
        if (trace_v1_meta_positive(val, 3u, &r->meta.arm_um, &r->meta.arm_exact) != 0) {
            return trace_v1_fail_q(r, r->line_no, (uint32_t)val->col,
                                   "arm_mm must be a positive number of millimetres, got '", val->s,
                                   val->len, "'");
        }
    } else if (strcmp(key, "period_ms") == 0) {
        uint64_t v = 0;
        if (trace_v1_meta_uint(val, UINT32_MAX, &v) != 0) {
            return trace_v1_fail_q(r, r->line_no, (uint32_t)val->col,
                                   "period_ms must be an integer in 1..4294967295, got '", val->s,
                                   val->len, "'");
        }
        r->meta.period_ms = (uint32_t)v;
    }
    return 0;
}

/* Checks and keeps key (key_len bytes at key_start) = val. 0, or -1 (failed). */
static int keep_meta(struct trace_v1_reader *r, size_t key_start, size_t key_len,
                     const struct trace_field *val) {
    const char *line = r->line;
    if (key_len >= TRACE_KEY_MAX) {
        struct trace_msg m = trace_msg_begin(r, r->line_no, (uint32_t)key_start + 1u);
        trace_msg_str(&m, "metadata key '");
        trace_msg_quote(&m, line + key_start, key_len);
        trace_msg_str(&m, "' longer than ");
        trace_msg_u64(&m, TRACE_KEY_MAX - 1u);
        trace_msg_str(&m, " bytes");
        return trace_msg_fail(r);
    }
    if (val->len >= TRACE_VALUE_MAX) {
        struct trace_msg m = trace_msg_begin(r, r->line_no, (uint32_t)val->col);
        trace_msg_str(&m, "metadata value longer than ");
        trace_msg_u64(&m, TRACE_VALUE_MAX - 1u);
        trace_msg_str(&m, " bytes");
        return trace_msg_fail(r);
    }
    char key[TRACE_KEY_MAX];
    memcpy(key, line + key_start, key_len);
    key[key_len] = '\0';
    if (trace_v1_meta(r, key) != NULL) {
        return trace_v1_fail_q(r, r->line_no, (uint32_t)key_start + 1u, "duplicate metadata key '",
                               key, key_len, "'");
    }
    if (r->meta.count >= TRACE_MAX_META) {
        struct trace_msg m = trace_msg_begin(r, r->line_no, (uint32_t)key_start + 1u);
        trace_msg_str(&m, "more than ");
        trace_msg_u64(&m, TRACE_MAX_META);
        trace_msg_str(&m, " metadata keys");
        return trace_msg_fail(r);
    }
    if (read_known_key(r, key, val) != 0 || trace_v1_cal_key(r, key, val) != 0) {
        return -1;
    }
    const unsigned i = r->meta.count++;
    r->meta.line[i] = r->line_no;
    memcpy(r->meta.key[i], key, key_len + 1u);
    memcpy(r->meta.value[i], val->s, val->len);
    r->meta.value[i][val->len] = '\0';
    return 0;
}

/* A line starting with '#' before the header: "# key=value" metadata or a comment. */
static int read_meta_line(struct trace_v1_reader *r) {
    const char *line = r->line;
    size_t i = 1;
    while (i < r->line_len && is_blank(line[i])) {
        ++i;
    }
    const size_t key_start = i;
    while (i < r->line_len && trace_v1_key_char(line[i])) {
        ++i;
    }
    const size_t key_len = i - key_start;
    while (i < r->line_len && is_blank(line[i])) {
        ++i;
    }
    if (key_len == 0u || i >= r->line_len || line[i] != '=') {
        return 0; /* a plain comment */
    }
    const struct trace_field val = trace_v1_make_field(line, i + 1u, r->line_len);
    return keep_meta(r, key_start, key_len, &val);
}

/* The header's fields: each known column's index. 0, or -1 (failed). */
static int read_columns(struct trace_v1_reader *r) {
    unsigned n = 0;
    size_t start = 0;
    for (size_t i = 0; i <= r->line_len; ++i) {
        if (i < r->line_len && r->line[i] != ',') {
            continue;
        }
        const struct trace_field f = trace_v1_make_field(r->line, start, i);
        if (n >= TRACE_MAX_COLUMNS) {
            struct trace_msg m = trace_msg_begin(r, r->line_no, (uint32_t)f.col);
            trace_msg_str(&m, "more than ");
            trace_msg_u64(&m, TRACE_MAX_COLUMNS);
            trace_msg_str(&m, " columns in the header");
            return trace_msg_fail(r);
        }
        if (f.len == 0u) {
            return trace_v1_fail(r, r->line_no, (uint32_t)f.col, "empty column name in the header");
        }
        for (unsigned c = 0; c < TRACE_COL_COUNT; ++c) {
            const char *name = trace_v1_column_names[c];
            if (strlen(name) == f.len && memcmp(name, f.s, f.len) == 0) {
                if (r->column_of[c] >= 0) {
                    return trace_v1_fail_q(r, r->line_no, (uint32_t)f.col, "duplicate column '",
                                           name, f.len, "'");
                }
                r->column_of[c] = (int8_t)n;
            }
        }
        ++n;
        start = i + 1u;
    }
    r->n_columns = n;
    return 0;
}

static int read_header_line(struct trace_v1_reader *r) {
    if (trace_v1_meta(r, "arm_mm") == NULL) {
        return trace_v1_fail(r, r->line_no, 1u,
                             "missing metadata arm_mm (a line '# arm_mm=<mm>' must come before "
                             "the header)");
    }
    r->header_line = r->line_no;
    if (read_columns(r) != 0) {
        return -1;
    }
    /* t_ms and the four ranges are required; statuses and truth are optional. */
    for (unsigned c = TRACE_COL_T_MS; c <= TRACE_COL_D_MM; ++c) {
        if (r->column_of[c] < 0) {
            return trace_v1_fail_q(r, r->line_no, 1u, "header lacks required column '",
                                   trace_v1_column_names[c], strlen(trace_v1_column_names[c]), "'");
        }
    }
    r->timing.period_from_meta = r->meta.period_ms > 0u;
    r->timing.period_ms = r->timing.period_from_meta ? r->meta.period_ms : TRACE_DEFAULT_PERIOD_MS;
    memset(r->column_use, 0, sizeof r->column_use);
    for (unsigned c = 0; c < TRACE_COL_COUNT; ++c) {
        if (r->column_of[c] >= 0) {
            r->column_use[r->column_of[c]] = (uint8_t)(c + 1u);
        }
    }
    return 0;
}

/* The first line: "# tof-trace v1", after a UTF-8 byte-order mark if there is one. */
static int read_version(struct trace_v1_reader *r) {
    const int got = next_line(r);
    if (got < 0) {
        return -1;
    }
    if (got == 0) {
        return trace_v1_fail(r, 1u, 1u, "empty file (the first line must be '# tof-trace v1')");
    }
    /* A UTF-8 byte-order mark, as Windows editors and loggers write, is not text. */
    if (r->line_len >= 3u && memcmp(r->line, "\xEF\xBB\xBF", 3u) == 0) {
        r->line_len -= 3u;
        memmove(r->line, r->line + 3u, r->line_len + 1u);
        r->bom = true;
    }
    static const char version_prefix[] = "# tof-trace v";
    const size_t prefix_len = sizeof version_prefix - 1u;
    if (strcmp(r->line, "# tof-trace v1") == 0) {
        return 0;
    }
    if (r->line_len > prefix_len && memcmp(r->line, version_prefix, prefix_len) == 0) {
        return trace_v1_fail_q(r, 1u, (uint32_t)prefix_len + 1u, "unsupported trace version 'v",
                               r->line + prefix_len, r->line_len - prefix_len,
                               "' (this reader reads v1)");
    }
    return trace_v1_fail_q(r, 1u, 1u, "the first line must be '# tof-trace v1', got '", r->line,
                           r->line_len, "'");
}

int trace_v1_open(struct trace_v1_reader *r, struct trace_v1_input in, unsigned char *block,
                  uint32_t block_size) {
    memset(r, 0, sizeof *r);
    r->in = in;
    r->block = block;
    r->block_size = block_size;
    for (unsigned c = 0; c < TRACE_COL_COUNT; ++c) {
        r->column_of[c] = -1;
    }
    if (read_version(r) != 0) {
        return -1;
    }
    /* Bounded: each turn reads a line, and the input ends or fails. */
    for (;;) {
        const int got = next_line(r);
        if (got < 0) {
            return -1;
        }
        if (got == 0) {
            return trace_v1_fail(
                r, r->line_no + 1u, 1u,
                "end of file before the header line (t_ms,a_mm,b_mm,c_mm,d_mm,...)");
        }
        if (r->line_len == 0u) {
            return trace_v1_fail(r, r->line_no, 1u, "empty line where the header was expected");
        }
        if (r->line[0] != '#') {
            return trace_v1_cal_finish(r) != 0 ? -1 : read_header_line(r);
        }
        if (read_meta_line(r) != 0) {
            return -1;
        }
    }
}

int trace_v1_next(struct trace_v1_reader *r, struct trace_v1_row *row) {
    if (r->state != 0) {
        return r->state;
    }
    for (;;) {
        const int got = next_line(r);
        if (got < 0) {
            return -1;
        }
        if (got == 0) {
            if (r->rows == 0u) {
                struct trace_msg m = trace_msg_begin(r, r->line_no + 1u, 1u);
                trace_msg_str(&m, "no samples after the header (line ");
                trace_msg_u64(&m, r->header_line);
                trace_msg_str(&m, ")");
                return trace_msg_fail(r);
            }
            r->state = 1;
            return 1;
        }
        if (r->line_len == 0u) {
            /* Empty lines are allowed only at the end, as editors leave them. */
            if (r->empty_line == 0u) {
                r->empty_line = r->line_no;
            }
            continue;
        }
        if (r->empty_line != 0u) {
            return trace_v1_fail(r, r->empty_line, 1u, "empty line (expected a sample row)");
        }
        if (r->line[0] == '#') {
            continue; /* a comment line (docs/reference/trace-format.md) */
        }
        if (trace_v1_parse_row(r, row) == 0) {
            return 0;
        }
        /* A row that fails with a CR inside it fails for its line endings. */
        const char *cr = memchr(r->line, '\r', r->line_len);
        return cr != NULL ? cr_only(r, r->line_no, (uint32_t)(cr - r->line) + 1u) : -1;
    }
}

void trace_v1_readings_only(struct trace_v1_reader *r) {
    for (unsigned c = TRACE_COL_ALPHA; c <= TRACE_COL_DISTANCE; ++c) {
        if (r->column_of[c] >= 0) {
            r->column_use[r->column_of[c]] = 0u; /* skipped like a column nobody knows */
        }
    }
}

const char *trace_v1_meta(const struct trace_v1_reader *r, const char *key) {
    for (unsigned i = 0; i < r->meta.count; ++i) {
        if (strcmp(r->meta.key[i], key) == 0) {
            return r->meta.value[i];
        }
    }
    return NULL;
}

uint32_t trace_v1_meta_line(const struct trace_v1_reader *r, const char *key) {
    for (unsigned i = 0; i < r->meta.count; ++i) {
        if (strcmp(r->meta.key[i], key) == 0) {
            return r->meta.line[i];
        }
    }
    return 0;
}
