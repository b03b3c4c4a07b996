/*
 * Adapters from rows (struct scene_row) to the device models' range source
 * (sim/include/sim/range_source.h: reading number sample_index of
 * sensor k; present = false is a dropout).
 *
 * - scene_row_array: rows already in memory (the estimator benchmark).
 * - scene_row_stream: rows pulled one at a time from a trace reader or a
 *   scenario generator through a ring of SCENE_STREAM_RING rows, so a
 *   million-row trace replays in constant memory. The four sensors ask for the
 *   same sample index at nearly the same time; a row stays available until
 *   SCENE_STREAM_RING newer rows have been pulled, and asking for an older one
 *   is an error, never a wrong reading.
 */
#ifndef SCENE_ROW_SOURCE_H
#define SCENE_ROW_SOURCE_H

#include <stddef.h>
#include <stdint.h>

#include "scene/row.h"
#include "sim/range_source.h"

/* Error returned by the sources' next(): the source's data is bad or a sample
 * index is no longer available (see scene_row_stream_error()). */
#define SCENE_SOURCE_ERR (-1)

/* ---- in-memory rows ---- */

struct scene_row_array {
    const struct scene_row *rows;
    size_t count;
};

/* A range source over a->rows[0..count) (a must outlive the source); sample
 * index i is rows[i]; past the end next() returns 1. */
struct sim_range_source scene_row_array_source(struct scene_row_array *a);

/* ---- streamed rows ---- */

#define SCENE_STREAM_RING 256u

/* Produces the next row: 0 with *row, 1 at the end, -1 on an error. */
typedef int (*scene_row_pull_fn)(void *ctx, struct scene_row *row);

struct scene_row_stream {
    scene_row_pull_fn pull;
    void *pull_ctx;
    struct scene_row ring[SCENE_STREAM_RING];
    uint64_t next_index; /* index of the next row to pull: rows [next_index − count, next_index) are
                            held */
    unsigned count;
    int end; /* 0 more may come, 1 producer ended, -1 producer failed */
    char err[160];
};

/* Starts a stream over pull(pull_ctx, ...). */
void scene_row_stream_init(struct scene_row_stream *s, scene_row_pull_fn pull, void *pull_ctx);

/*
 * Row number index, pulling rows up to it if needed. Returns the row (valid
 * until SCENE_STREAM_RING more rows are pulled), or NULL with *rc = 1 past the
 * end, or *rc = -1 if the producer failed or the row was already dropped.
 */
const struct scene_row *scene_row_stream_get(struct scene_row_stream *s, uint64_t index, int *rc);

/* Why the stream failed ("" if it did not; the producer's own message, e.g.
 * trace_reader_error(), says what was wrong with its input). */
const char *scene_row_stream_error(const struct scene_row_stream *s);

/* The stream as a range source (s must outlive it). */
struct sim_range_source scene_row_stream_source(struct scene_row_stream *s);

/* Pull functions for the two producers: ctx is a struct trace_reader * (opened)
 * or a struct scene_gen * (initialised). */
int scene_pull_trace(void *reader, struct scene_row *row);
int scene_pull_scenario(void *gen, struct scene_row *row);

#endif /* SCENE_ROW_SOURCE_H */
