/*
 * scene_tool: writes scenarios as trace v1 files and checks traces.
 *   scene_tool scenario NAME [--seed S] --trace-out TRACE.csv
 *   scene_tool check TRACE.csv     (reads it; prints rows and metadata or the error)
 *   scene_tool list                (scenario names)
 * host_sim will offer the same `scenario` command (docs/reference/tools.md).
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene/scene_io.h"
#include "scene/trace.h"

static int usage(void) {
    fputs("usage: scene_tool scenario NAME [--seed S] --trace-out TRACE.csv\n"
          "       scene_tool check TRACE.csv\n"
          "       scene_tool list\n",
          stderr);
    return 2;
}

static int parse_seed(const char *s, uint64_t *out) {
    if (s[0] < '0' || s[0] > '9') {
        return -1;
    }
    char *end = NULL;
    errno = 0;
    const unsigned long long v = strtoull(s, &end, 10);
    if (errno != 0 || *end != '\0') {
        return -1;
    }
    *out = (uint64_t)v;
    return 0;
}

static int cmd_scenario(int argc, char **argv) {
    if (argc < 3) {
        return usage();
    }
    const char *name = argv[2];
    const char *out = NULL;
    uint64_t seed = 1;
    for (int i = 3; i < argc; ++i) {
        if (strcmp(argv[i], "--seed") == 0 && i + 1 < argc) {
            if (parse_seed(argv[++i], &seed) != 0) {
                fprintf(stderr, "scene_tool: --seed: '%s' is not an unsigned integer\n", argv[i]);
                return 2;
            }
        } else if (strcmp(argv[i], "--trace-out") == 0 && i + 1 < argc) {
            out = argv[++i];
        } else {
            fprintf(stderr, "scene_tool: unexpected argument '%s'\n", argv[i]);
            return usage();
        }
    }
    if (out == NULL) {
        fputs("scene_tool: --trace-out is required\n", stderr);
        return usage();
    }
    char err[512];
    if (scene_write_scenario(name, seed, out, err, sizeof err) != 0) {
        fprintf(stderr, "scene_tool: %s\n", err);
        return 1;
    }
    return 0;
}

static int cmd_check(const char *path) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        fprintf(stderr, "scene_tool: %s: cannot open: %s\n", path, strerror(errno));
        return 1;
    }
    static struct trace_reader reader;
    int rc = trace_reader_open(&reader, f, path);
    unsigned long long rows = 0;
    unsigned long long absent = 0;
    unsigned long long flagged = 0;
    while (rc == 0) {
        struct scene_row row = {0};
        const int got = trace_reader_next(&reader, &row);
        if (got == 1) {
            break;
        }
        if (got < 0) {
            rc = -1;
            break;
        }
        ++rows;
        for (unsigned k = 0; k < SCENE_SENSORS; ++k) {
            absent += row.present[k] ? 0u : 1u;
            flagged += (row.present[k] && row.status[k] != 0u) ? 1u : 0u;
        }
    }
    fclose(f);
    if (rc != 0) {
        fprintf(stderr, "scene_tool: %s\n", trace_reader_error(&reader));
        return 1;
    }
    printf("%s: trace v1, %llu rows, arm_mm=%g, %llu absent and %llu flagged readings\n", path,
           rows, reader.meta.arm_mm, absent, flagged);
    for (unsigned i = 0; i < reader.meta.count; ++i) {
        printf("  %s=%s\n", reader.meta.key[i], reader.meta.value[i]);
    }
    const struct trace_timing *tm = trace_reader_timing(&reader);
    printf("  time base: period_ms %u (%s); %llu repeated t_ms, %llu jumps of more than two "
           "periods%s\n",
           tm->period_ms, tm->period_from_meta ? "from the trace" : "default, none in the trace",
           (unsigned long long)tm->repeats, (unsigned long long)tm->jumps,
           reader.bom ? "; a UTF-8 byte-order mark was skipped" : "");
    for (unsigned i = 0; i < tm->note_count; ++i) {
        printf("  %s:%lu: t_ms %lu after %lu (%s)\n", path, (unsigned long)tm->notes[i].line,
               (unsigned long)tm->notes[i].t_ms, (unsigned long)tm->notes[i].prev_t_ms,
               tm->notes[i].kind == TRACE_TIME_REPEAT ? "repeated" : "jump");
    }
    return 0;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        return usage();
    }
    if (strcmp(argv[1], "scenario") == 0) {
        return cmd_scenario(argc, argv);
    }
    if (strcmp(argv[1], "check") == 0 && argc == 3) {
        return cmd_check(argv[2]);
    }
    if (strcmp(argv[1], "list") == 0 && argc == 2) {
        for (size_t i = 0; scene_scenario_names[i] != NULL; ++i) {
            puts(scene_scenario_names[i]);
        }
        return 0;
    }
    return usage();
}
