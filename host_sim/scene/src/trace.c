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

/* Unsigned decimal integer in 0..max (digits only). One pass without a division per
 * digit: leading zeros skipped, up to 19 significant digits accumulate exactly in 64
 * bits, and more than 19 exceed any max. */
static enum parse_result parse_uint(const struct field *f, uint64_t max, uint64_t *out) {
    if (f->len == 0u) {
        return PARSE_EMPTY;
    }
    size_t i = 0;
    bool negative = false;
    if (f->s[0] == '-' || f->s[0] == '+') {
        negative = f->s[0] == '-';
        i = 1;
    }
    if (i == f->len) {
        return PARSE_SYNTAX;
    }
    while (i < f->len && f->s[i] == '0') {
        ++i;
    }
    uint64_t v = 0;
    size_t significant = 0;
    for (; i < f->len; ++i) {
        if (!is_digit(f->s[i])) {
            return PARSE_SYNTAX;
        }
        if (significant < 19u) {
            v = v * 10u + (uint64_t)(f->s[i] - '0');
        }
        ++significant;
    }
    const bool over = significant > 19u || v > max;
    if (negative) {
        if (significant == 0u) { /* "-0" is 0 */
            *out = 0u;
            return PARSE_OK;
        }
        return PARSE_NEGATIVE;
    }
    if (over) {
        return PARSE_RANGE;
    }
    *out = v;
    return PARSE_OK;
}

/* The common form of a real, [+-]digits[.digits] with 1..15 digits in all (what the
 * writer produces: "-12.345678"), in one pass: the digits as an exact integer, scaled
 * by one exact power of ten, exactly as parse_real's Clinger path computes it. False
 * for anything else, which parse_real then takes the long way (and rejects if bad). */
