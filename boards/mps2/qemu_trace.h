/*
 * The QEMU replay image's trace input: trace v1 (DESIGN.md §5) read through
 * semihosting and parsed with integers only. It reads what the firmware needs
 * (t_ms, the four ranges and statuses, arm_mm and period_ms) and reports
 * malformed input as file:line:column like host_sim's reader; the ground-truth
 * columns are not needed on target and are skipped. A status of 255 with range
 * 0 is a sensor that produced no reading (docs/traces.md), as on the host.
 */
#ifndef BOARDS_MPS2_QEMU_TRACE_H
#define BOARDS_MPS2_QEMU_TRACE_H

#include <stdbool.h>
#include <stdint.h>

#include "sim/range_source.h"

#define QEMU_TRACE_RING 64u   /* rows kept for the device models and the output */
#define QEMU_TRACE_LINE 1024u /* longest accepted line, as on the host */

struct qemu_trace_row {
    uint32_t t_ms;
    uint16_t range_mm[4];
    uint8_t status[4];
};

struct qemu_trace {
    int handle;
    const char *path;
    char block[512];
    uint32_t block_len, block_pos;
    bool eof;
    char line[QEMU_TRACE_LINE + 1u];
    uint32_t line_no;
    int8_t col_t, col_range[4], col_status[4]; /* header column of each field, -1 absent */
    uint8_t columns;
    int32_t arm_um;
    uint32_t period_ms;
    uint8_t distance_mode; /* '# distance_mode=': 1 short, 2 long (enum vl53_distance_mode);
                              0 unstated */
    bool long_fits;        /* unstated, and the period admits a long-mode budget: a reading
                              only long mode reports is an error (host_sim would read the
                              trace ahead and choose long; this reader cannot) */
    struct qemu_trace_row ring[QEMU_TRACE_RING];
    uint32_t rows;   /* rows parsed so far (row i is in ring[i % RING] if i + RING > rows) */
    bool done;       /* end of file reached */
    char error[160]; /* non-empty after an error: "file:line:col: what" */
};

/* Open `path` and read the version line, metadata and header. 0, or -1 with t->error. */
int qemu_trace_open(struct qemu_trace *t, const char *path);

/*
 * Row `index`, parsing ahead as needed. 0 with *row, 1 past the end, -1 on a
 * malformed row or a row no longer held (t->error says which).
 */
int qemu_trace_row(struct qemu_trace *t, uint32_t index, const struct qemu_trace_row **row);

/* The trace as a range source for the device models (index = row). */
struct sim_range_source qemu_trace_source(struct qemu_trace *t);

#endif /* BOARDS_MPS2_QEMU_TRACE_H */
