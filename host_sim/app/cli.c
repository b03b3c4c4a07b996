/* host_sim's command line: subcommands, their options and their --help (cli.h). */
#include "cli.h"
#include "telemetry/tlm_command_text.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "calibrate.h"
#include "calibrate/fixture.h"
#include "scene/scenario.h"
#include "vl53/vl53.h"

const char *const cli_estimator_names[] = {"consensus", "consensus-paper", "kalman", "mean", NULL};

bool cli_parse_u64(const char *text, uint64_t min, uint64_t max, uint64_t *out) {
    if (text == NULL || *text < '0' || *text > '9') {
        return false;
    }
    errno = 0;
    char *end = NULL;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno != 0 || end == text || *end != '\0' || v < min || v > max) {
        return false;
    }
    *out = (uint64_t)v;
    return true;
}

static int usage_error(const char *cmd, const char *what, const char *value) {
    if (value != NULL) {
        fprintf(stderr, "host_sim %s: %s: '%s'\n", cmd, what, value);
    } else {
        fprintf(stderr, "host_sim %s: %s\n", cmd, what);
    }
    fprintf(stderr, "run 'host_sim --help' for usage\n");
    return -1;
}

/* The value after option argv[*i], advancing *i; NULL (after an error) when missing. */
static const char *option_value(const char *cmd, int argc, char **argv, int *i) {
    if (*i + 1 >= argc) {
        usage_error(cmd, "option needs a value", argv[*i]);
        return NULL;
    }
    ++*i;
    return argv[*i];
}

/* One intensity in mm²/s, plain decimal (digits, one optional point and fraction), as
 * whole µm²/s; false when it is not exactly that or exceeds 2^32 − 1 µm²/s. */
bool cli_parse_rate_mdeg_s(const char *text, uint32_t *mdeg_s) {
    uint32_t whole = 0;
    uint32_t frac = 0;
    unsigned frac_digits = 0;
    bool point = false;
    bool digit = false;
    for (const char *p = text; *p != '\0'; ++p) {
        if (*p == '.' && !point) {
            point = true;
        } else if (*p >= '0' && *p <= '9') {
            digit = true;
            if (!point) {
                whole = whole * 10u + (uint32_t)(*p - '0');
                if (whole > 360u) {
                    return false;
                }
            } else if (frac_digits < 3u) {
                frac = frac * 10u + (uint32_t)(*p - '0');
                frac_digits++;
            } else if (*p != '0') {
                return false; /* finer than 1 m°/s */
            }
        } else {
            return false;
        }
    }
    for (; frac_digits < 3u; ++frac_digits) {
        frac *= 10u;
    }
    const uint32_t v = whole * 1000u + frac;
    if (!digit || v > 360000u) {
        return false;
    }
    *mdeg_s = v;
    return true;
}

static bool parse_intensity(const char *text, size_t len, uint32_t *um2_per_s) {
    uint64_t whole = 0;
    uint64_t frac = 0;
    unsigned frac_digits = 0;
    bool point = false;
    bool digit = false;
    for (size_t i = 0; i < len; ++i) {
        const char c = text[i];
        if (c == '.' && !point) {
            point = true;
        } else if (c >= '0' && c <= '9') {
            digit = true;
            if (!point) {
                whole = whole * 10u + (uint64_t)(c - '0');
                if (whole > 5000u) {
                    return false;
                }
            } else if (frac_digits < 6u) {
                frac = frac * 10u + (uint64_t)(c - '0');
                frac_digits++;
            } else if (c != '0') {
                return false; /* finer than 1 µm²/s */
            }
        } else {
            return false;
        }
    }
    while (frac_digits < 6u) {
        frac *= 10u;
        frac_digits++;
    }
    const uint64_t v = whole * 1000000u + frac;
    if (!digit || v > UINT32_MAX) {
        return false;
    }
    *um2_per_s = (uint32_t)v;
    return true;
}

static bool known_estimator(const char *name) {
    for (size_t k = 0; cli_estimator_names[k] != NULL; ++k) {
        if (strcmp(cli_estimator_names[k], name) == 0) {
            return true;
        }
    }
    return false;
}

