/* Trace v1 fields and rows: the one integer and the one decimal scanner, the row parser. */
#include <string.h>

#include "trace_v1_impl.h"

const char *const trace_v1_column_names[TRACE_COL_COUNT] = {
    "t_ms", "a_mm", "b_mm",      "c_mm",     "d_mm",        "a_st",   "b_st",
    "c_st", "d_st", "alpha_deg", "beta_deg", "distance_mm", "temp_c",
};

enum parse_result { PARSE_OK, PARSE_EMPTY, PARSE_SYNTAX, PARSE_NEGATIVE, PARSE_RANGE };

static bool is_blank(char c) {
    return c == ' ' || c == '\t';
}

static bool is_digit(char c) {
    return c >= '0' && c <= '9';
}

struct trace_field trace_v1_make_field(const char *line, size_t start, size_t end) {
    size_t b = start;
    while (b < end && is_blank(line[b])) {
        ++b;
    }
    size_t e = end;
    while (e > b && is_blank(line[e - 1u])) {
        --e;
    }
    struct trace_field f = {line + b, e - b, (b < end ? b : start) + 1u};
    return f;
}

/*
 * The scanners read NUL-terminated text (the reader's line always is, and it refuses a
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

/* A decimal read exactly in units of 10^-decimals (truncated toward zero). */
struct decimal {
    uint64_t units; /* |value|, below DECIMAL_CAP unless over */
    bool over;      /* |value| >= DECIMAL_CAP units */
    bool below;     /* nonzero digits below the unit */
    bool round_up;  /* the first digit below the unit is 5 or more */
    bool negative;
    bool nonzero; /* some digit is not 0 */
};

#define DECIMAL_CAP 1000000000000000000u /* 10^18 units: beyond any value a trace may hold */

static inline void decimal_digit(struct decimal *d, unsigned digit, long q) {
    d->nonzero = d->nonzero || digit != 0u;
    if (q >= 0) {
        if (d->units > (DECIMAL_CAP - digit) / 10u) {
            d->over = true;
        } else if (!d->over) {
            d->units = d->units * 10u + digit;
        }
    } else {
        d->round_up = q == -1 ? digit >= 5u : d->round_up;
        d->below = d->below || digit != 0u;
    }
}

/* The value of the checked text [int_start, end) with exponent e, each digit placed by its
 * power of ten relative to the unit (q = 0: the unit's digit). */
static inline void decimal_value(const char *int_start, const char *end, long e, unsigned decimals,
                                 struct decimal *d) {
    long n_int = 0;
    while (is_digit(int_start[n_int])) {
        ++n_int;
    }
    long q = n_int - 1 + e + (long)decimals;
    for (const char *c = int_start; c < end; ++c) {
        if (is_digit(*c)) {
            decimal_digit(d, (unsigned)(*c - '0'), q--);
        }
    }
    for (; q >= 0 && d->units != 0u && !d->over; --q) { /* zeros the exponent adds */
        if (d->units > DECIMAL_CAP / 10u) {
            d->over = true;
        } else {
            d->units *= 10u;
        }
    }
    d->over = d->over || d->units >= DECIMAL_CAP;
}

/*
 * The one decimal parser. The field at *pp: blanks, then
 * [+-]digits[.digits][(e|E)[+-]digits] or [+-].digits[...], then blanks. Exact: no digit
 * is lost, only noted (below, round_up) when it is finer than the unit. On PARSE_OK *pp is
 * left at the field's ',' or end.
 */