static bool parse_plain_real(const struct field *f, double *out) {
    static const double pow10[16] = {1e0, 1e1, 1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                     1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
    size_t i = 0;
    const bool negative = f->s[0] == '-';
    if (f->s[0] == '+' || f->s[0] == '-') {
        i = 1;
    }
    uint64_t mantissa = 0;
    size_t digits = 0;
    size_t fraction_digits = 0;
    bool point = false;
    for (; i < f->len; ++i) {
        const char c = f->s[i];
        if (is_digit(c)) {
            mantissa = mantissa * 10u + (uint64_t)(c - '0');
            ++digits;
            fraction_digits += point ? 1u : 0u;
        } else if (c == '.' && !point) {
            point = true;
        } else {
            return false;
        }
        if (digits > 15u) {
            return false;
        }
    }
    if (digits == 0u) {
        return false;
    }
    const double v = (double)mantissa / pow10[fraction_digits];
    *out = negative ? -v : v;
    return true;
}

/* Decimal real [+-]digits[.digits][(e|E)[+-]digits] (or .digits), finite. */
static enum parse_result parse_real(const struct field *f, double *out) {
    if (f->len == 0u) {
        return PARSE_EMPTY;
    }
    if (parse_plain_real(f, out)) {
        return PARSE_OK;
    }
    size_t i = 0;
    if (f->s[i] == '+' || f->s[i] == '-') {
        ++i;
    }
    size_t digits = 0;
    while (i < f->len && is_digit(f->s[i])) {
        ++i;
        ++digits;
    }
    if (i < f->len && f->s[i] == '.') {
        ++i;
        while (i < f->len && is_digit(f->s[i])) {
            ++i;
            ++digits;
        }
    }
    if (digits == 0u) {
        return PARSE_SYNTAX;
    }
    if (i < f->len && (f->s[i] == 'e' || f->s[i] == 'E')) {
        ++i;
        if (i < f->len && (f->s[i] == '+' || f->s[i] == '-')) {
            ++i;
        }
        size_t exp_digits = 0;
        while (i < f->len && is_digit(f->s[i])) {
            ++i;
            ++exp_digits;
        }
        if (exp_digits == 0u) {
            return PARSE_SYNTAX;
        }
    }
    if (i != f->len) {
        return PARSE_SYNTAX;
    }
    /* Clinger's fast path: with at most 15 significant digits the mantissa is
     * an exact double, and so is 10^k for k <= 22, so one multiplication or
     * division gives the correctly rounded value, the same as strtod's. */
    static const double pow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                     1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                     1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    uint64_t mantissa = 0;
    unsigned significant = 0;
    long exp10 = 0;
    bool after_point = false;
    bool negative = false;
    size_t j = 0;
    if (f->s[0] == '+' || f->s[0] == '-') {
        negative = f->s[0] == '-';
        j = 1;
    }
    for (; j < f->len && f->s[j] != 'e' && f->s[j] != 'E'; ++j) {
        if (f->s[j] == '.') {
            after_point = true;
            continue;
        }
        if (significant > 0u || f->s[j] != '0') {
            ++significant;
            if (significant <= 15u) {
                mantissa = mantissa * 10u + (uint64_t)(f->s[j] - '0');
            }
        }
        if (after_point && significant <= 15u) {
            --exp10;
        } else if (!after_point && significant > 15u) {
            ++exp10; /* dropped digit before the point (only for the bound check) */
        }
    }
    if (j < f->len) { /* exponent digits, saturated far beyond any double */
        ++j;
        const bool exp_negative = f->s[j] == '-';
        if (f->s[j] == '+' || f->s[j] == '-') {
            ++j;
        }
        long e = 0;
        for (; j < f->len; ++j) {
            e = e < 100000 ? e * 10 + (f->s[j] - '0') : e;
        }
        exp10 += exp_negative ? -e : e;
    }
    if (significant <= 15u && exp10 >= -22 && exp10 <= 22) {
        double v = (double)mantissa;
        v = exp10 >= 0 ? v * pow10[exp10] : v / pow10[-exp10];
        *out = negative ? -v : v;
        return PARSE_OK;
    }
    char buf[TRACE_LINE_MAX + 1u];
    memcpy(buf, f->s, f->len);
    buf[f->len] = '\0';
    errno = 0;
    const double v = strtod(buf, NULL);
    if (!isfinite(v) || (errno == ERANGE && fabs(v) > 1.0)) {
        return PARSE_RANGE;
    }
    *out = v;
    return PARSE_OK;
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
        if (parse_real(&val, &v) != PARSE_OK || !(v > 0.0)) {
            return fail_at(r, r->line_no, val.col,
                           "arm_mm must be a positive number of millimetres, got '%s'",
                           quote(q, sizeof q, val.s, val.len));
        }
        r->meta.arm_mm = v;
    } else if (strcmp(key, "period_ms") == 0) {
        uint64_t v = 0;
        if (parse_uint(&val, UINT32_MAX, &v) != PARSE_OK || v == 0u) {
            return fail_at(r, r->line_no, val.col,
                           "period_ms must be an integer in 1..4294967295, got '%s'",
                           quote(q, sizeof q, val.s, val.len));
        }
        r->meta.period_ms = (uint32_t)v;
    }
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

/* parse_plain_real's form and value, scanned from *pp up to the first character that is
 * neither a digit nor the point (the caller checks that it ends the field). */
static bool scan_plain_real(const char **pp, const char *end, double *out) {
    static const double pow10[16] = {1e0, 1e1, 1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                     1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
    const char *p = *pp;
    bool negative = false;
    if (p < end && (*p == '+' || *p == '-')) {
        negative = *p == '-';
        ++p;
    }
    uint64_t mantissa = 0; /* wraps beyond 19 digits, but more than 15 is refused below */
    size_t digits = 0;
    size_t fraction_digits = 0;
    while (p < end && is_digit(*p)) {
        mantissa = mantissa * 10u + (uint64_t)(*p - '0');
        ++digits;
        ++p;
    }
    if (p < end && *p == '.') {
        ++p;
        while (p < end && is_digit(*p)) {
            mantissa = mantissa * 10u + (uint64_t)(*p - '0');
            ++digits;
            ++fraction_digits;
            ++p;
        }
    }
    if (digits == 0u || digits > 15u) {
        return false;
    }
    const double v = (double)mantissa / pow10[fraction_digits];
    *out = negative ? -v : v;
    *pp = p;
    return true;
}

/*
 * A row in the form the writer produces (plain digits, plain reals, nothing to trim),
 * read in one pass over the line. True with *row filled exactly as parse_row fills it;
 * false for anything else (blanks, signs, exponents, long numbers, a bad or missing
 * field, time going backwards), which parse_row then reads the long way and accepts or
 * reports with its line and column. So the fast path never decides an error.
 */
static bool parse_row_fast(struct trace_reader *r, struct scene_row *row) {
    const char *p = r->line;
    const char *const end = r->line + r->line_len;
    memset(row, 0, sizeof *row);
    for (unsigned n = 0; n < r->n_columns; ++n) {
        const unsigned use = r->column_use[n];
        if (use >= TRACE_COL_T_MS + 1u && use <= TRACE_COL_D_ST + 1u) {
            /* 1..9 digits: at most 999 999 999, exact in 32 bits. */
            uint32_t v = 0;
            unsigned digits = 0;
            while (p < end && is_digit(*p)) {
                if (++digits > 9u) {
                    return false;
                }
                v = v * 10u + (uint32_t)(*p - '0');
                ++p;
            }
            if (digits == 0u) {
                return false;
            }
            const unsigned c = use - 1u;
            if (c == TRACE_COL_T_MS) {
                row->t_ms = v;
            } else if (c <= TRACE_COL_D_MM) {
                if (v > UINT16_MAX) {
                    return false;
                }
                row->range_mm[c - TRACE_COL_A_MM] = (uint16_t)v;
            } else {
                if (v > UINT8_MAX) {
                    return false;
                }
                row->status[c - TRACE_COL_A_ST] = (uint8_t)v;
            }
        } else if (use == 0u) {
            while (p < end && *p != ',') { /* a column this reader does not use */
                ++p;
            }
        } else {
            if (p < end && *p != ',') { /* truth; empty means none (DESIGN.md §5) */
                double d = 0.0;
                if (!scan_plain_real(&p, end, &d) || !(fabs(d) <= 90.0)) {
                    return false;
                }
                if (use - 1u == TRACE_COL_ALPHA) {
                    row->has_alpha = true;
                    row->alpha_deg = d;
                } else {
                    row->has_beta = true;
                    row->beta_deg = d;
                }
            }
        }
        if (n + 1u < r->n_columns) {
            if (p == end || *p != ',') {
                return false;
            }
            ++p;
        } else if (p != end) {
            return false;
        }
    }
    if (r->rows > 0u && row->t_ms < r->last_t_ms) {
        return false;
    }
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        row->present[k] = row->status[k] != SCENE_STATUS_NO_READING;
    }
    r->last_t_ms = row->t_ms;
    r->rows++;
    return true;
}

static int parse_row(struct trace_reader *r, struct scene_row *row) {
    if (parse_row_fast(r, row)) {
        return 0;
    }
    struct field fields[TRACE_MAX_COLUMNS];
    unsigned n = 0;
    size_t start = 0;
    const char *line = r->line;
    const size_t len = r->line_len;
    for (;;) { /* one field per pass; each pass consumes at least its ',' or ends the line */
        size_t i = start;
        while (i < len && line[i] != ',') {
            ++i;
        }
        if (n == r->n_columns) {
            return fail_at(r, r->line_no, start + 1u, "long row: more than the header's %u fields",
                           r->n_columns);
        }
        fields[n++] = make_field(line, start, i);
        if (i == len) {
            break;
        }
        start = i + 1u;
    }
    if (n < r->n_columns) {
        return fail_at(r, r->line_no, r->line_len + 1u, "short row: %u fields, the header has %u",
                       n, r->n_columns);
    }
    memset(row, 0, sizeof *row);
    uint64_t v = 0;
    enum parse_result pr;
    const struct field *f = &fields[r->column_of[TRACE_COL_T_MS]];
    pr = parse_uint(f, UINT32_MAX, &v);
    if (pr != PARSE_OK) {
        return field_error(r, f, TRACE_COL_T_MS, pr, UINT32_MAX);
    }
    if (r->rows > 0u && v < r->last_t_ms) {
        return fail_at(r, r->line_no, f->col,
                       "t_ms %llu is earlier than the previous row's %lu (time went backwards)",
                       (unsigned long long)v, (unsigned long)r->last_t_ms);
    }
    row->t_ms = (uint32_t)v;
    for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
        const enum trace_column c = (enum trace_column)(TRACE_COL_A_MM + k);
        f = &fields[r->column_of[c]];
        pr = parse_uint(f, UINT16_MAX, &v);
        if (pr != PARSE_OK) {
            return field_error(r, f, c, pr, UINT16_MAX);
        }
        row->range_mm[k] = (uint16_t)v;
        const enum trace_column cs = (enum trace_column)(TRACE_COL_A_ST + k);
        row->status[k] = 0;
        if (r->column_of[cs] >= 0) {
            f = &fields[r->column_of[cs]];
            pr = parse_uint(f, UINT8_MAX, &v);
            if (pr != PARSE_OK) {
                return field_error(r, f, cs, pr, UINT8_MAX);
            }
            row->status[k] = (uint8_t)v;
        }
        row->present[k] = row->status[k] != SCENE_STATUS_NO_READING;
    }
    for (unsigned t = 0; t < 2u; ++t) {
        const enum trace_column c = t == 0u ? TRACE_COL_ALPHA : TRACE_COL_BETA;
        if (r->column_of[c] < 0) {
            continue;
        }
        f = &fields[r->column_of[c]];
        double d = 0.0;
        pr = parse_real(f, &d);
        if (pr == PARSE_EMPTY) {
            continue; /* truth may be empty (DESIGN.md §5) */
        }
        if (pr == PARSE_OK && !(fabs(d) <= 90.0)) {
            pr = PARSE_RANGE;
        }
        if (pr != PARSE_OK) {
            return field_error(r, f, c, pr, 0u);
        }
        if (t == 0u) {
            row->has_alpha = true;
            row->alpha_deg = d;
        } else {
            row->has_beta = true;
            row->beta_deg = d;
        }
    }
    r->last_t_ms = row->t_ms;
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
            return fail_at(r, r->line_no, 1u, "empty line (expected a sample row)");
        }
        if (r->line[0] == '#') {
            continue; /* a comment line (DESIGN.md §5) */
        }
        return parse_row(r, row);
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
