/*
 * host_sim command line (docs/reference/tools.md; names are an interface, keep them):
 *
 *   host_sim replay TRACE.csv --estimator NAME [--window N] [--mode tumbling|sliding]
 *                             [--out EST.csv] [--report REPORT.json] [--plot FIG.png]
 *                             [--faults SPEC] [--seed S] [--i2c-log BUS.csv]
 *                             [--process-noise QD,QT | --process-noise auto]
 *                             [--i2c-khz 100|400]
 *   host_sim scenario NAME [--seed S] --trace-out TRACE.csv
 *   host_sim calibrate CAL_TRACE.csv --out HEAD.cal [--report CAL.json]   (calibrate.h)
 *   host_sim camera ...      (synthetic ToF camera + pose pipeline; see docs/explanation/pose.md)
 */
#ifndef HOST_SIM_CLI_H
#define HOST_SIM_CLI_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

struct replay_args {
    const char *trace_path;
    const char *estimator; /* consensus | consensus-paper | kalman | mean */
    unsigned window;       /* samples per window, default 100 */
    bool sliding;          /* --mode sliding */
    const char *out_path;
    const char *report_path;
    const char *plot_path;
    const char *faults; /* fault spec, parsed by the replay */
    uint64_t seed;
    bool quiet;                /* --quiet: no summary table on stdout */
    uint64_t faults_until_row; /* --faults-until ROW: injection stops there (0: never) */
    /* --process-noise QD,QT: random-walk intensities of x̄ and of a·tan α, a·tan β in
     * µm²/s (given in mm²/s); --process-noise auto: learned by the filter */
    uint32_t process_noise_um2_per_s[2];
    bool process_noise_auto;
    bool process_noise_given;     /* --process-noise given: else the mode's default (sliding:
                                     auto, tumbling: 0; tof_estimator_mode_process_noise) */
    const char *i2c_log_path;     /* --i2c-log BUS.csv: every bus transaction (NULL: none) */
    unsigned i2c_khz;             /* --i2c-khz: the simulated bus clock, 100 or 400 (0: 400) */
    unsigned distance_mode;       /* --distance-mode: 0 unset (the trace's, else from its
                                     readings), else enum vl53_distance_mode */
    const char *calibration_path; /* --calibration HEAD.cal (wins over the trace's keys) */
    bool max_rate_given;          /* --max-rate DEG_S given (wins over the trace's key) */
    uint32_t max_rate_mdeg_s;     /* ... its value, m°/s */
    bool offset_walk_given;       /* --offset-walk UM2_H given */
    uint32_t offset_walk_um2_h;   /* ... the estimator's prior offset walk, µm²/h */
    const char *commands[16];     /* --command ROW:TEXT, in order (replay_commands.h parses) */
    unsigned command_count;
};

/* The orbit-thermal scenario's options (--hours, --amplitude-c, ...), as given. */
#define CLI_THERMAL_OPTIONS 8u
struct scenario_args {
    const char *name;
    uint64_t seed;
    const char *trace_out;
    unsigned n_thermal;
    const char *thermal_option[CLI_THERMAL_OPTIONS]; /* "--hours", ... */
    double thermal_value[CLI_THERMAL_OPTIONS];
    const char *cal_out; /* orbit-thermal: --cal-out HEAD.cal (NULL: the keys inline) */
};

/* Applies the thermal options of `a` to cfg (a thermal scenario's configuration): 0, or -1
 * after a message on stderr (an option of another scenario, a value out of range). */
struct scene_config;
int cli_apply_thermal(const struct scenario_args *a, struct scene_config *cfg);

/* True if any argument after argv[0] (the subcommand) is --help or -h. */
bool cli_wants_help(int argc, char **argv);

/* Print subcommand `cmd`'s usage and options to f (scenario_names: the scenarios, for
 * `scenario`). False for a subcommand without help text here. */
bool cli_print_help(const char *cmd, const char *const *scenario_names, FILE *f);

/* Parse `replay` arguments (argv[0] is "replay"). 0, or -1 after printing the error to stderr. */
int cli_parse_replay(int argc, char **argv, struct replay_args *out);

/* Parse `scenario` arguments (argv[0] is "scenario"). 0, or -1 after printing the error. */
int cli_parse_scenario(int argc, char **argv, struct scenario_args *out);

/* Parse a decimal unsigned integer in [min, max]; false when `text` is not exactly that. */
bool cli_parse_u64(const char *text, uint64_t min, uint64_t max, uint64_t *out);

/* A plate rate bound in °/s as text ("1", "0.2", "0"; at most 3 decimals, 0..360) in m°/s:
 * false when `text` is not exactly that (the option and the trace key share it). */
bool cli_parse_rate_mdeg_s(const char *text, uint32_t *mdeg_s);

/* The estimator names replay accepts, in output order; NULL-terminated. */
extern const char *const cli_estimator_names[];

#endif /* HOST_SIM_CLI_H */