bool cli_wants_help(int argc, char **argv) {
    for (int i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            return true;
        }
    }
    return false;
}

/* Each subcommand's options, one per line (keep in step with its parser). */
static const char replay_help[] =
    "usage: host_sim replay TRACE.csv [options]\n"
    "Feeds a trace v1 file (docs/reference/trace-format.md) through the simulated VL53 sensors and "
    "I2C bus\n"
    "into the firmware pipeline and its estimators; windows are counted in trace rows.\n"
    "options:\n"
    "  --estimator NAME     primary estimator: consensus (default), consensus-paper, kalman,\n"
    "                       mean (all four run; this one leads the summary and the plot)\n"
    "  --window N           samples per window, 2..255 (default 100)\n"
    "  --mode MODE          tumbling (default) or sliding\n"
    "  --out EST.csv        estimates, one row per estimate (docs/reference/tools.md)\n"
    "  --report REPORT.json statistics, time base, bus and firmware counters\n"
    "  --plot FIG.png       estimates against truth (tools/plot_replay.py, matplotlib)\n"
    "  --faults SPEC        bus faults kind=probability[,...] per transaction; kinds: nack\n"
    "                       stretch reset drdy_high drdy_low garbage bitflip stuck\n"
    "  --faults-until ROW   stop injecting faults at trace row ROW (>= 1)\n"
    "  --seed S             seed of the fault injection (default 1)\n"
    "  --i2c-log BUS.csv    every bus transaction: t_us,addr,write,read,result "
    "(docs/explanation/driver-and-bus.md)\n"
    "  --i2c-khz K          the simulated bus clock, 100 or 400 (default 400): the board\n"
    "                       images' TOF_I2C_KHZ; a period the bus cannot carry is refused\n"
    "  --process-noise Q    Kalman random-walk intensities QD,QT in mm²/s (x̄; a·tan α and\n"
    "                       a·tan β; Q per row = q·period), or auto (learned); default 0\n"
    "                       in tumbling mode, auto in sliding mode (0,0 for Q = 0 there)\n"
    "  --distance-mode M    the parts' mode: short (to 1360 mm) or long (to 4000 mm); default:\n"
    "                       the trace's '# distance_mode=', else long when it holds readings\n"
    "                       above 1360 mm and its period admits long mode, else short\n"
    "  --calibration F      the head's calibration, a HEAD.cal (docs/how-to/calibrate-a-head.md); "
    "wins\n"
    "                       over the trace's keys; neither: an uncalibrated head, never ok\n"
    "  --max-rate DEG_S     the plate's rate bound in °/s, 0..360 (0: a still plate, e.g. a\n"
    "                       fixture); wins over the trace's '# max_rate_deg_s='; default 1\n"
    "  --offset-walk UM2_H  the head's offset random walk the sd allows for, µm²/h (the\n"
    "                       estimator's offset_walk_um2_h; default 576000, a recorded\n"
    "                       VL53L0X hour's: docs/explanation/uncertainty.md)\n"
    "  --command ROW:TEXT   a host's command (tools/tof_telemetry.py --send syntax: set-window\n"
    "                       50 sliding, estimator kalman, process-noise auto, raw on, ...)\n"
    "                       to the firmware's link at 115200 Bd when row ROW's slot is half\n"
    "                       over; repeatable, in order (docs/reference/tools.md)\n"
    "  --quiet              no summary table on stdout\n"
    "  --help, -h           this text\n"
    "exit status: 0 done, 1 bad input or a failed run, 2 bad command line\n";

