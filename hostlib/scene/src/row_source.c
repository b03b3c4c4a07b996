/* Rows as range sources for the simulated VL53 devices (row_source.h). */
#include "scene/row_source.h"

#include <stdio.h>
#include <string.h>

#include "scene/scenario.h"
#include "scene/trace.h"

static void fill_range(const struct scene_row *row, unsigned sensor, struct sim_range *out) {
    out->distance_mm = row->range_mm[sensor];
    out->range_status = row->status[sensor];
    out->present = row->present[sensor];
}

static int array_next(void *ctx, unsigned sensor, uint32_t sample_index, struct sim_range *out) {
    const struct scene_row_array *a = ctx;
    if (sensor >= SCENE_SENSORS) {
        return SCENE_SOURCE_ERR;
    }
    if (sample_index >= a->count) {
        return 1;
    }
    fill_range(&a->rows[sample_index], sensor, out);
    return 0;
}

static const struct sim_range_source_ops array_ops = {.next = array_next};

struct sim_range_source scene_row_array_source(struct scene_row_array *a) {
    struct sim_range_source src = {&array_ops, a};
    return src;
}

void scene_row_stream_init(struct scene_row_stream *s, scene_row_pull_fn pull, void *pull_ctx) {
    memset(s, 0, sizeof *s);
    s->pull = pull;
    s->pull_ctx = pull_ctx;
}

const struct scene_row *scene_row_stream_get(struct scene_row_stream *s, uint64_t index, int *rc) {
    const uint64_t oldest = s->next_index - s->count;
    if (index < oldest) {
        snprintf(s->err, sizeof s->err,
                 "row %llu asked for after it left the %u-row stream buffer (oldest held: %llu)",
                 (unsigned long long)index, SCENE_STREAM_RING, (unsigned long long)oldest);
        *rc = -1;
        return NULL;
    }
    /* Bounded: each pass pulls one row, and a producer that ends or fails stops it. */
    while (index >= s->next_index) {
        if (s->end != 0) {
            *rc = s->end;
            return NULL;
        }
        struct scene_row *slot = &s->ring[s->next_index % SCENE_STREAM_RING];
        const int got = s->pull(s->pull_ctx, slot);
        if (got != 0) {
            s->end = got > 0 ? 1 : -1;
            if (got < 0) {
                snprintf(s->err, sizeof s->err, "the row producer failed at row %llu",
                         (unsigned long long)s->next_index);
            }
            continue;
        }
        s->next_index++;
        if (s->count < SCENE_STREAM_RING) {
            s->count++;
        }
    }
    *rc = 0;
    return &s->ring[index % SCENE_STREAM_RING];
}

const char *scene_row_stream_error(const struct scene_row_stream *s) {
    return s->err;
}

static int stream_next(void *ctx, unsigned sensor, uint32_t sample_index, struct sim_range *out) {
    struct scene_row_stream *s = ctx;
    if (sensor >= SCENE_SENSORS) {
        return SCENE_SOURCE_ERR;
    }
    int rc = 0;
    const struct scene_row *row = scene_row_stream_get(s, sample_index, &rc);
    if (row == NULL) {
        return rc > 0 ? 1 : SCENE_SOURCE_ERR;
    }
    fill_range(row, sensor, out);
    return 0;
}

static const struct sim_range_source_ops stream_ops = {.next = stream_next};

struct sim_range_source scene_row_stream_source(struct scene_row_stream *s) {
    struct sim_range_source src = {&stream_ops, s};
    return src;
}

int scene_pull_trace(void *reader, struct scene_row *row) {
    return trace_reader_next(reader, row);
}

int scene_pull_scenario(void *gen, struct scene_row *row) {
    return scene_gen_next(gen, row, NULL, NULL, 0u);
}
