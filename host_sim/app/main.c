/*
 * host_sim: the host target. Replays recorded traces and scenarios through the
 * real firmware path (simulated I²C bus, VL53 models, drivers, fault manager,
 * estimators), writes scenario traces, and runs the synthetic ToF camera.
 * Command line: docs/reference/tools.md (cli.h).
 */
#include <stdio.h>
#include <string.h>

#include "camera/camera_cmd.h"
#include "calibrate.h"
#include "calibrate/fixture.h"
#include "calibrate/head_cal.h"
#include "campaign.h"
#include "cli.h"
#include "replay.h"
#include "scene/scenario.h"
#include "scene/scene_io.h"
#include "scene/thermal.h"

static void usage(FILE *f) {
    fputs(
        "usage:\n"
        "  host_sim replay TRACE.csv [--estimator consensus|consensus-paper|kalman|mean]\n"
        "                  [--window N] [--mode tumbling|sliding] [--out EST.csv]\n"
        "                  [--report REPORT.json] [--plot FIG.png] [--faults SPEC] [--seed S]\n"
        "                  [--faults-until ROW] [--i2c-log BUS.csv]\n"
        "                  [--process-noise QD,QT|auto] [--distance-mode short|long]\n"
        "                  [--calibration HEAD.cal] [--command ROW:TEXT]... [--quiet]\n"
        "  host_sim scenario NAME [--seed S] --trace-out TRACE.csv [--hours H] [--amplitude-c A]\n"
        "                  [--phase-deg P] [--coeff-range K] [--coeff-sd S] [--walk-um2-h W]\n"
        "                  [--temp-noise-c N]   (orbit-thermal)\n"
        "  host_sim calibrate CAL_TRACE.csv --out HEAD.cal [--report CAL.json]\n"
        "  host_sim camera --frames K --range-mm R ... (see docs/explanation/pose.md)\n"
        "  host_sim campaign [--trace T.csv] [--seed S] [--markdown FILE.md]\n"
        "  host_sim SUBCOMMAND --help   (each subcommand's options)\n"
        "fault SPEC: kind=probability[,...] per bus transaction, kinds:\n"
        "  nack stretch reset drdy_high drdy_low garbage bitflip stuck "
        "(docs/explanation/driver-and-bus.md)\n"
        "scenarios:",
        f);
    for (size_t i = 0; scene_scenario_names[i] != NULL; ++i) {
        fprintf(f, " %s", scene_scenario_names[i]);
    }
    for (size_t i = 0; fixture_names[i] != NULL; ++i) {
        fprintf(f, " %s", fixture_names[i]);
    }
    fputc('\n', f);
}

/* --cal-out's file as the trace names it: relative to the trace's folder, so the file must be
 * in it (cal_apply.h reads calibration=FILE beside the trace). 0, or -1 after a message. */
static int cal_file_name(const struct scenario_args *a, struct scene_config *cfg) {
    const char *name = a->cal_out;
    const char *slash = strrchr(name, '/');
    const char *tslash = strrchr(a->trace_out, '/');
    const size_t dir = slash != NULL ? (size_t)(slash - name) + 1u : 0u;
    const size_t tdir = tslash != NULL ? (size_t)(tslash - a->trace_out) + 1u : 0u;
    if (!cfg->thermal.on) {
        fprintf(stderr, "host_sim scenario: --cal-out: only for orbit-thermal, not %s\n",
                cfg->name);
        return -1;
    }
    if (strcmp(a->trace_out, "-") == 0 || dir != tdir || strncmp(name, a->trace_out, dir) != 0 ||
        name[dir] == '\0' || strlen(name + dir) >= sizeof cfg->thermal.calibration_file) {
        fprintf(stderr,
                "host_sim scenario: --cal-out: '%s' must be a file in the trace's folder (the "
                "trace names it relative to itself), the trace a file\n",
                name);
        return -1;
    }
    snprintf(cfg->thermal.calibration_file, sizeof cfg->thermal.calibration_file, "%s", name + dir);
    return 0;
}

/* The orbit-thermal head's calibration as the trace would state it inline (its offsets at
 * cal_temp_c exactly, gains 1, the coefficients as stated with their sd), as a HEAD.cal. */
