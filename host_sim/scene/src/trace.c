/* Trace format v1 reader and writer (trace.h, DESIGN.md §5, docs/traces.md). */
#include "scene/trace.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

static const char *const column_names[TRACE_COL_COUNT] = {
    "t_ms", "a_mm", "b_mm", "c_mm", "d_mm", "a_st", "b_st", "c_st", "d_st", "alpha_deg", "beta_deg",
};

/* ---- errors ---- */

/* Records "name:line:col: message" and fails the reader. Returns -1. */
static int fail_at(struct trace_reader *r, unsigned long line, size_t col, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static int fail_at(struct trace_reader *r, unsigned long line, size_t col, const char *fmt, ...) {
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    snprintf(r->err, sizeof r->err, "%s:%lu:%zu: %s", r->name, line, col, msg);
    r->state = -1;
    return -1;
}

/* A bounded, printable quote of untrusted text for a message. */
static const char *quote(char *buf, size_t buflen, const char *s, size_t len) {
    const size_t keep = 40u;
    size_t o = 0;
    for (size_t i = 0; i < len && i < keep && o + 1u < buflen; ++i) {
        const unsigned char c = (unsigned char)s[i];
        buf[o++] = (c >= 0x20u && c < 0x7fu) ? (char)c : '?';
    }
    if (len > keep && o + 4u < buflen) {
        memcpy(buf + o, "...", 3u);
        o += 3u;
    }
    buf[o] = '\0';
    return buf;
}

/* ---- lines ---- */

static int cr_only(struct trace_reader *r, unsigned long line, size_t col) {
    return fail_at(r, line, col,
                   "CR-only line endings (a carriage return inside a line, as old Mac "
                   "files end lines): lines must end in LF or CRLF");
}

/* Reads the next line into r->line. Returns 1 with a line, 0 at the end of the
 * input, -1 (failed) on a NUL byte, an over-long line or a read error. */
static int next_line(struct trace_reader *r) {
    r->line_len = 0;
    bool any = false;
    for (;;) {
        if (r->block_pos == r->block_len) {
            if (r->eof) {
                break;
            }
            if (r->file != NULL) {
                r->block_len = fread(r->block, 1u, sizeof r->block, r->file);
            } else {
                const size_t left = r->mem_len - r->mem_pos;
                r->block_len = left < sizeof r->block ? left : sizeof r->block;
                memcpy(r->block, r->mem + r->mem_pos, r->block_len);
                r->mem_pos += r->block_len;
            }
            r->block_pos = 0;
            if (r->block_len == 0u) {
                r->eof = true;
                if (r->file != NULL && ferror(r->file)) {
                    return fail_at(r, r->line_no + 1u, 1u, "read error");
                }
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
        if (nul != NULL && r->line_len + (size_t)(nul - seg) < TRACE_LINE_MAX) {
            return fail_at(r, r->line_no + 1u, r->line_len + (size_t)(nul - seg) + 1u, "NUL byte");
        }
        /* Room for TRACE_LINE_MAX bytes plus the '\r' of a CRLF ending (checked below). */
        if (nul != NULL || r->line_len + seg_len > TRACE_LINE_MAX + 1u) {
            /* A file with CR-only endings reads as one long line: say so, not "too long". */
            const size_t in_line = r->line_len < TRACE_LINE_MAX ? r->line_len : TRACE_LINE_MAX;
            const size_t in_seg =
                TRACE_LINE_MAX - in_line < seg_len ? TRACE_LINE_MAX - in_line : seg_len;
            const char *cr = memchr(r->line, '\r', in_line);
            const unsigned char *cr_seg = cr == NULL ? memchr(seg, '\r', in_seg) : NULL;
            if (cr != NULL || cr_seg != NULL) {
                const size_t at =
                    cr != NULL ? (size_t)(cr - r->line) : r->line_len + (size_t)(cr_seg - seg);
                return cr_only(r, r->line_no + 1u, at + 1u);
            }
            return fail_at(r, r->line_no + 1u, TRACE_LINE_MAX + 1u, "line longer than %u bytes",
                           TRACE_LINE_MAX);
        }
        memcpy(r->line + r->line_len, seg, seg_len);
        r->line_len += seg_len;
        r->block_pos += seg_len;
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
        return fail_at(r, r->line_no, TRACE_LINE_MAX + 1u, "line longer than %u bytes",
                       TRACE_LINE_MAX);
    }
    r->line[r->line_len] = '\0';
    /* Before the header, a CR inside a line is named here; in rows, only when the row
     * fails (trace_reader_next), which keeps the search off the hot path. */
    if (r->header_line == 0u) {
        const char *cr = memchr(r->line, '\r', r->line_len);
        if (cr != NULL) {
            return cr_only(r, r->line_no, (size_t)(cr - r->line) + 1u);
        }
    }
    return 1;
}

/* ---- fields ---- */

struct field {
    const char *s; /* first byte after leading blanks */
    size_t len;    /* without trailing blanks */
    size_t col;    /* 1-based column of s (of the field start if it is blank) */
};

static bool is_blank(char c) {
    return c == ' ' || c == '\t';
}

static struct field make_field(const char *line, size_t start, size_t end) {
    size_t b = start;
    while (b < end && is_blank(line[b])) {
        ++b;
    }
    size_t e = end;
    while (e > b && is_blank(line[e - 1u])) {
        --e;
    }
    struct field f = {line + b, e - b, (b < end ? b : start) + 1u};
    return f;
}

enum parse_result { PARSE_OK, PARSE_EMPTY, PARSE_SYNTAX, PARSE_NEGATIVE, PARSE_RANGE };

static bool is_digit(char c) {
    return c >= '0' && c <= '9';
}

/*
 * The scanners read NUL-terminated text (r->line always is, and next_line() refuses a
 * NUL inside a line), so the terminator stops every loop and no end pointer is needed.
 */

/* Past the blanks at p. */
static const char *skip_blanks(const char *p) {
    while (is_blank(*p)) {
        ++p;
    }
    return p;
}

/* A field ends at a ',' or at the end of the text. */
static bool at_field_end(const char *p) {
    return *p == ',' || *p == '\0';
}

/*
 * The one integer parser. The field at *pp (up to the next ',' or the end): blanks,
 * then [+-]digits, then blanks. Unsigned decimal in 0..max; "-0" is 0. One pass
 * without a division per digit: up to 19 digits accumulate exactly in 64 bits; a sign
 * or a longer number is looked at again (leading zeros dropped; more than 19
 * significant digits exceed any max). On PARSE_OK *pp is left at the field's ',' or
 * end. Inlined: it is most of the work of reading a row.
 */
static inline __attribute__((always_inline)) enum parse_result
scan_uint(const char **pp, uint64_t max, uint64_t *out) {
    const char *p = *pp;
    bool negative = false;
    if (!is_digit(*p)) { /* blanks or a sign first */
        p = skip_blanks(p);
        if (at_field_end(p)) {
            return PARSE_EMPTY;
        }
        if (*p == '-' || *p == '+') {
            negative = *p == '-';
            ++p;
        }
    }
    const char *const digits_start = p;
    uint64_t v = 0; /* exact for up to 19 digits; a longer number is redone below */
    for (; is_digit(*p); ++p) {
        v = v * 10u + (uint64_t)(*p - '0');
    }
    size_t significant = (size_t)(p - digits_start);
    if (!at_field_end(p)) { /* blanks after the digits, or anything else */
        p = skip_blanks(p);
        if (!at_field_end(p)) {
            return PARSE_SYNTAX;
        }
    }
    if (negative || significant - 1u >= 19u) { /* a sign, no digit, or 20 digits or more */
        if (significant == 0u) {
            return PARSE_SYNTAX; /* a sign alone */
        }
        const char *q = digits_start;
        while (*q == '0') {
            ++q;
        }
        significant = (size_t)(p - q);
        v = 0;
        for (; significant <= 19u && is_digit(*q); ++q) {
            v = v * 10u + (uint64_t)(*q - '0');
        }
        if (negative && v > 0u) {
            return PARSE_NEGATIVE;
        }
        if (significant > 19u) {
            return PARSE_RANGE;
        }
    }
    if (v > max) {
        return PARSE_RANGE;
    }
    *out = v;
    *pp = p;
    return PARSE_OK;
}

/*
 * The one real-number parser. The field at *pp: blanks, then
 * [+-]digits[.digits][(e|E)[+-]digits] or [+-].digits[...], then blanks; finite.
 * Scanned once: the digits accumulate as one integer with a decimal exponent.
 * Clinger's fast path: with at most 15 digits (leading zeros included) the integer is
 * below 10^15, an exact double, and so is 10^k for k <= 22, so one multiplication or
 * division gives the correctly rounded value, the same as strtod's. Any other number
 * (rare in a trace: long mantissas, large exponents) is converted by strtod from the
 * text already checked here. On PARSE_OK *pp is left at the field's ',' or end.
 */
static inline __attribute__((always_inline)) enum parse_result scan_real(const char **pp,
                                                                         double *out) {
    static const double pow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                     1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                     1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    const char *p = *pp;
    if (is_blank(*p)) {
        p = skip_blanks(p);
    }
    if (at_field_end(p)) {
        return PARSE_EMPTY;
    }
    const char *const text = p;
    bool negative = false;
    if (*p == '+' || *p == '-') {
        negative = *p == '-';
        ++p;
    }
    /* Wraps harmlessly beyond 19 digits: then more than 15 send the number to strtod. */
    uint64_t mantissa = 0;
    const char *const int_start = p;
    for (; is_digit(*p); ++p) {
        mantissa = mantissa * 10u + (uint64_t)(*p - '0');
    }
    size_t digits = (size_t)(p - int_start);
    long exp10 = 0;
    if (*p == '.') {
        const char *const frac_start = ++p;
        for (; is_digit(*p); ++p) {
            mantissa = mantissa * 10u + (uint64_t)(*p - '0');
        }
        exp10 = -(long)(p - frac_start);
        digits += (size_t)(p - frac_start);
    }
    if (digits == 0u) {
        return PARSE_SYNTAX;
    }
    if (*p == 'e' || *p == 'E') {
        ++p;
        bool exp_negative = false;
        if (*p == '+' || *p == '-') {
            exp_negative = *p == '-';
            ++p;
        }
        long e = 0;
        const char *const exp_start = p;
        for (; is_digit(*p); ++p) {
            e = e < 100000 ? e * 10 + (*p - '0') : e; /* saturated far beyond any double */
        }
        if (p == exp_start) {
            return PARSE_SYNTAX;
        }
        exp10 += exp_negative ? -e : e;
    }
    const char *const text_end = p;
    if (!at_field_end(p)) {
        p = skip_blanks(p);
        if (!at_field_end(p)) {
            return PARSE_SYNTAX;
        }
    }
    double v = 0.0;
    if (digits <= 15u && exp10 >= -22 && exp10 <= 22) {
        v = (double)mantissa;
        v = exp10 >= 0 ? v * pow10[exp10] : v / pow10[-exp10];
        v = negative ? -v : v;
    } else {
        char buf[TRACE_LINE_MAX + 1u];
        const size_t len = (size_t)(text_end - text);
        memcpy(buf, text, len);
        buf[len] = '\0';
        errno = 0;
        v = strtod(buf, NULL);
        if (!isfinite(v) || (errno == ERANGE && fabs(v) > 1.0)) {
            return PARSE_RANGE;
        }
    }
    *out = v;
    *pp = p;
    return PARSE_OK;
}

/* A whole metadata value as one number: the scanners' field must be all of it. */
static enum parse_result parse_meta_uint(const struct field *f, uint64_t max, uint64_t *out) {
    char buf[TRACE_VALUE_MAX];
    memcpy(buf, f->s, f->len); /* the caller checked len < TRACE_VALUE_MAX */
    buf[f->len] = '\0';
    const char *p = buf;
    const enum parse_result pr = scan_uint(&p, max, out);
    return pr == PARSE_OK && *p != '\0' ? PARSE_SYNTAX : pr;
}

static enum parse_result parse_meta_real(const struct field *f, double *out) {
    char buf[TRACE_VALUE_MAX];
    memcpy(buf, f->s, f->len);
    buf[f->len] = '\0';
    const char *p = buf;
    const enum parse_result pr = scan_real(&p, out);
    return pr == PARSE_OK && *p != '\0' ? PARSE_SYNTAX : pr;
}

/* ---- header part ---- */

static bool is_key_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || is_digit(c) || c == '_' ||
           c == '-' || c == '.';
}

/* A line starting with '#' before the header: "# key=value" metadata or a comment. */
static int read_meta_line(struct trace_reader *r) {
    const char *line = r->line;
    size_t i = 1;
    while (i < r->line_len && is_blank(line[i])) {
        ++i;
    }
    const size_t key_start = i;
    while (i < r->line_len && is_key_char(line[i])) {
        ++i;
    }
    const size_t key_len = i - key_start;
    while (i < r->line_len && is_blank(line[i])) {
        ++i;
    }
    if (key_len == 0u || i >= r->line_len || line[i] != '=') {
        return 0; /* a plain comment */
    }
    const struct field val = make_field(line, i + 1u, r->line_len);
    char q[64];
    if (key_len >= TRACE_KEY_MAX) {
        return fail_at(r, r->line_no, key_start + 1u, "metadata key '%s' longer than %u bytes",
                       quote(q, sizeof q, line + key_start, key_len), TRACE_KEY_MAX - 1u);
    }
    if (val.len >= TRACE_VALUE_MAX) {
        return fail_at(r, r->line_no, val.col, "metadata value longer than %u bytes",
                       TRACE_VALUE_MAX - 1u);
    }
    char key[TRACE_KEY_MAX];
    memcpy(key, line + key_start, key_len);
    key[key_len] = '\0';
    if (trace_reader_meta(r, key) != NULL) {
        return fail_at(r, r->line_no, key_start + 1u, "duplicate metadata key '%s'", key);
    }
    if (r->meta.count >= TRACE_MAX_META) {
        return fail_at(r, r->line_no, key_start + 1u, "more than %u metadata keys", TRACE_MAX_META);
    }
    if (strcmp(key, "arm_mm") == 0) {
        double v = 0.0;
        if (parse_meta_real(&val, &v) != PARSE_OK || !(v > 0.0)) {
            return fail_at(r, r->line_no, val.col,
                           "arm_mm must be a positive number of millimetres, got '%s'",
                           quote(q, sizeof q, val.s, val.len));
        }
        r->meta.arm_mm = v;
    } else if (strcmp(key, "period_ms") == 0) {
        uint64_t v = 0;
        if (parse_meta_uint(&val, UINT32_MAX, &v) != PARSE_OK || v == 0u) {
            return fail_at(r, r->line_no, val.col,
                           "period_ms must be an integer in 1..4294967295, got '%s'",
                           quote(q, sizeof q, val.s, val.len));
        }
        r->meta.period_ms = (uint32_t)v;
    }
    r->meta.line[r->meta.count] = r->line_no;
    memcpy(r->meta.key[r->meta.count], key, key_len + 1u);
    memcpy(r->meta.value[r->meta.count], val.s, val.len);
    r->meta.value[r->meta.count][val.len] = '\0';
    r->meta.count++;
    return 0;
}

static int read_header_line(struct trace_reader *r) {
    if (!(r->meta.arm_mm > 0.0)) {
        return fail_at(r, r->line_no, 1u,
                       "missing metadata arm_mm (a line '# arm_mm=<mm>' must come before the "
                       "header)");
    }
    for (unsigned c = 0; c < TRACE_COL_COUNT; ++c) {
        r->column_of[c] = -1;
    }
    r->header_line = r->line_no;
    unsigned n = 0;
    size_t start = 0;
    for (size_t i = 0; i <= r->line_len; ++i) {
        if (i < r->line_len && r->line[i] != ',') {
            continue;
        }
        const struct field f = make_field(r->line, start, i);
        if (n >= TRACE_MAX_COLUMNS) {
            return fail_at(r, r->line_no, f.col, "more than %u columns in the header",
                           TRACE_MAX_COLUMNS);
        }
        if (f.len == 0u) {
            return fail_at(r, r->line_no, f.col, "empty column name in the header");
        }
        for (unsigned c = 0; c < TRACE_COL_COUNT; ++c) {
            if (strlen(column_names[c]) == f.len && memcmp(column_names[c], f.s, f.len) == 0) {
                if (r->column_of[c] >= 0) {
                    return fail_at(r, r->line_no, f.col, "duplicate column '%s'", column_names[c]);
                }
                r->column_of[c] = (int)n;
            }
        }
        ++n;
        start = i + 1u;
    }
    r->n_columns = n;
    /* t_ms and the four ranges are required; statuses and truth are optional. */
    for (unsigned c = TRACE_COL_T_MS; c <= TRACE_COL_D_MM; ++c) {
        if (r->column_of[c] < 0) {
            return fail_at(r, r->line_no, 1u, "header lacks required column '%s'", column_names[c]);
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

static int open_common(struct trace_reader *r, const char *name);

int trace_reader_open(struct trace_reader *r, FILE *file, const char *name) {
    memset(r, 0, sizeof *r);
    r->file = file;
    return open_common(r, name);
}

int trace_reader_open_mem(struct trace_reader *r, const void *data, size_t len, const char *name) {
    memset(r, 0, sizeof *r);
    r->mem = data;
    r->mem_len = data != NULL ? len : 0u;
    return open_common(r, name);
}

static int open_common(struct trace_reader *r, const char *name) {
    const size_t name_len = strlen(name);
    if (name_len < sizeof r->name) {
        memcpy(r->name, name, name_len + 1u);
    } else {
        snprintf(r->name, sizeof r->name, "...%s", name + name_len - (sizeof r->name - 4u));
    }
    for (unsigned c = 0; c < TRACE_COL_COUNT; ++c) {
        r->column_of[c] = -1;
    }
    char q[64];
    int got = next_line(r);
    if (got < 0) {
        return -1;
    }
    if (got == 0) {
        return fail_at(r, 1u, 1u, "empty file (the first line must be '# tof-trace v1')");
    }
    /* A UTF-8 byte-order mark, as Windows editors and loggers write, is not text. */
    if (r->line_len >= 3u && memcmp(r->line, "\xEF\xBB\xBF", 3u) == 0) {
        r->line_len -= 3u;
        memmove(r->line, r->line + 3u, r->line_len + 1u);
        r->bom = true;
    }
    static const char version_prefix[] = "# tof-trace v";
    const size_t prefix_len = sizeof version_prefix - 1u;
    if (strcmp(r->line, "# tof-trace v1") != 0) {
        if (r->line_len > prefix_len && memcmp(r->line, version_prefix, prefix_len) == 0) {
            return fail_at(r, 1u, prefix_len + 1u,
                           "unsupported trace version 'v%s' (this reader reads v1)",
                           quote(q, sizeof q, r->line + prefix_len, r->line_len - prefix_len));
        }
        return fail_at(r, 1u, 1u, "the first line must be '# tof-trace v1', got '%s'",
                       quote(q, sizeof q, r->line, r->line_len));
    }
    for (;;) {
        got = next_line(r);
        if (got < 0) {
            return -1;
        }
        if (got == 0) {
            return fail_at(r, r->line_no + 1u, 1u,
                           "end of file before the header line (t_ms,a_mm,b_mm,c_mm,d_mm,...)");
        }
        if (r->line_len == 0u) {
            return fail_at(r, r->line_no, 1u, "empty line where the header was expected");
        }
        if (r->line[0] == '#') {
            if (read_meta_line(r) != 0) {
                return -1;
            }
            continue;
        }
        return read_header_line(r);
    }
}

/* ---- rows ---- */

static int field_error(struct trace_reader *r, const struct field *f, enum trace_column c,
                       enum parse_result pr, uint64_t max) {
    char q[64];
    const char *name = column_names[c];
    quote(q, sizeof q, f->s, f->len);
    switch (pr) {
    case PARSE_EMPTY:
        return fail_at(r, r->line_no, f->col, "%s: empty value", name);
    case PARSE_NEGATIVE:
        if (c >= TRACE_COL_A_MM && c <= TRACE_COL_D_MM) {
            return fail_at(r, r->line_no, f->col, "%s: negative range '%s'", name, q);
        }
        return fail_at(r, r->line_no, f->col, "%s: negative value '%s'", name, q);
    case PARSE_RANGE:
        if (c == TRACE_COL_ALPHA || c == TRACE_COL_BETA) {
            return fail_at(r, r->line_no, f->col, "%s: '%s' out of range -90..90 degrees", name, q);
        }
        return fail_at(r, r->line_no, f->col, "%s: '%s' out of range 0..%llu", name, q,
                       (unsigned long long)max);
    case PARSE_SYNTAX:
    case PARSE_OK:
    default:
        break;
    }
    if (c == TRACE_COL_ALPHA || c == TRACE_COL_BETA) {
        return fail_at(r, r->line_no, f->col, "%s: expected a number, got '%s'", name, q);
    }
    return fail_at(r, r->line_no, f->col, "%s: expected an integer, got '%s'", name, q);
}

/* The field that starts at line[start] (up to its ',' or the end), trimmed. */
static struct field field_at(const struct trace_reader *r, size_t start) {
    const char *comma = memchr(r->line + start, ',', r->line_len - start);
    const size_t end = comma != NULL ? (size_t)(comma - r->line) : r->line_len;
    return make_field(r->line, start, end);
}

/* A row with other than the header's number of fields, whatever else is wrong with it. */
static int check_field_count(struct trace_reader *r) {
    unsigned n = 1;
    for (const char *c = memchr(r->line, ',', r->line_len); c != NULL;
         c = memchr(c + 1, ',', r->line_len - (size_t)(c + 1 - r->line))) {
        if (n == r->n_columns) {
            return fail_at(r, r->line_no, (size_t)(c - r->line) + 2u,
                           "long row: more than the header's %u fields", r->n_columns);
        }
        ++n;
    }
    if (n < r->n_columns) {
        return fail_at(r, r->line_no, r->line_len + 1u, "short row: %u fields, the header has %u",
                       n, r->n_columns);
    }
    return 0;
}

/* Notes a time stamp that repeats the previous one or jumps more than two periods. */
static void check_timing(struct trace_reader *r, uint32_t t_ms) {
    struct trace_timing *tm = &r->timing;
    const uint64_t dt = (uint64_t)t_ms - r->last_t_ms;
    uint8_t kind = 0;
    if (dt == 0u) {
        ++tm->repeats;
        kind = TRACE_TIME_REPEAT;
    } else if (dt > 2u * (uint64_t)tm->period_ms) {
        ++tm->jumps;
        kind = TRACE_TIME_JUMP;
        if (dt > tm->max_jump_ms) {
            tm->max_jump_ms = (uint32_t)dt;
            tm->max_jump_line = r->line_no;
        }
    } else {
        return;
    }
    if (tm->note_count < TRACE_TIMING_NOTES) {
        tm->notes[tm->note_count++] = (struct trace_timing_note){
            .line = r->line_no, .t_ms = t_ms, .prev_t_ms = r->last_t_ms, .kind = kind};
    }
}

/*
 * The one row parser: a single pass over the line, each field read as the header says
 * (column_use), with the one integer and the one real parser. The first field that is
 * wrong, from the left, is the error; a row with the wrong number of fields is reported
 * as such first, whatever else is wrong with it.
 */
static int parse_row(struct trace_reader *r, struct scene_row *row) {
    const char *const line = r->line;
    const char *p = line;
    size_t t_start = 0; /* offset of the t_ms field, for its message */
    memset(row, 0, sizeof *row);
    for (unsigned n = 0;; ++n) {
        const char *const start = p;
        const unsigned use = r->column_use[n];
        enum parse_result pr = PARSE_OK;
        enum trace_column c = (enum trace_column)(use - 1u);
        uint64_t max = 0;
        uint64_t v = 0;
        double d = 0.0;
        switch (use) {
        case 0u: /* a column this reader does not use */
            while (!at_field_end(p)) {
                ++p;
            }
            break;
        case TRACE_COL_T_MS + 1u:
            max = UINT32_MAX;
            pr = scan_uint(&p, max, &v);
            row->t_ms = (uint32_t)v;
            t_start = (size_t)(start - line);
            break;
        case TRACE_COL_A_MM + 1u:
        case TRACE_COL_B_MM + 1u:
        case TRACE_COL_C_MM + 1u:
        case TRACE_COL_D_MM + 1u:
            max = UINT16_MAX;
            pr = scan_uint(&p, max, &v);
            row->range_mm[c - TRACE_COL_A_MM] = (uint16_t)v;
            break;
        case TRACE_COL_A_ST + 1u:
        case TRACE_COL_B_ST + 1u:
        case TRACE_COL_C_ST + 1u:
        case TRACE_COL_D_ST + 1u:
            max = UINT8_MAX;
            pr = scan_uint(&p, max, &v);
            row->status[c - TRACE_COL_A_ST] = (uint8_t)v;
            break;
        default: /* alpha_deg, beta_deg */
            pr = scan_real(&p, &d);
            if (pr == PARSE_EMPTY) { /* truth may be empty (DESIGN.md §5) */
                p = skip_blanks(p);
                pr = PARSE_OK;
            } else if (pr == PARSE_OK && !(fabs(d) <= 90.0)) {
                pr = PARSE_RANGE;
            } else if (pr == PARSE_OK && c == TRACE_COL_ALPHA) {
                row->has_alpha = true;
                row->alpha_deg = d;
            } else if (pr == PARSE_OK) {
                row->has_beta = true;
                row->beta_deg = d;
            }
            break;
        }
        if (pr != PARSE_OK) {
            if (check_field_count(r) != 0) {
                return -1;
            }
            const struct field f = field_at(r, (size_t)(start - line));
            return field_error(r, &f, c, pr, max);
        }
        if (*p == ',') {
            if (n + 1u == r->n_columns) {
                return check_field_count(r); /* long row */
            }
            ++p;
        } else { /* the end of the line */
            if (n + 1u < r->n_columns) {
                return check_field_count(r); /* short row */
            }
            break;
        }
    }
    if (r->rows > 0u && row->t_ms < r->last_t_ms) {
        const struct field f = field_at(r, t_start);
        return fail_at(r, r->line_no, f.col,
                       "t_ms %lu is earlier than the previous row's %lu (time went backwards)",
                       (unsigned long)row->t_ms, (unsigned long)r->last_t_ms);
    }
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        row->present[k] = row->status[k] != SCENE_STATUS_NO_READING;
    }
    if (r->rows > 0u) {
        check_timing(r, row->t_ms);
    }
    r->last_t_ms = row->t_ms;
    r->last_row_line = r->line_no;
    r->rows++;
    return 0;
}

int trace_reader_next(struct trace_reader *r, struct scene_row *row) {
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
                return fail_at(r, r->line_no + 1u, 1u, "no samples after the header (line %lu)",
                               r->header_line);
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
            return fail_at(r, r->empty_line, 1u, "empty line (expected a sample row)");
        }
        if (r->line[0] == '#') {
            continue; /* a comment line (DESIGN.md §5) */
        }
        if (parse_row(r, row) == 0) {
            return 0;
        }
        /* A row that fails with a CR inside it fails for its line endings. */
        const char *cr = memchr(r->line, '\r', r->line_len);
        return cr != NULL ? cr_only(r, r->line_no, (size_t)(cr - r->line) + 1u) : -1;
    }
}

const char *trace_reader_error(const struct trace_reader *r) {
    return r->err;
}

const char *trace_reader_meta(const struct trace_reader *r, const char *key) {
    for (unsigned i = 0; i < r->meta.count; ++i) {
        if (strcmp(r->meta.key[i], key) == 0) {
            return r->meta.value[i];
        }
    }
    return NULL;
}

unsigned long trace_reader_meta_line(const struct trace_reader *r, const char *key) {
    for (unsigned i = 0; i < r->meta.count; ++i) {
        if (strcmp(r->meta.key[i], key) == 0) {
            return r->meta.line[i];
        }
    }
    return 0;
}

const struct trace_timing *trace_reader_timing(const struct trace_reader *r) {
    return &r->timing;
}

int trace_load_file(const char *path, size_t max_rows, struct scene_row **rows, size_t *count,
                    struct trace_meta *meta, char *err, size_t errlen) {
    *rows = NULL;
    *count = 0;
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    struct trace_reader *r = malloc(sizeof *r);
    if (r == NULL) {
        fclose(f);
        snprintf(err, errlen, "%s: out of memory", path);
        return -1;
    }
    int rc = trace_reader_open(r, f, path);
    struct scene_row *data = NULL;
    size_t n = 0;
    size_t cap = 0;
    while (rc == 0) {
        struct scene_row row = {0};
        const int got = trace_reader_next(r, &row);
        if (got == 1) {
            break;
        }
        if (got < 0) {
            rc = -1;
            break;
        }
        if (n == max_rows) {
            snprintf(r->err, sizeof r->err, "%s:%lu:1: more than %zu rows", r->name, r->line_no,
                     max_rows);
            rc = -1;
            break;
        }
        if (n == cap) {
            const size_t new_cap = cap == 0u ? 1024u : cap * 2u;
            struct scene_row *grown = realloc(data, new_cap * sizeof *grown);
            if (grown == NULL) {
                snprintf(r->err, sizeof r->err, "%s: out of memory", r->name);
                rc = -1;
                break;
            }
            data = grown;
            cap = new_cap;
        }
        data[n++] = row;
    }
    if (rc != 0) {
        snprintf(err, errlen, "%s", r->err);
        free(data);
    } else {
        if (meta != NULL) {
            *meta = r->meta;
        }
        *rows = data;
        *count = n;
    }
    free(r);
    fclose(f);
    return rc;
}

/* ---- writer ---- */

/* Shortest of %.15g/%.17g that reads back to the same double. */
static void format_double(char *buf, size_t len, double v) {
    snprintf(buf, len, "%.15g", v);
    if (strtod(buf, NULL) != v) {
        snprintf(buf, len, "%.17g", v);
    }
}

static bool meta_entry_ok(const char *kv) {
    size_t i = 0;
    while (is_key_char(kv[i])) {
        ++i;
    }
    if (i == 0u || i >= TRACE_KEY_MAX || kv[i] != '=') {
        return false;
    }
    const size_t vlen = strlen(kv + i + 1u);
    return vlen < TRACE_VALUE_MAX && strchr(kv, '\n') == NULL && strchr(kv, '\r') == NULL &&
           strncmp(kv, "arm_mm=", 7u) != 0 && strncmp(kv, "period_ms=", 10u) != 0;
}

int trace_write_header(FILE *f, double arm_mm, uint32_t period_ms, const char *const *extra_meta) {
    if (!(arm_mm > 0.0) || !isfinite(arm_mm)) {
        return -1;
    }
    char arm[40];
    format_double(arm, sizeof arm, arm_mm);
    if (fprintf(f, "# tof-trace v1\n# arm_mm=%s\n", arm) < 0) {
        return -1;
    }
    if (period_ms > 0u && fprintf(f, "# period_ms=%lu\n", (unsigned long)period_ms) < 0) {
        return -1;
    }
    for (size_t i = 0; extra_meta != NULL && extra_meta[i] != NULL; ++i) {
        if (!meta_entry_ok(extra_meta[i]) || fprintf(f, "# %s\n", extra_meta[i]) < 0) {
            return -1;
        }
    }
    if (fputs("t_ms,a_mm,b_mm,c_mm,d_mm,a_st,b_st,c_st,d_st,alpha_deg,beta_deg\n", f) < 0) {
        return -1;
    }
    return 0;
}

int trace_write_row(FILE *f, const struct scene_row *row) {
    unsigned range[SCENE_SENSORS];
    unsigned status[SCENE_SENSORS];
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        range[k] = row->present[k] ? row->range_mm[k] : 0u;
        status[k] = row->present[k] ? row->status[k] : SCENE_STATUS_NO_READING;
        if (row->present[k] && row->status[k] == SCENE_STATUS_NO_READING) {
            return -1; /* would read back as absent */
        }
    }
    char alpha[32] = "";
    char beta[32] = "";
    if (row->has_alpha) {
        if (!(fabs(row->alpha_deg) <= 90.0)) {
            return -1;
        }
        snprintf(alpha, sizeof alpha, "%.6f", row->alpha_deg);
    }
    if (row->has_beta) {
        if (!(fabs(row->beta_deg) <= 90.0)) {
            return -1;
        }
        snprintf(beta, sizeof beta, "%.6f", row->beta_deg);
    }
    const int n = fprintf(f, "%lu,%u,%u,%u,%u,%u,%u,%u,%u,%s,%s\n", (unsigned long)row->t_ms,
                          range[0], range[1], range[2], range[3], status[0], status[1], status[2],
                          status[3], alpha, beta);
    return n < 0 ? -1 : 0;
}
