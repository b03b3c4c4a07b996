/* mkstemp, fdopen */
#define _POSIX_C_SOURCE 200809L

#include "campaign.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "replay.h"
#include "scene/scene_io.h"
#include "sim/sim_fault.h"

static const double rates[] = {0.0001, 0.001, 0.01, 0.05};
#define RATE_COUNT (sizeof rates / sizeof rates[0])

struct campaign_row {
    char kind[24];
    double rate;
    int rc;
    struct replay_result res;
};

static int run_one(const char *trace, const char *spec, uint64_t seed, uint64_t stop_row,
                   struct replay_result *res) {
    struct replay_args args = {.trace_path = trace,
                               .estimator = "consensus",
                               .window = 100,
                               .faults = spec,
                               .seed = seed,
                               .quiet = true,
                               .faults_until_row = stop_row};
    return replay_execute(&args, res);
}

static void print_row(FILE *f, const struct campaign_row *row, bool markdown) {
    const struct replay_result *r = &row->res;
    uint32_t windows = 0, available = 0, wrong = 0;
    for (unsigned s = 0; s < 3; ++s) {
        windows += r->status_count[ATTITUDE_EST_CONSENSUS][s];
    }
    available =
        r->status_count[ATTITUDE_EST_CONSENSUS][0] + r->status_count[ATTITUDE_EST_CONSENSUS][1];
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        wrong += r->unflagged_wrong[e];
    }
    const double avail = windows ? 100.0 * available / windows : 0.0;
    char recovery[32];
    if (r->recovery_us >= 0) {
        snprintf(recovery, sizeof recovery, "%.1f", (double)r->recovery_us / 1000.0);
    } else {
        snprintf(recovery, sizeof recovery, "never");
    }
    if (markdown) {
        fprintf(f, "| %-9s | %7.2f | %5s | %5u | %9u | %7.1f | %8s | %7u | %7u | %7u |\n",
                row->kind, row->rate * 100.0, row->rc == 0 ? "0" : "FAIL", r->overruns, wrong,
                avail, recovery, r->max_iteration_us, r->reinits, r->bus_recoveries);
    } else {
        fprintf(f, "%-9s %7.2f %5s %5u %9u %7.1f %8s %7u %7u %7u\n", row->kind, row->rate * 100.0,
                row->rc == 0 ? "0" : "FAIL", r->overruns, wrong, avail, recovery,
                r->max_iteration_us, r->reinits, r->bus_recoveries);
    }
}

static void print_table(FILE *f, const struct campaign_row *rows, size_t n, bool markdown) {
    if (markdown) {
        fputs("| fault | rate % | hang | overr | unflagged | avail % | recov ms | max it us "
              "| reinits | bus rec |\n|---|---|---|---|---|---|---|---|---|---|\n",
              f);
    } else {
        fprintf(f, "%-9s %7s %5s %5s %9s %7s %8s %7s %7s %7s\n", "fault", "rate%", "hang", "overr",
                "unflagged", "avail%", "recov_ms", "max_it", "reinits", "busrec");
    }
    for (size_t i = 0; i < n; ++i) {
        print_row(f, &rows[i], markdown);
    }
}

int campaign_main(int argc, char **argv) {
    const char *trace = NULL;
    const char *markdown = NULL;
    uint64_t seed = 1;
    for (int i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--trace") == 0 && i + 1 < argc) {
            trace = argv[++i];
        } else if (strcmp(argv[i], "--markdown") == 0 && i + 1 < argc) {
            markdown = argv[++i];
        } else if (strcmp(argv[i], "--seed") == 0 && i + 1 < argc) {
            if (!cli_parse_u64(argv[++i], 0, UINT64_MAX, &seed)) {
                fprintf(stderr, "host_sim campaign: --seed: expected an integer: '%s'\n", argv[i]);
                return 2;
            }
        } else {
            fprintf(stderr, "host_sim campaign: unknown or incomplete option '%s'\n", argv[i]);
            return 2;
        }
    }
    char generated[] = "/tmp/host_sim_campaign_XXXXXX";
    if (trace == NULL) {
        const int fd = mkstemp(generated);
        if (fd < 0) {
            perror("host_sim campaign: mkstemp");
            return 1;
        }
        fclose(fdopen(fd, "w"));
        char err[512];
        if (scene_write_scenario("table1", seed, generated, err, sizeof err) != 0) {
            fprintf(stderr, "host_sim campaign: %s\n", err);
            remove(generated);
            return 1;
        }
        trace = generated;
    }
    /* The baseline run tells the trace's length; faults stop at 3/4 of it. */
    struct replay_result base;
    if (run_one(trace, NULL, seed, 0, &base) != 0) {
        fprintf(stderr, "host_sim campaign: baseline replay of %s failed\n", trace);
        return 1;
    }
    const uint64_t stop_row = base.rows * 3u / 4u;
    static struct campaign_row rows[(SIM_FAULT_COUNT + 1u) * RATE_COUNT];
    size_t n = 0;
    int failures = 0;
    for (unsigned k = 0; k <= SIM_FAULT_COUNT; ++k) {
        for (size_t r = 0; r < RATE_COUNT; ++r) {
            /* Probabilities with 6 decimals, as the fault grammar takes them. */
            char spec[512] = "";
            struct campaign_row *row = &rows[n++];
            row->rate = rates[r];
            if (k < SIM_FAULT_COUNT) {
                const char *name = sim_fault_name((enum sim_fault_kind)k);
                snprintf(row->kind, sizeof row->kind, "%s", name);
                snprintf(spec, sizeof spec, "%s=%.6f", name, rates[r]);
            } else {
                /* Mixed: every kind at once, sharing the rate. */
                snprintf(row->kind, sizeof row->kind, "mixed");
                for (unsigned j = 0; j < SIM_FAULT_COUNT; ++j) {
                    const size_t used = strlen(spec);
                    snprintf(spec + used, sizeof spec - used, "%s%s=%.6f", j ? "," : "",
                             sim_fault_name((enum sim_fault_kind)j), rates[r] / SIM_FAULT_COUNT);
                }
            }
            row->rc = run_one(trace, spec, seed + n, stop_row, &row->res);
            uint32_t wrong = 0;
            for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
                wrong += row->res.unflagged_wrong[e];
            }
            if (row->rc != 0 || row->res.overruns != 0u || wrong != 0u) {
                ++failures;
            }
        }
    }
    printf("fault campaign on %s (%llu rows, faults stop at row %llu, seed %llu)\n", trace,
           (unsigned long long)base.rows, (unsigned long long)stop_row, (unsigned long long)seed);
    print_table(stdout, rows, n, false);
    if (markdown != NULL) {
        FILE *f = fopen(markdown, "w");
        if (f == NULL) {
            perror(markdown);
            failures = 1;
        } else {
            fprintf(f,
                    "Fault campaign: `host_sim campaign --seed %llu` on the table1 scenario "
                    "(%llu rows); faults stop at row %llu.\n\n",
                    (unsigned long long)seed, (unsigned long long)base.rows,
                    (unsigned long long)stop_row);
            print_table(f, rows, n, true);
            fclose(f);
        }
    }
    if (trace == generated) {
        remove(generated);
    }
    if (failures != 0) {
        fprintf(stderr,
                "host_sim campaign: %d run(s) hung, failed or reported an unflagged "
                "wrong estimate\n",
                failures);
        return 1;
    }
    return 0;
}