static inline __attribute__((always_inline)) enum parse_result
scan_decimal(const char **pp, unsigned decimals, struct decimal *d) {
    const char *p = skip_blanks(*pp);
    if (at_field_end(p)) {
        return PARSE_EMPTY;
    }
    *d = (struct decimal){0};
    if (*p == '+' || *p == '-') {
        d->negative = *p == '-';
        ++p;
    }
    const char *const int_start = p;
    uint64_t mantissa = 0; /* all digits as one integer: exact up to 19 of them */
    for (; is_digit(*p); ++p) {
        mantissa = mantissa * 10u + (uint64_t)(*p - '0');
    }
    size_t digits = (size_t)(p - int_start);
    size_t frac_digits = 0;
    if (*p == '.') {
        const char *const frac_start = ++p;
        for (; is_digit(*p); ++p) {
            mantissa = mantissa * 10u + (uint64_t)(*p - '0');
        }
        frac_digits = (size_t)(p - frac_start);
        digits += frac_digits;
    }
    if (digits == 0u) {
        return PARSE_SYNTAX;
    }
    const char *const digits_end = p;
    long e = 0;
    if (*p == 'e' || *p == 'E') {
        ++p;
        bool exp_negative = false;
        if (*p == '+' || *p == '-') {
            exp_negative = *p == '-';
            ++p;
        }
        const char *const exp_start = p;
        for (; is_digit(*p); ++p) {
            e = e < 100000 ? e * 10 + (*p - '0') : e; /* saturated far beyond any value */
        }
        if (p == exp_start) {
            return PARSE_SYNTAX;
        }
        e = exp_negative ? -e : e;
    }
    if (!at_field_end(p)) {
        p = skip_blanks(p);
        if (!at_field_end(p)) {
            return PARSE_SYNTAX;
        }
    }
    if (e == 0 && decimals <= 6u && frac_digits <= decimals &&
        digits + (decimals - frac_digits) < 18u) {
        /* What traces hold (the writer's 6 decimals): the digits as one integer, scaled to
         * the unit (decimals <= 6); the general path below places each digit. */
        static const uint64_t pow10[7] = {1u, 10u, 100u, 1000u, 10000u, 100000u, 1000000u};
        d->units = mantissa * pow10[decimals - frac_digits]; /* below 10^17: exact */
        d->nonzero = mantissa != 0u;
        *pp = p;
        return PARSE_OK;
    }
    decimal_value(int_start, digits_end, e, decimals, d);
    *pp = p;
    return PARSE_OK;
}

int trace_v1_meta_uint(const struct trace_field *f, uint64_t max, uint64_t *out) {
    const char *p = f->s;
    return scan_uint(&p, max, out) == PARSE_OK && *p == '\0' && *out > 0u ? 0 : -1;
}

int trace_v1_meta_positive(const struct trace_field *f, unsigned decimals, int32_t *units,
                           bool *exact) {
    const char *p = f->s;
    struct decimal d;
    if (scan_decimal(&p, decimals, &d) != PARSE_OK || *p != '\0' || d.negative || d.over ||
        !d.nonzero) {
        return -1;
    }
    const uint64_t v = d.units + d.round_up;
    /* Positive but below half a unit (3e-400): every layer above would read 0, which is
     * not a positive value (a host's strtod underflows to 0.0). */
    if (v == 0u) {
        return -1;
    }
    *units = v > (uint64_t)INT32_MAX ? INT32_MAX : (int32_t)v;
    *exact = !d.below && v <= (uint64_t)INT32_MAX;
    return 0;
}

int trace_v1_list_decimal(const char **pp, unsigned decimals, int64_t max_units, int64_t *units) {
    struct decimal d;
    if (scan_decimal(pp, decimals, &d) != PARSE_OK || d.over) {
        return -1;
    }
    const uint64_t v = d.units + d.round_up; /* half away from zero */
    if (v > (uint64_t)max_units) {
        return -1;
    }
    *units = d.negative ? -(int64_t)v : (int64_t)v;
    return 0;
}

/* ---- rows ---- */

/* The largest magnitude of each truth value, in its unit: 90 degrees, 65,535 mm. */
static const uint32_t truth_max[TRACE_TRUTHS] = {90000000u, 90000000u, 65535000u};
static const unsigned truth_decimals[TRACE_TRUTHS] = {6u, 6u, 3u};

static int field_error(struct trace_v1_reader *r, const struct trace_field *f, enum trace_column c,
                       enum parse_result pr, uint64_t max) {
    const char *name = trace_v1_column_names[c];
    const bool truth = c >= TRACE_COL_ALPHA;
    struct trace_msg m = trace_msg_begin(r, r->line_no, (uint32_t)f->col);
    trace_msg_str(&m, name);
    switch (pr) {
    case PARSE_EMPTY:
        trace_msg_str(&m, ": empty value");
        return trace_msg_fail(r);
    case PARSE_NEGATIVE:
        trace_msg_str(&m, c >= TRACE_COL_A_MM && c <= TRACE_COL_D_MM ? ": negative range '"
                                                                     : ": negative value '");
        trace_msg_quote(&m, f->s, f->len);
        trace_msg_str(&m, "'");
        return trace_msg_fail(r);
    case PARSE_RANGE:
        trace_msg_str(&m, ": '");
        trace_msg_quote(&m, f->s, f->len);
        if (c == TRACE_COL_ALPHA || c == TRACE_COL_BETA) {
            trace_msg_str(&m, "' out of range -90..90 degrees");
        } else if (c == TRACE_COL_TEMP) {
            trace_msg_str(&m, "' out of range -100..200 degrees C");
        } else {
            trace_msg_str(&m, "' out of range 0..");
            trace_msg_u64(&m, max);
            trace_msg_str(&m, c == TRACE_COL_DISTANCE ? " mm" : "");
        }
        return trace_msg_fail(r);
    case PARSE_SYNTAX:
    case PARSE_OK:
    default:
        break;
    }
    trace_msg_str(&m, truth ? ": expected a number, got '" : ": expected an integer, got '");
    trace_msg_quote(&m, f->s, f->len);
    trace_msg_str(&m, "'");
    return trace_msg_fail(r);
}

