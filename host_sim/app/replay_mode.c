/* host_sim replay's distance mode: evidence read ahead, sim/'s policy, the words (replay_mode.h).
 */
#include "replay_mode.h"

#include <stdio.h>
#include <sys/stat.h>

#include "firmware/config.h"

_Static_assert((int)TRACE_MODE_SHORT == (int)VL53_DISTANCE_SHORT &&
                   (int)TRACE_MODE_LONG == (int)VL53_DISTANCE_LONG,
               "trace/trace_v1.h's modes carry the driver's numbers");

/* The trace's readings in (1,360, 4,000] mm, from a second pass of the reader over the
 * file. 0 with *ev, or -1 when the file is not a regular one (a pipe cannot be read
 * twice) or does not parse to its end (the replay's own pass reports that). */
static int read_ahead(const char *path, struct trace_mode_evidence *ev) {
    static struct trace_reader scan; /* static: the reader holds its block buffer */
    struct stat sb;
    if (stat(path, &sb) != 0 || !S_ISREG(sb.st_mode)) {
        return -1;
    }
    FILE *f = fopen(path, "rb");
    if (f == NULL || trace_reader_open(&scan, f, path) != 0) {
        if (f != NULL) {
            fclose(f);
        }
        return -1;
    }
    trace_v1_readings_only(&scan.core); /* the evidence is in the readings alone */
    *ev = (struct trace_mode_evidence){.short_max_mm = VL53_RANGE_MAX_SHORT_MM,
                                       .long_max_mm = VL53_RANGE_MAX_LONG_MM};
    struct trace_v1_row row;
    int rc = 0;
    while ((rc = trace_v1_next(&scan.core, &row)) == 0) {
        trace_mode_evidence_add(ev, &row, scan.core.last_row_line);
    }
    fclose(f);
    return rc == 1 ? 0 : -1;
}

/* Says why: the source text of every choice, and a note or warning for those the
 * readings made. */
static void describe(struct replay_mode *m, struct trace_mode_choice c, const char *path,
                     const struct trace_mode_evidence *ev, uint32_t meta_line, uint32_t period_ms) {
    const char sensor = (char)('A' + ev->first_sensor);
    switch (c.why) {
    case TRACE_MODE_BY_OPTION:
        snprintf(m->source, sizeof m->source, "--distance-mode");
        break;
    case TRACE_MODE_BY_TRACE:
        snprintf(m->source, sizeof m->source, "the trace (line %lu)", (unsigned long)meta_line);
        break;
    case TRACE_MODE_NOT_READ_AHEAD:
        snprintf(m->source, sizeof m->source, "default: the readings could not be read ahead");
        fprintf(stderr,
                "host_sim replay: note: %s: not a regular file that parses to its end, so its "
                "readings were not read ahead for the distance mode: short (to %u mm) unless "
                "'# distance_mode=' or --distance-mode says otherwise\n",
                path, VL53_RANGE_MAX_SHORT_MM);
        break;
    case TRACE_MODE_NO_EVIDENCE:
        snprintf(m->source, sizeof m->source, "default: no reading in (%u, %u] mm",
                 VL53_RANGE_MAX_SHORT_MM, VL53_RANGE_MAX_LONG_MM);
        break;
    case TRACE_MODE_BY_READINGS:
        snprintf(m->source, sizeof m->source,
                 "%lld readings above short mode's %u mm, the first at line %lu (sensor %c)",
                 (long long)ev->count, VL53_RANGE_MAX_SHORT_MM, (unsigned long)ev->first_line,
                 sensor);
        fprintf(stderr,
                "host_sim replay: note: %s: distance mode long (to %u mm): %s; state it with "
                "'# distance_mode=long' or --distance-mode\n",
                path, VL53_RANGE_MAX_LONG_MM, m->source);
        break;
    case TRACE_MODE_NO_BUDGET:
    default:
        snprintf(m->source, sizeof m->source, "default: long mode has no budget for period_ms %u",
                 period_ms);
        fprintf(stderr,
                "host_sim replay: warning: %s: %lld readings above short mode's %u mm (the first "
                "at line %lu, sensor %c) are flagged: long mode, which reports them, has no "
                "budget for period_ms %u (at least %u ms)\n",
                path, (long long)ev->count, VL53_RANGE_MAX_SHORT_MM, (unsigned long)ev->first_line,
                sensor, period_ms,
                vl53_shortest_budget_ms(VL53_DISTANCE_LONG) + VL53_IMP_MARGIN_MS);
        break;
    }
}

int replay_mode_choose(struct replay_mode *m, const struct trace_reader *reader, const char *path,
                       unsigned option, uint32_t period_ms) {
    const char *stated = trace_reader_meta(reader, "distance_mode");
    const uint32_t meta_line = (uint32_t)trace_reader_meta_line(reader, "distance_mode");
    enum vl53_distance_mode stated_mode = VL53_DISTANCE_SHORT;
    if (stated != NULL && !vl53_distance_mode_from_name(stated, &stated_mode)) {
        fprintf(stderr, "host_sim replay: %s:%lu: distance_mode must be short or long, got '%s'\n",
                path, (unsigned long)meta_line, stated);
        return -1;
    }
    struct trace_mode_evidence ev = {0};
    const bool need_evidence = option == 0u && stated == NULL;
    const bool have_evidence = need_evidence && read_ahead(path, &ev) == 0;
    const struct trace_mode_choice c = trace_mode_choose(
        (enum trace_mode)option,
        stated != NULL ? (enum trace_mode)stated_mode : TRACE_MODE_UNSTATED,
        have_evidence ? &ev : NULL, tof_app_replay_mode_fits(period_ms, VL53_DISTANCE_LONG));
    m->mode = (enum vl53_distance_mode)c.mode;
    describe(m, c, path, &ev, meta_line, period_ms);
    return 0;
}