static const char scenario_help[] =
    "usage: host_sim scenario NAME [--seed S] --trace-out TRACE.csv [thermal options]\n"
    "Writes a named synthetic scenario as a trace v1 file (docs/reference/trace-format.md).\n"
    "options:\n"
    "  --seed S             seed of the scenario's noise (default 1)\n"
    "  --trace-out FILE     where to write it ('-' is stdout); required\n"
    "orbit-thermal only (the head's temperature T = 20 C + A sin(2 pi t / 90 min + phase)):\n"
    "  --hours H            length, (0, 24] hours (default 6)\n"
    "  --amplitude-c A      half the cycle's swing, 0..60 C (default 20: a 40 C cycle)\n"
    "  --phase-deg P        the cycle's phase at t = 0, -360..360 (default 0)\n"
    "  --coeff-range K      offsets' temperature coefficients uniform in +-K mm/C, 0..0.5\n"
    "                       (default 0.0375: up to 1.5 mm over a 40 C cycle; no public\n"
    "                       VL53L1X figure exists)\n"
    "  --coeff-sd S         the sd the trace states with the coefficients, which it draws\n"
    "                       about the truth with that sd, 0..0.125 mm/C (default 0.001)\n"
    "  --walk-um2-h W       each offset's random walk, um^2/h (default 57600, a tenth of\n"
    "                       the estimator's prior)\n"
    "  --temp-noise-c N     the measured temperature's noise sd, 0..10 C (default 0.3)\n"
    "  --cal-out HEAD.cal   write the head's calibration there, in the trace's folder, and\n"
    "                       name it in the trace (calibration=FILE) instead of the keys\n"
    "  --help, -h           this text\n"
    "exit status: 0 done, 1 failed, 2 bad command line\n"
    "scenarios:";

static const char campaign_help[] =
    "usage: host_sim campaign [--trace T.csv] [--seed S] [--markdown FILE.md]\n"
    "Runs every bus fault kind alone and mixed over a trace and checks that no run hangs\n"
    "and no wrong estimate goes unflagged (docs/reference/fault-campaign.md).\n"
    "options:\n"
    "  --trace T.csv        the trace to replay (default: the table1 scenario, seed S)\n"
    "  --seed S             seed of the fault injection (default 1)\n"
    "  --markdown FILE.md   also write the result table as Markdown\n"
    "  --help, -h           this text\n"
    "exit status: 0 all runs passed, 1 a run failed, 2 bad command line\n";

bool cli_print_help(const char *cmd, const char *const *scenario_names, FILE *f) {
    if (strcmp(cmd, "replay") == 0) {
        fputs(replay_help, f);
    } else if (strcmp(cmd, "campaign") == 0) {
        fputs(campaign_help, f);
    } else if (strcmp(cmd, "calibrate") == 0) {
        fputs(calibrate_help, f);
    } else if (strcmp(cmd, "scenario") == 0) {
        fputs(scenario_help, f);
        for (size_t i = 0; scenario_names != NULL && scenario_names[i] != NULL; ++i) {
            fprintf(f, " %s", scenario_names[i]);
        }
        for (size_t i = 0; fixture_names[i] != NULL; ++i) {
            fprintf(f, " %s", fixture_names[i]); /* docs/how-to/calibrate-a-head.md */
        }
        fputc('\n', f);
    } else {
        return false;
    }
    return true;
}

