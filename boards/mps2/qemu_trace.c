#include "qemu_trace.h"

#include <string.h>

#include "firmware/text.h"
#include "semihost.h"
#include "vl53/vl53.h"

static int fail(struct qemu_trace *t, uint32_t col, const char *what) {
    struct tof_text out;
    tof_text_init(&out, t->error, sizeof t->error);
    tof_text_str(&out, t->path);
    tof_text_str(&out, ":");
    tof_text_u64(&out, t->line_no);
    tof_text_str(&out, ":");
    tof_text_u64(&out, col);
    tof_text_str(&out, ": ");
    tof_text_str(&out, what);
    return -1;
}

/* Next line into t->line. 1 with a line, 0 at the end, -1 on an error. */
static int next_line(struct qemu_trace *t) {
    uint32_t len = 0;
    bool any = false;
    for (uint32_t guard = 0; guard <= QEMU_TRACE_LINE + 1u; ++guard) {
        if (t->block_pos == t->block_len) {
            if (t->eof) {
                break;
            }
            const int n = semihost_read(t->handle, t->block, sizeof t->block);
            if (n < 0) {
                ++t->line_no;
                return fail(t, 1, "read error");
            }
            t->block_len = (uint32_t)n;
            t->block_pos = 0;
            if (n == 0) {
                t->eof = true;
                break;
            }
        }
        const char c = t->block[t->block_pos++];
        any = true;
        if (c == '\n') {
            break;
        }
        if (c == '\0') {
            ++t->line_no;
            return fail(t, len + 1u, "NUL byte");
        }
        if (len == QEMU_TRACE_LINE) {
            ++t->line_no;
            return fail(t, len + 1u, "line too long");
        }
        t->line[len++] = c;
        guard = 0; /* the bound is per character: a line ends within LINE + 1 of them */
    }
    if (!any) {
        return 0;
    }
    if (len > 0u && t->line[len - 1u] == '\r') {
        --len;
    }
    t->line[len] = '\0';
    ++t->line_no;
    return 1;
}

/* Parse a non-negative decimal integer field [s, s+len) into *v (<= max). */
static bool parse_uint(const char *s, uint32_t len, uint32_t max, uint32_t *v) {
    if (len == 0u || len > 10u) {
        return false;
    }
    uint64_t acc = 0;
    for (uint32_t i = 0; i < len; ++i) {
        if (s[i] < '0' || s[i] > '9') {
            return false;
        }
        acc = acc * 10u + (uint64_t)(s[i] - '0');
    }
    if (acc > max) {
        return false;
    }
    *v = (uint32_t)acc;
    return true;
}

/* "30", "30.0", "29.5": millimetres with up to three decimals, as micrometres. */
static bool parse_mm_as_um(const char *s, int32_t *um) {
    uint32_t whole = 0;
    uint32_t i = 0;
    while (s[i] >= '0' && s[i] <= '9' && i < 7u) {
        whole = whole * 10u + (uint32_t)(s[i] - '0');
        ++i;
    }
    if (i == 0u) {
        return false;
    }
    uint32_t frac = 0;
    uint32_t scale = 1000u;
    if (s[i] == '.') {
        ++i;
        for (uint32_t d = 0; s[i] >= '0' && s[i] <= '9'; ++d, ++i) {
            if (d < 3u) {
                scale /= 10u;
                frac += (uint32_t)(s[i] - '0') * scale;
            } else if (s[i] != '0') {
                return false; /* finer than a micrometre: not representable here */
            }
        }
    }
    if (s[i] != '\0') {
        return false;
    }
    *um = (int32_t)(whole * 1000u + frac);
    return true;
}

static const char *const column_names[9] = {"t_ms", "a_mm", "b_mm", "c_mm", "d_mm",
                                            "a_st", "b_st", "c_st", "d_st"};

static int parse_header(struct qemu_trace *t) {
    int8_t *slots[9] = {&t->col_t,         &t->col_range[0],  &t->col_range[1],
                        &t->col_range[2],  &t->col_range[3],  &t->col_status[0],
                        &t->col_status[1], &t->col_status[2], &t->col_status[3]};
    for (unsigned k = 0; k < 9u; ++k) {
        *slots[k] = -1;
    }
    uint32_t col = 0;
    const char *s = t->line;
    for (uint32_t pos = 0; col < 64u; ++col) {
        uint32_t end = pos;
        while (s[end] != ',' && s[end] != '\0') {
            ++end;
        }
        for (unsigned k = 0; k < 9u; ++k) {
            if (strlen(column_names[k]) == end - pos &&
                strncmp(column_names[k], s + pos, end - pos) == 0) {
                *slots[k] = (int8_t)col;
            }
        }
        if (s[end] == '\0') {
            break;
        }
        pos = end + 1u;
    }
    t->columns = (uint8_t)(col + 1u);
    for (unsigned k = 0; k < 5u; ++k) {
        if (*slots[k] < 0) {
            return fail(t, 1, "missing column");
        }
    }
    return 0;
}