/* The field that starts at line[start] (up to its ',' or the end), trimmed. */
static struct trace_field field_at(const struct trace_v1_reader *r, size_t start) {
    const char *comma = memchr(r->line + start, ',', r->line_len - start);
    const size_t end = comma != NULL ? (size_t)(comma - r->line) : r->line_len;
    return trace_v1_make_field(r->line, start, end);
}

/* A row with other than the header's number of fields, whatever else is wrong with it. */
static int check_field_count(struct trace_v1_reader *r) {
    unsigned n = 1;
    for (const char *c = memchr(r->line, ',', r->line_len); c != NULL;
         c = memchr(c + 1, ',', r->line_len - (size_t)(c + 1 - r->line))) {
        if (n == r->n_columns) {
            struct trace_msg m = trace_msg_begin(r, r->line_no, (uint32_t)(c - r->line) + 2u);
            trace_msg_str(&m, "long row: more than the header's ");
            trace_msg_u64(&m, r->n_columns);
            trace_msg_str(&m, " fields");
            return trace_msg_fail(r);
        }
        ++n;
    }
    if (n < r->n_columns) {
        struct trace_msg m = trace_msg_begin(r, r->line_no, r->line_len + 1u);
        trace_msg_str(&m, "short row: ");
        trace_msg_u64(&m, n);
        trace_msg_str(&m, " fields, the header has ");
        trace_msg_u64(&m, r->n_columns);
        return trace_msg_fail(r);
    }
    return 0;
}

