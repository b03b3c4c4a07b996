/*
 * The QEMU replay image's trace input: trace v1 (docs/reference/trace-format.md) read through
 * semihosting by the one trace v1 reader (trace/trace_v1.h), so its rules and messages
 * ("file:line:column: what") are host_sim's. It keeps the last rows in a ring for the
 * device models and the output, and chooses the parts' distance mode by sim/'s policy
 * (trace_mode_choose) with the evidence read so far: it cannot read the trace ahead as
 * host_sim does, so a reading that would make the policy choose long when the trace
 * does not state its mode is an error, and the two never differ in silence.
 */
#ifndef BOARDS_MPS2_QEMU_TRACE_H
#define BOARDS_MPS2_QEMU_TRACE_H

#include <stdbool.h>
#include <stdint.h>

#include "sim/range_source.h"
#include "trace/trace_v1.h"
#include "vl53/vl53.h"

#define QEMU_TRACE_RING 64u /* rows kept for the device models and the output */

struct qemu_trace_row {
    uint32_t t_ms;
    uint16_t range_mm[4];
    uint8_t status[4];
};

struct qemu_trace {
    int handle;
    const char *path;
    unsigned char block[512];
    struct trace_v1_reader reader;
    int32_t arm_um;
    uint32_t period_ms;
    enum trace_mode stated;              /* the trace's distance_mode, or unstated */
    bool long_fits;                      /* the period admits a long-mode budget */
    enum vl53_distance_mode mode;        /* the parts' mode, chosen at open */
    struct trace_mode_evidence evidence; /* readings only long mode reports, so far */
    struct qemu_trace_row ring[QEMU_TRACE_RING];
    uint32_t rows;   /* rows parsed so far (row i is in ring[i % RING] if i + RING > rows) */
    bool done;       /* end of file reached */
    char error[320]; /* non-empty after an error: "file:line:col: what" */
};

/* Open `path` and read the version line, metadata and header; choose the distance mode.
 * 0, or -1 with t->error. */
int qemu_trace_open(struct qemu_trace *t, const char *path);

/*
 * Row `index`, parsing ahead as needed. 0 with *row, 1 past the end, -1 on a
 * malformed row or a row no longer held (t->error says which).
 */
int qemu_trace_row(struct qemu_trace *t, uint32_t index, const struct qemu_trace_row **row);

/* The trace as a range source for the device models (index = row). */
struct sim_range_source qemu_trace_source(struct qemu_trace *t);

#endif /* BOARDS_MPS2_QEMU_TRACE_H */