int qemu_trace_open(struct qemu_trace *t, const char *path) {
    memset(t, 0, sizeof *t);
    t->path = path;
    t->period_ms = 20;
    t->handle = semihost_open(path, SEMIHOST_MODE_READ_BINARY);
    if (t->handle < 0) {
        return fail(t, 0, "cannot open");
    }
    int rc = next_line(t);
    if (rc <= 0 || strcmp(t->line, "# tof-trace v1") != 0) {
        return rc < 0 ? -1 : fail(t, 1, "first line must be '# tof-trace v1'");
    }
    bool have_arm = false;
    for (uint32_t n = 0; n < 64u; ++n) {
        rc = next_line(t);
        if (rc <= 0) {
            return rc < 0 ? -1 : fail(t, 1, "no header line");
        }
        if (t->line[0] != '#') {
            if (!have_arm) {
                return fail(t, 1, "missing arm_mm");
            }
            return parse_header(t);
        }
        const char *kv = t->line + 1;
        while (*kv == ' ') {
            ++kv;
        }
        if (strncmp(kv, "arm_mm=", 7) == 0) {
            if (!parse_mm_as_um(kv + 7, &t->arm_um)) {
                return fail(t, (uint32_t)(kv - t->line) + 8u, "arm_mm is not a length in mm");
            }
            have_arm = true;
        } else if (strncmp(kv, "distance_mode=", 14) == 0) {
            const char *v = kv + 14;
            enum vl53_distance_mode mode;
            if (!vl53_distance_mode_from_name(v, &mode)) {
                return fail(t, (uint32_t)(v - t->line) + 1u, "distance_mode is not short or long");
            }
            t->distance_mode = (uint8_t)mode;
        } else if (strncmp(kv, "period_ms=", 10) == 0) {
            const char *v = kv + 10;
            if (!parse_uint(v, (uint32_t)strlen(v), 10000u, &t->period_ms) || t->period_ms == 0u) {
                return fail(t, (uint32_t)(v - t->line) + 1u, "period_ms is not 1..10000");
            }
        }
    }
    return fail(t, 1, "too many metadata lines");
}

/* Parse the current line as row number t->rows. 0, or -1 with t->error. */
static int parse_row(struct qemu_trace *t) {
    struct qemu_trace_row row = {0};
    uint32_t col = 0;
    uint32_t pos = 0;
    const char *s = t->line;
    for (; col < t->columns; ++col) {
        uint32_t end = pos;
        while (s[end] != ',' && s[end] != '\0') {
            ++end;
        }
        uint32_t v = 0;
        const uint32_t len = end - pos;
        if ((int)col == t->col_t) {
            if (!parse_uint(s + pos, len, UINT32_MAX, &v)) {
                return fail(t, pos + 1u, "t_ms is not a non-negative integer");
            }
            row.t_ms = v;
        }
        for (unsigned k = 0; k < 4u; ++k) {
            if ((int)col == t->col_range[k] && !parse_uint(s + pos, len, 65535u, &v)) {
                return fail(t, pos + 1u, "range is not an integer 0..65535 mm");
            }
            if ((int)col == t->col_range[k]) {
                row.range_mm[k] = (uint16_t)v;
                if (t->long_fits && v > VL53_RANGE_MAX_SHORT_MM && v <= VL53_RANGE_MAX_LONG_MM) {
                    return fail(t, pos + 1u,
                                "a reading only long mode reports, and no '# distance_mode=': "
                                "state it (host_sim chooses long for this trace)");
                }
            }
            if ((int)col == t->col_status[k] && len > 0u) {
                if (!parse_uint(s + pos, len, 255u, &v)) {
                    return fail(t, pos + 1u, "status is not an integer 0..255");
                }
                row.status[k] = (uint8_t)v;
            }
        }
        if (s[end] == '\0') {
            break;
        }
        pos = end + 1u;
    }
    if (col + 1u != t->columns || s[pos - 1u] == '\0') {
        return fail(t, pos + 1u, col + 1u < t->columns ? "short row" : "long row");
    }
    if (t->rows > 0u && row.t_ms < t->ring[(t->rows - 1u) % QEMU_TRACE_RING].t_ms) {
        return fail(t, (uint32_t)t->col_t + 1u, "time goes backwards");
    }
    t->ring[t->rows % QEMU_TRACE_RING] = row;
    ++t->rows;
    return 0;
}

int qemu_trace_row(struct qemu_trace *t, uint32_t index, const struct qemu_trace_row **row) {
    if (t->error[0] != '\0') {
        return -1;
    }
    for (uint32_t guard = 0; index >= t->rows && !t->done && guard < QEMU_TRACE_RING; ++guard) {
        const int rc = next_line(t);
        if (rc < 0) {
            return -1;
        }
        if (rc == 0) {
            t->done = true;
        } else if (t->line[0] != '#' && parse_row(t) != 0) {
            return -1;
        }
    }
    if (index >= t->rows) {
        return t->done ? 1 : fail(t, 0, "row requested too far ahead");
    }
    if (index + QEMU_TRACE_RING < t->rows) {
        return fail(t, 0, "row no longer held");
    }
    *row = &t->ring[index % QEMU_TRACE_RING];
    return 0;
}

static int source_next(void *ctx, unsigned sensor, uint32_t sample_index, struct sim_range *out) {
    const struct qemu_trace_row *row = NULL;
    const int rc = qemu_trace_row(ctx, sample_index, &row);
    if (rc != 0) {
        return rc;
    }
    const bool missing = row->status[sensor] == 255u; /* no reading (docs/traces.md) */
    *out = (struct sim_range){.distance_mm = row->range_mm[sensor],
                              .range_status = missing ? 0u : row->status[sensor],
                              .present = !missing};
    return 0;
}

static const struct sim_range_source_ops source_ops = {.next = source_next};

struct sim_range_source qemu_trace_source(struct qemu_trace *t) {
    return (struct sim_range_source){.ops = &source_ops, .ctx = t};
}