static int write_thermal_cal(const struct scenario_args *a, const struct scene_config *cfg) {
    struct scene_thermal_head h;
    scene_thermal_draw(&h, &cfg->thermal, a->seed);
    struct head_cal cal = {.has_gain = true, .thermal = true};
    cal.cal_temp_c = cfg->thermal.cal_temp_c;
    for (unsigned k = 0; k < 4u; ++k) {
        cal.offset_mm[k] = h.offset_mm[k];
        cal.gain[k] = 1.0;
        cal.temp_coeff_mm_per_c[k] = h.stated_mm_per_c[k];
        cal.temp_coeff_sd_mm_per_c[k] = cfg->thermal.coeff_sd_mm_per_c;
    }
    char source[HEAD_CAL_VALUE_MAX];
    snprintf(source, sizeof source, "source=scenario %s seed %llu", cfg->name,
             (unsigned long long)a->seed);
    const char *const extra[] = {source, NULL};
    FILE *f = fopen(a->cal_out, "wb");
    int rc = f != NULL ? head_cal_write(f, &cal, extra) : -1;
    if (f != NULL && fclose(f) != 0) {
        rc = -1;
    }
    if (rc != 0) {
        fprintf(stderr, "host_sim scenario: %s: cannot write the calibration\n", a->cal_out);
        remove(a->cal_out);
        return 1;
    }
    return 0;
}

static int scenario_main(int argc, char **argv) {
    struct scenario_args args;
    if (cli_parse_scenario(argc, argv, &args) != 0) {
        return 2;
    }
    char err[512];
    struct fixture_config fixture;
    if (fixture_named(args.name, &fixture) == 0) { /* a calibration fixture (calibrate.h) */
        if (args.n_thermal > 0u || args.cal_out != NULL) {
            fprintf(stderr, "host_sim scenario: %s: only for orbit-thermal, not %s\n",
                    args.n_thermal > 0u ? args.thermal_option[0] : "--cal-out", args.name);
            return 2;
        }
        if (fixture_write(args.name, args.seed, args.trace_out, err, sizeof err) != 0) {
            fprintf(stderr, "host_sim scenario: %s\n", err);
            return 1;
        }
        return 0;
    }
    struct scene_config cfg;
    if (scene_config_named_listed(args.name, &cfg, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim scenario: %s\n", err);
        return 1;
    }
    if (cli_apply_thermal(&args, &cfg) != 0 ||
        (args.cal_out != NULL && cal_file_name(&args, &cfg) != 0)) {
        return 2;
    }
    if (scene_write_scenario_config(&cfg, args.seed, args.trace_out, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim scenario: %s\n", err);
        return 1;
    }
    return args.cal_out != NULL ? write_thermal_cal(&args, &cfg) : 0;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    const char *cmd = argv[1];
    /* `host_sim SUBCOMMAND --help`: the options, exit status 0 (the camera prints its own). */
    if (strcmp(cmd, "camera") != 0 && cli_wants_help(argc - 1, argv + 1) &&
        cli_print_help(cmd, scene_scenario_names, stdout)) {
        return 0;
    }
    if (strcmp(cmd, "replay") == 0) {
        struct replay_args args;
        if (cli_parse_replay(argc - 1, argv + 1, &args) != 0) {
            return 2;
        }
        return replay_run(&args);
    }
    if (strcmp(cmd, "scenario") == 0) {
        return scenario_main(argc - 1, argv + 1);
    }
    if (strcmp(cmd, "campaign") == 0) {
        return campaign_main(argc - 1, argv + 1);
    }
    if (strcmp(cmd, "calibrate") == 0) {
        return calibrate_main(argc - 1, argv + 1);
    }
    if (strcmp(cmd, "camera") == 0) {
        return host_sim_camera_main(argc - 1, argv + 1);
    }
    if (strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0 || strcmp(cmd, "help") == 0) {
        usage(stdout);
        return 0;
    }
    fprintf(stderr, "host_sim: unknown command '%s'\n", cmd);
    usage(stderr);
    return 2;
}
