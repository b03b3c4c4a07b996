/*
 * scene_bench: throughput of the scene and trace code that host_sim replay
 * sits on (the replay is held to ≥ 1,000,000 samples/s end to end, so these parts
 * must be well above that). Prints rows per second for
 *   1. generating a scenario (table1 protocol stretched to ROWS rows),
 *   2. writing it as trace v1 to a temporary file,
 *   3. reading that file back with the streaming reader,
 *   4. reading it through the 256-row ring as a sim_range_source (4 sensors).
 * Usage: scene_bench [ROWS]   (default 1,000,000; use the host-release preset)
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "scene/row_source.h"
#include "scene/scenario.h"
#include "scene/trace.h"

static double now_s(void) {
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void report(const char *what, unsigned long rows, double seconds) {
    printf("%-44s %9lu rows %8.3f s %10.0f rows/s\n", what, rows, seconds, (double)rows / seconds);
}

int main(int argc, char **argv) {
    unsigned long rows = 1000000ul;
    if (argc > 1) {
        char *end = NULL;
        rows = strtoul(argv[1], &end, 10);
        if (*end != '\0' || rows < 100ul || rows > 100000000ul) {
            fprintf(stderr, "scene_bench: ROWS must be 100..100000000\n");
            return 2;
        }
    }
    struct scene_config cfg;
    scene_config_named("table1", &cfg);
    cfg.n_positions = (uint32_t)(rows / cfg.samples_per_position);
    rows = cfg.n_positions * (unsigned long)cfg.samples_per_position;
    static struct scene_gen gen;
    char err[512];
    struct scene_row row = {0};

    /* 1. generate */
    if (scene_gen_init(&gen, &cfg, 1, err, sizeof err) != 0) {
        fprintf(stderr, "scene_bench: %s\n", err);
        return 1;
    }
    unsigned long sum = 0;
    double t0 = now_s();
    while (scene_gen_next(&gen, &row, NULL, err, sizeof err) == 0) {
        sum += row.range_mm[0];
    }
    report("generate (table1 noise model)", rows, now_s() - t0);

    /* 2. write */
    FILE *f = tmpfile();
    if (f == NULL) {
        perror("scene_bench: tmpfile");
        return 1;
    }
    scene_gen_init(&gen, &cfg, 1, err, sizeof err);
    t0 = now_s();
    trace_write_header(f, cfg.arm_mm, cfg.period_ms, NULL);
    while (scene_gen_next(&gen, &row, NULL, err, sizeof err) == 0) {
        if (trace_write_row(f, &row) != 0) {
            fprintf(stderr, "scene_bench: write failed\n");
            return 1;
        }
    }
    fflush(f);
    const long bytes = ftell(f);
    report("generate + write trace v1", rows, now_s() - t0);

    /* 3. read */
    static struct trace_reader reader;
    rewind(f);
    t0 = now_s();
    if (trace_reader_open(&reader, f, "bench.csv") != 0) {
        fprintf(stderr, "scene_bench: %s\n", trace_reader_error(&reader));
        return 1;
    }
    unsigned long got = 0;
    int rc = 0;
    while ((rc = trace_reader_next(&reader, &row)) == 0) {
        sum += row.range_mm[1];
        ++got;
    }
    const double t_read = now_s() - t0;
    if (rc < 0 || got != rows) {
        fprintf(stderr, "scene_bench: %s\n", trace_reader_error(&reader));
        return 1;
    }
    report("read trace v1 (streaming reader)", rows, t_read);
    printf("%-44s %9.1f MB/s (%ld bytes)\n", "", (double)bytes / t_read / 1e6, bytes);

    /* 4. ring source: each sensor asks for each sample index */
    rewind(f);
    trace_reader_open(&reader, f, "bench.csv");
    static struct scene_row_stream stream;
    scene_row_stream_init(&stream, scene_pull_trace, &reader);
    const struct sim_range_source src = scene_row_stream_source(&stream);
    t0 = now_s();
    for (uint32_t i = 0; i < rows; ++i) {
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            struct sim_range r;
            if (src.ops->next(src.ctx, k, i, &r) != 0) {
                fprintf(stderr, "scene_bench: source failed at %lu\n", (unsigned long)i);
                return 1;
            }
            sum += r.distance_mm;
        }
    }
    report("read through the ring range source", rows, now_s() - t0);
    fclose(f);
    printf("(checksum %lu)\n", sum);
    return 0;
}
