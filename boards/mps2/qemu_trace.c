/* The QEMU replay image's trace input: semihosting under sim/'s trace v1 reader (qemu_trace.h). */
#include "qemu_trace.h"

#include <string.h>

#include "firmware/config.h"
#include "firmware/text.h"
#include "semihost.h"

_Static_assert((int)TRACE_MODE_SHORT == (int)VL53_DISTANCE_SHORT &&
                   (int)TRACE_MODE_LONG == (int)VL53_DISTANCE_LONG,
               "trace/trace_v1.h's modes carry the driver's numbers");

static int fail(struct qemu_trace *t, uint32_t line, uint32_t col, const char *what) {
    struct tof_text out;
    tof_text_init(&out, t->error, sizeof t->error);
    tof_text_str(&out, t->path);
    tof_text_str(&out, ":");
    tof_text_u64(&out, line);
    tof_text_str(&out, ":");
    tof_text_u64(&out, col);
    tof_text_str(&out, ": ");
    tof_text_str(&out, what);
    return -1;
}

static int reader_failed(struct qemu_trace *t) {
    return fail(t, t->reader.err.line, t->reader.err.col, t->reader.err.msg);
}

static int32_t read_semihost(void *ctx, unsigned char *buf, uint32_t len) {
    const struct qemu_trace *t = ctx;
    return semihost_read(t->handle, buf, len);
}

/* What the image needs of the metadata: arm_mm in whole µm, period_ms 1..10000, and the
 * distance mode by sim/'s policy with no evidence yet. 0, or -1 with t->error. */
static int read_meta(struct qemu_trace *t) {
    const struct trace_v1_meta *m = &t->reader.meta;
    if (!m->arm_exact) {
        return fail(t, trace_v1_meta_line(&t->reader, "arm_mm"), 1u,
                    "arm_mm is not a length in whole micrometres");
    }
    t->arm_um = m->arm_um;
    t->period_ms = t->reader.timing.period_ms; /* or TRACE_DEFAULT_PERIOD_MS */
    if (t->period_ms > 10000u) {
        return fail(t, trace_v1_meta_line(&t->reader, "period_ms"), 1u,
                    "period_ms is not 1..10000");
    }
    const char *stated = trace_v1_meta(&t->reader, "distance_mode");
    enum vl53_distance_mode mode = VL53_DISTANCE_SHORT;
    if (stated != NULL && !vl53_distance_mode_from_name(stated, &mode)) {
        return fail(t, trace_v1_meta_line(&t->reader, "distance_mode"), 1u,
                    "distance_mode is not short or long");
    }
    t->stated = stated != NULL ? (enum trace_mode)mode : TRACE_MODE_UNSTATED;
    t->long_fits = tof_app_replay_mode_fits(t->period_ms, VL53_DISTANCE_LONG);
    t->mode = (enum vl53_distance_mode)trace_mode_choose(TRACE_MODE_UNSTATED, t->stated, NULL,
                                                         t->long_fits)
                  .mode;
    t->evidence = (struct trace_mode_evidence){.short_max_mm = VL53_RANGE_MAX_SHORT_MM,
                                               .long_max_mm = VL53_RANGE_MAX_LONG_MM};
    return 0;
}

int qemu_trace_open(struct qemu_trace *t, const char *path) {
    memset(t, 0, sizeof *t);
    t->path = path;
    t->handle = semihost_open(path, SEMIHOST_MODE_READ_BINARY);
    if (t->handle < 0) {
        return fail(t, 0, 0, "cannot open");
    }
    const struct trace_v1_input in = {.read = read_semihost, .ctx = t};
    if (trace_v1_open(&t->reader, in, t->block, sizeof t->block) != 0) {
        return reader_failed(t);
    }
    return read_meta(t);
}

/* 1-based column of field `field` of the reader's current line. */
static uint32_t field_column(const struct trace_v1_reader *r, int field) {
    uint32_t col = 1;
    for (uint32_t i = 0; i < r->line_len && field > 0; ++i) {
        if (r->line[i] == ',') {
            --field;
            col = i + 2u;
        }
    }
    return col;
}

/* The row's readings as evidence: one that would make sim/'s policy choose other than
 * the mode the image runs is an error, since host_sim, reading ahead, would. */
static int check_mode(struct qemu_trace *t, const struct trace_v1_row *row) {
    const uint64_t before = t->evidence.count;
    trace_mode_evidence_add(&t->evidence, row, t->reader.last_row_line);
    if (before != 0u || t->evidence.count == 0u ||
        trace_mode_choose(TRACE_MODE_UNSTATED, t->stated, &t->evidence, t->long_fits).mode ==
            (enum trace_mode)t->mode) {
        return 0;
    }
    const int field = t->reader.column_of[TRACE_COL_A_MM + t->evidence.first_sensor];
    return fail(t, t->reader.last_row_line, field_column(&t->reader, field),
                "a reading only long mode reports, and no '# distance_mode=': "
                "state it (host_sim chooses long for this trace)");
}

/* The next row into the ring. 0, 1 at the end, or -1 with t->error. */
static int read_row(struct qemu_trace *t) {
    struct trace_v1_row v;
    const int rc = trace_v1_next(&t->reader, &v);
    if (rc != 0) {
        return rc < 0 ? reader_failed(t) : 1;
    }
    if (check_mode(t, &v) != 0) {
        return -1;
    }
    struct qemu_trace_row *row = &t->ring[t->rows % QEMU_TRACE_RING];
    row->t_ms = v.t_ms;
    memcpy(row->range_mm, v.range_mm, sizeof row->range_mm);
    memcpy(row->status, v.status, sizeof row->status);
    ++t->rows;
    return 0;
}

int qemu_trace_row(struct qemu_trace *t, uint32_t index, const struct qemu_trace_row **row) {
    if (t->error[0] != '\0') {
        return -1;
    }
    for (uint32_t guard = 0; index >= t->rows && !t->done && guard < QEMU_TRACE_RING; ++guard) {
        const int rc = read_row(t);
        if (rc < 0) {
            return -1;
        }
        t->done = rc == 1;
    }
    if (index >= t->rows) {
        return t->done ? 1 : fail(t, 0, 0, "row requested too far ahead");
    }
    if (index + QEMU_TRACE_RING < t->rows) {
        return fail(t, 0, 0, "row no longer held");
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
    const bool missing =
        row->status[sensor] == TRACE_STATUS_NO_READING; /* docs/reference/trace-format.md */
    *out = (struct sim_range){.distance_mm = row->range_mm[sensor],
                              .range_status = missing ? 0u : row->status[sensor],
                              .present = !missing};
    return 0;
}

static const struct sim_range_source_ops source_ops = {.next = source_next};

struct sim_range_source qemu_trace_source(struct qemu_trace *t) {
    return (struct sim_range_source){.ops = &source_ops, .ctx = t};
}