int cli_parse_replay(int argc, char **argv, struct replay_args *out) {
    *out = (struct replay_args){.estimator = NULL, .window = 100, .sliding = false, .seed = 1};
    const char *cmd = "replay";
    for (int i = 1; i < argc; ++i) {
        const char *arg = argv[i];
        const char *v = NULL;
        uint64_t n = 0;
        if (strcmp(arg, "--estimator") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            if (!known_estimator(v)) {
                return usage_error(
                    cmd, "--estimator: unknown (consensus, consensus-paper, kalman, mean)", v);
            }
            out->estimator = v;
        } else if (strcmp(arg, "--window") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            if (!cli_parse_u64(v, 2, 255, &n)) {
                return usage_error(cmd, "--window: expected an integer 2..255", v);
            }
            out->window = (unsigned)n;
        } else if (strcmp(arg, "--mode") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            if (strcmp(v, "tumbling") == 0) {
                out->sliding = false;
            } else if (strcmp(v, "sliding") == 0) {
                out->sliding = true;
            } else {
                return usage_error(cmd, "--mode: expected tumbling or sliding", v);
            }
        } else if (strcmp(arg, "--out") == 0) {
            if ((out->out_path = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
        } else if (strcmp(arg, "--report") == 0) {
            if ((out->report_path = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
        } else if (strcmp(arg, "--plot") == 0) {
            if ((out->plot_path = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
        } else if (strcmp(arg, "--calibration") == 0) {
            if ((out->calibration_path = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
        } else if (strcmp(arg, "--i2c-log") == 0) {
            if ((out->i2c_log_path = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
        } else if (strcmp(arg, "--i2c-khz") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            uint64_t khz = 0;
            if (!cli_parse_u64(v, 100, 400, &khz) || (khz != 100u && khz != 400u)) {
                return usage_error(cmd, "--i2c-khz: expected 100 or 400", v);
            }
            out->i2c_khz = (unsigned)khz;
        } else if (strcmp(arg, "--faults") == 0) {
            if ((out->faults = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
        } else if (strcmp(arg, "--seed") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            if (!cli_parse_u64(v, 0, UINT64_MAX, &out->seed)) {
                return usage_error(cmd, "--seed: expected a non-negative integer", v);
            }
        } else if (strcmp(arg, "--faults-until") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            if (!cli_parse_u64(v, 1, UINT32_MAX, &out->faults_until_row)) {
                return usage_error(cmd, "--faults-until: expected a row number >= 1", v);
            }
        } else if (strcmp(arg, "--process-noise") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            out->process_noise_given = true;
            const char *comma = strchr(v, ',');
            if (strcmp(v, "auto") == 0) {
                out->process_noise_auto = true;
            } else if (comma == NULL ||
                       !parse_intensity(v, (size_t)(comma - v), &out->process_noise_um2_per_s[0]) ||
                       !parse_intensity(comma + 1, strlen(comma + 1),
                                        &out->process_noise_um2_per_s[1])) {
                return usage_error(cmd,
                                   "--process-noise: expected QD,QT (mm²/s, decimals up to "
                                   "4294.967295, at most 6 places) or auto",
                                   v);
            }
        } else if (strcmp(arg, "--max-rate") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            if (!cli_parse_rate_mdeg_s(v, &out->max_rate_mdeg_s)) {
                return usage_error(cmd,
                                   "--max-rate: expected the plate's rate bound in °/s, "
                                   "0..360 with at most 3 decimals",
                                   v);
            }
            out->max_rate_given = true;
        } else if (strcmp(arg, "--offset-walk") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            char *end = NULL;
            errno = 0;
            const unsigned long long walk = strtoull(v, &end, 10);
            if (errno != 0 || end == v || *end != '\0' || v[0] == '-' || walk > UINT32_MAX) {
                return usage_error(cmd,
                                   "--offset-walk: expected the offset walk in µm²/h, a whole "
                                   "number 0..4294967295",
                                   v);
            }
            out->offset_walk_um2_h = (uint32_t)walk;
            out->offset_walk_given = true;
        } else if (strcmp(arg, "--distance-mode") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            enum vl53_distance_mode mode;
            if (!vl53_distance_mode_from_name(v, &mode)) {
                return usage_error(cmd, "--distance-mode: expected short or long", v);
            }
            out->distance_mode = (unsigned)mode;
        } else if (strcmp(arg, "--command") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            if (out->command_count == sizeof out->commands / sizeof out->commands[0]) {
                return usage_error(cmd, "--command: 16 at most", v);
            }
            uint32_t row = 0;
            struct tlm_command parsed;
            const char *why = tlm_command_from_arg(v, &row, &parsed);
            if (why != NULL) {
                return usage_error(cmd, why, v);
            }
            out->commands[out->command_count++] = v; /* encoded by the replay */
        } else if (strcmp(arg, "--quiet") == 0) {
            out->quiet = true;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            return usage_error(cmd, "unknown option", arg);
        } else if (out->trace_path == NULL) {
            out->trace_path = arg;
        } else {
            return usage_error(cmd, "more than one trace given", arg);
        }
    }
    if (out->trace_path == NULL) {
        return usage_error(cmd, "missing TRACE.csv", NULL);
    }
    if (out->estimator == NULL) {
        out->estimator = "consensus"; /* the product's default (docs/reference/tools.md) */
    }
    return 0;
}

/* One of the orbit-thermal scenario's options (listed after this parser, which the
 * --help check reads up to its end). */
static bool thermal_option(const char *arg);

int cli_parse_scenario(int argc, char **argv, struct scenario_args *out) {
    *out = (struct scenario_args){.seed = 1};
    const char *cmd = "scenario";
    for (int i = 1; i < argc; ++i) {
        const char *arg = argv[i];
        const char *v = NULL;
        if (strcmp(arg, "--seed") == 0) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            if (!cli_parse_u64(v, 0, UINT64_MAX, &out->seed)) {
                return usage_error(cmd, "--seed: expected a non-negative integer", v);
            }
        } else if (strcmp(arg, "--trace-out") == 0) {
            if ((out->trace_out = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
        } else if (strcmp(arg, "--cal-out") == 0) {
            if ((out->cal_out = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
        } else if (thermal_option(arg)) {
            if ((v = option_value(cmd, argc, argv, &i)) == NULL) {
                return -1;
            }
            char *end = NULL;
            errno = 0;
            const double x = strtod(v, &end);
            if (errno != 0 || end == v || *end != '\0' || !isfinite(x)) {
                return usage_error(cmd, "expected a decimal number after", arg);
            }
            if (out->n_thermal == CLI_THERMAL_OPTIONS) {
                return usage_error(cmd, "too many thermal options", arg);
            }
            out->thermal_option[out->n_thermal] = arg;
            out->thermal_value[out->n_thermal++] = x;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            return usage_error(cmd, "unknown option", arg);
        } else if (out->name == NULL) {
            out->name = arg;
        } else {
            return usage_error(cmd, "more than one scenario name given", arg);
        }
    }
    if (out->name == NULL) {
        return usage_error(cmd, "missing scenario NAME", NULL);
    }
    if (out->trace_out == NULL) {
        return usage_error(cmd, "missing --trace-out TRACE.csv", NULL);
    }
    return 0;
}

static const char *const thermal_options[] = {
    "--hours",    "--amplitude-c", "--phase-deg",    "--coeff-range",
    "--coeff-sd", "--walk-um2-h",  "--temp-noise-c", NULL};

static bool thermal_option(const char *arg) {
    for (size_t k = 0; thermal_options[k] != NULL; ++k) {
        if (strcmp(arg, thermal_options[k]) == 0) {
            return true;
        }
    }
    return false;
}

int cli_apply_thermal(const struct scenario_args *a, struct scene_config *cfg) {
    struct scene_thermal *t = &cfg->thermal;
    for (unsigned i = 0; i < a->n_thermal; ++i) {
        const char *opt = a->thermal_option[i];
        const double v = a->thermal_value[i];
        if (!t->on) {
            fprintf(stderr, "host_sim scenario: %s: only for orbit-thermal, not %s\n", opt,
                    cfg->name);
            return -1;
        }
        if (strcmp(opt, "--hours") == 0) {
            if (scene_config_set_hours(cfg, v) != 0) {
                fprintf(stderr, "host_sim scenario: --hours: expected (0, 24], got %g\n", v);
                return -1;
            }
        } else if (strcmp(opt, "--amplitude-c") == 0) {
            t->amplitude_c = v;
        } else if (strcmp(opt, "--phase-deg") == 0) {
            t->phase_deg = v;
        } else if (strcmp(opt, "--coeff-range") == 0) {
            t->coeff_range_mm_per_c = v;
        } else if (strcmp(opt, "--coeff-sd") == 0) {
            t->coeff_sd_mm_per_c = v;
        } else if (strcmp(opt, "--walk-um2-h") == 0) {
            t->walk_um2_h = v;
        } else {
            t->temp_noise_c = v;
        }
    }
    const char *why = t->on ? scene_thermal_check(t) : NULL;
    if (why != NULL) {
        fprintf(stderr, "host_sim scenario: %s: %s\n", cfg->name, why);
        return -1;
    }
    return 0;
}
