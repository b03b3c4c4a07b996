/* Trace format v1: host_sim's layer over the one reader (trace/trace_v1.h), and the writer. */
#include "scene/trace.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- reader: the host's input, messages and doubles around sim/'s reader ---- */

static int32_t read_file(void *ctx, unsigned char *buf, uint32_t len) {
    struct trace_reader *r = ctx;
    const size_t n = fread(buf, 1u, len, r->file);
    return n == 0u && ferror(r->file) ? -1 : (int32_t)n;
}

static int32_t read_mem(void *ctx, unsigned char *buf, uint32_t len) {
    struct trace_reader *r = ctx;
    const size_t left = r->mem_len - r->mem_pos;
    const size_t n = left < len ? left : len;
    if (n > 0u) {
        memcpy(buf, r->mem + r->mem_pos, n);
    }
    r->mem_pos += n;
    return (int32_t)n;
}

/* "name:line:col: what" from the core's failure. Returns -1. */
static int core_failed(struct trace_reader *r) {
    const struct trace_v1_error *e = &r->core.err;
    snprintf(r->err, sizeof r->err, "%s:%lu:%lu: %s", r->name, (unsigned long)e->line,
             (unsigned long)e->col, e->msg);
    return -1;
}

/*
 * A value the core read exactly in units of 10^-decimals, as the double strtod gives for
 * its text: units and 10^decimals are exact doubles (below 2^53), so their quotient is the
 * correctly rounded value. Any other value (more digits than the unit holds) is
 * converted from its text, as strtod alone can.
 */
static double to_double(int32_t units, bool exact, double scale, const char *text) {
    return exact ? (double)units / scale : strtod(text, NULL);
}

static void keep_meta(struct trace_reader *r) {
    const struct trace_v1_meta *m = &r->core.meta;
    const char *arm = trace_v1_meta(&r->core, "arm_mm");
    r->meta.arm_mm = to_double(m->arm_um, m->arm_exact, 1e3, arm);
    r->meta.period_ms = m->period_ms;
    r->meta.count = m->count;
    memcpy(r->meta.key, m->key, sizeof r->meta.key);
    memcpy(r->meta.value, m->value, sizeof r->meta.value);
    memcpy(r->meta.line, m->line, sizeof r->meta.line);
}

static int open_common(struct trace_reader *r, const char *name,
                       int32_t (*read)(void *, unsigned char *, uint32_t)) {
    const size_t name_len = strlen(name);
    if (name_len < sizeof r->name) {
        memcpy(r->name, name, name_len + 1u);
    } else {
        snprintf(r->name, sizeof r->name, "...%s", name + name_len - (sizeof r->name - 4u));
    }
    const struct trace_v1_input in = {.read = read, .ctx = r};
    const int rc = trace_v1_open(&r->core, in, r->block, sizeof r->block);
    r->bom = r->core.bom;
    if (rc != 0) {
        return core_failed(r);
    }
    keep_meta(r);
    return 0;
}

int trace_reader_open(struct trace_reader *r, FILE *file, const char *name) {
    memset(r, 0, sizeof *r);
    r->file = file;
    return open_common(r, name, read_file);
}

int trace_reader_open_mem(struct trace_reader *r, const void *data, size_t len, const char *name) {
    memset(r, 0, sizeof *r);
    r->mem = data;
    r->mem_len = data != NULL ? len : 0u;
    return open_common(r, name, read_mem);
}

int trace_reader_next(struct trace_reader *r, struct scene_row *row) {
    if (r->core.state != 0) {
        return r->core.state;
    }
    struct trace_v1_row v;
    const int rc = trace_v1_next(&r->core, &v);
    if (rc != 0) {
        return rc < 0 ? core_failed(r) : rc;
    }
    row->t_ms = v.t_ms;
    memcpy(row->range_mm, v.range_mm, sizeof row->range_mm);
    memcpy(row->status, v.status, sizeof row->status);
    memcpy(row->present, v.present, sizeof row->present);
    row->temp_present = v.temp_present;
    row->temp_cdeg = v.temp_cdeg;
    const char *line = r->core.line;
    row->has_alpha = v.has[TRACE_TRUTH_ALPHA];
    row->has_beta = v.has[TRACE_TRUTH_BETA];
    row->has_distance = v.has[TRACE_TRUTH_DISTANCE];
    row->alpha_deg = 0.0;
    row->beta_deg = 0.0;
    row->distance_mm = 0.0;
    if (row->has_alpha) {
        row->alpha_deg = to_double(v.truth[TRACE_TRUTH_ALPHA], v.exact[TRACE_TRUTH_ALPHA], 1e6,
                                   line + v.truth_at[TRACE_TRUTH_ALPHA]);
    }
    if (row->has_beta) {
        row->beta_deg = to_double(v.truth[TRACE_TRUTH_BETA], v.exact[TRACE_TRUTH_BETA], 1e6,
                                  line + v.truth_at[TRACE_TRUTH_BETA]);
    }
    if (row->has_distance) {
        row->distance_mm = to_double(v.truth[TRACE_TRUTH_DISTANCE], v.exact[TRACE_TRUTH_DISTANCE],
                                     1e3, line + v.truth_at[TRACE_TRUTH_DISTANCE]);
    }
    r->rows = r->core.rows;
    r->last_row_line = r->core.last_row_line;
    return 0;
}

const char *trace_reader_error(const struct trace_reader *r) {
    return r->err;
}

const char *trace_reader_meta(const struct trace_reader *r, const char *key) {
    return trace_v1_meta(&r->core, key);
}

unsigned long trace_reader_meta_line(const struct trace_reader *r, const char *key) {
    return trace_v1_meta_line(&r->core, key);
}

const struct trace_timing *trace_reader_timing(const struct trace_reader *r) {
    return &r->core.timing;
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
            snprintf(r->err, sizeof r->err, "%s:%lu:1: more than %zu rows", r->name,
                     (unsigned long)r->core.line_no, max_rows);
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
    while (trace_v1_key_char(kv[i])) {
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