/* Notes a time stamp that repeats the previous one or jumps more than two periods. */
static void check_timing(struct trace_v1_reader *r, uint32_t t_ms) {
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

/* A truth field: empty is allowed (docs/reference/trace-format.md); a value beyond its range is an
 * error. */
static inline __attribute__((always_inline)) enum parse_result
scan_truth(const char **pp, unsigned t, size_t at, struct trace_v1_row *row) {
    struct decimal d;
    enum parse_result pr = scan_decimal(pp, truth_decimals[t], &d);
    if (pr == PARSE_EMPTY) {
        *pp = skip_blanks(*pp);
        return PARSE_OK;
    }
    if (pr != PARSE_OK) {
        return pr;
    }
    const uint32_t max = truth_max[t];
    if (d.over || d.units > max || (d.units == max && d.below) ||
        (t == TRACE_TRUTH_DISTANCE && d.negative && d.nonzero)) {
        return PARSE_RANGE;
    }
    const int32_t v = (int32_t)(d.units + (d.below && d.round_up ? 1u : 0u));
    row->has[t] = true;
    row->exact[t] = !d.below && !(d.negative && v == 0); /* "-0": a host keeps its sign */
    row->truth[t] = d.negative ? -v : v;
    row->truth_at[t] = (uint16_t)at;
    return PARSE_OK;
}

/* temp_c: empty is allowed (no temperature for this row); a value beyond
 * TRACE_TEMP_MIN_C..TRACE_TEMP_MAX_C is an error. */
static enum parse_result scan_temp(const char **pp, struct trace_v1_row *row) {
    int64_t cdeg = 0;
    const char *p = skip_blanks(*pp);
    if (at_field_end(p)) {
        *pp = p;
        return PARSE_OK;
    }
    struct decimal d;
    const enum parse_result pr = scan_decimal(pp, 2u, &d);
    if (pr != PARSE_OK) {
        return pr;
    }
    const uint64_t v = d.units + (d.below && d.round_up ? 1u : 0u); /* half away from zero */
    const uint64_t max =
        d.negative ? (uint64_t)-TRACE_TEMP_MIN_C * 100u : (uint64_t)TRACE_TEMP_MAX_C * 100u;
    if (d.over || v > max) {
        return PARSE_RANGE;
    }
    cdeg = d.negative ? -(int64_t)v : (int64_t)v;
    row->temp_present = true;
    row->temp_cdeg = (int16_t)cdeg;
    return PARSE_OK;
}

/* One field of the row as column use (its trace_column + 1, 0 unknown) says; *max is the
 * field's largest value, for its message. A switch, as the row parser's hot path. */
static inline __attribute__((always_inline)) enum parse_result
scan_field(const char **pp, unsigned use, size_t at, struct trace_v1_row *row, uint64_t *max) {
    uint64_t v = 0;
    enum parse_result pr = PARSE_OK;
    switch (use) {
    case 0u: /* a column this reader does not use */
        while (!at_field_end(*pp)) {
            ++*pp;
        }
        break;
    case TRACE_COL_T_MS + 1u:
        *max = UINT32_MAX;
        pr = scan_uint(pp, *max, &v);
        row->t_ms = (uint32_t)v;
        break;
    case TRACE_COL_A_MM + 1u:
    case TRACE_COL_B_MM + 1u:
    case TRACE_COL_C_MM + 1u:
    case TRACE_COL_D_MM + 1u:
        *max = UINT16_MAX;
        pr = scan_uint(pp, *max, &v);
        row->range_mm[use - 1u - TRACE_COL_A_MM] = (uint16_t)v;
        break;
    case TRACE_COL_A_ST + 1u:
    case TRACE_COL_B_ST + 1u:
    case TRACE_COL_C_ST + 1u:
    case TRACE_COL_D_ST + 1u:
        *max = UINT8_MAX;
        pr = scan_uint(pp, *max, &v);
        row->status[use - 1u - TRACE_COL_A_ST] = (uint8_t)v;
        break;
    case TRACE_COL_TEMP + 1u:
        pr = scan_temp(pp, row);
        break;
    default: /* alpha_deg, beta_deg, distance_mm */
        *max = use == TRACE_COL_DISTANCE + 1u ? UINT16_MAX : 90u;
        pr = scan_truth(pp, use - 1u - TRACE_COL_ALPHA, at, row);
        break;
    }
    return pr;
}

/* The field that failed (pr, at start), or the row's wrong field count first. -1. */
static int row_error(struct trace_v1_reader *r, const char *start, unsigned use,
                     enum parse_result pr, uint64_t max) {
    if (check_field_count(r) != 0) {
        return -1;
    }
    const struct trace_field f = field_at(r, (size_t)(start - r->line));
    return field_error(r, &f, (enum trace_column)(use - 1u), pr, max);
}

/*
 * The one row parser: a single pass over the line, each field read as the header says
 * (column_use), with the one integer and the one decimal parser. The first field that is
 * wrong, from the left, is the error; a row with the wrong number of fields is reported
 * as such first, whatever else is wrong with it.
 */
int trace_v1_parse_row(struct trace_v1_reader *r, struct trace_v1_row *row) {
    const char *const line = r->line;
    const char *p = line;
    const char *t_start = line; /* the t_ms field, for its message */
    memset(row, 0, sizeof *row);
    /* Bounded: each turn passes a ',' of the line or ends. */
    for (unsigned n = 0;; ++n) {
        const char *const start = p;
        const unsigned use = r->column_use[n];
        uint64_t max = 0;
        const enum parse_result pr = scan_field(&p, use, (size_t)(start - line), row, &max);
        if (pr != PARSE_OK) {
            return row_error(r, start, use, pr, max);
        }
        t_start = use == TRACE_COL_T_MS + 1u ? start : t_start;
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
        const struct trace_field f = field_at(r, (size_t)(t_start - line));
        struct trace_msg m = trace_msg_begin(r, r->line_no, (uint32_t)f.col);
        trace_msg_str(&m, "t_ms ");
        trace_msg_u64(&m, row->t_ms);
        trace_msg_str(&m, " is earlier than the previous row's ");
        trace_msg_u64(&m, r->last_t_ms);
        trace_msg_str(&m, " (time went backwards)");
        return trace_msg_fail(r);
    }
    for (unsigned k = 0; k < 4u; ++k) {
        row->present[k] = row->status[k] != TRACE_STATUS_NO_READING;
    }
    if (r->rows > 0u) {
        check_timing(r, row->t_ms);
    }
    r->last_t_ms = row->t_ms;
    r->last_row_line = r->line_no;
    r->rows++;
    return 0;
}
