/* tof_twin's command line: the options of host_sim replay that the flight image can honour,
 * and the twin's own (--strict, --coverage, --hsi-fail, --spurious-berr, --max-sim-s, and the
 * record storage's --save, --flash-cut, --flash-in, --flash-out). */
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "telemetry/tlm_command_text.h"
#include "tof_twin.h"

static void usage(FILE *f) {
    fputs("usage: tof_twin FIRMWARE.elf TRACE.csv [--estimator consensus|kalman|...] [--window N]\n"
          "                [--mode tumbling|sliding] [--faults SPEC] [--seed S] --out EST.csv\n"
          "                [--uart-out CAPTURE.bin] [--i2c-log BUS.csv] [--strict]\n"
          "                [--coverage FILE] [--report FILE.json] [--hsi-fail]\n"
          "                [--spurious-berr PPM] [--max-sim-s S] [--late-command]\n"
          "                [--save] [--flash-cut N] [--flash-in FILE] [--flash-out FILE]\n"
          "                [--calibration HEAD.cal] [--command ROW:TEXT]...\n",
          f);
}

static bool parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out) {
    errno = 0;
    char *end = NULL;
    const unsigned long long v = strtoull(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || s[0] == '-' || v < lo || v > hi) {
        return false;
    }
    *out = v;
    return true;
}

/* An option that takes a value (argv[*i + 1], which exists): 1 if `o` is one (*i then
 * indexes its value), 0 if not, -1 after a message if the value is not valid. */
static int value_option(const char *o, char **argv, int *i, struct args *a) {
    uint64_t v = 0;
    if (strcmp(o, "--estimator") == 0) {
        a->estimator = argv[++*i];
    } else if (strcmp(o, "--window") == 0) {
        if (!parse_u64(argv[++*i], TLM_WINDOW_MIN, TLM_WINDOW_MAX, &v)) {
            fprintf(stderr,
                    "tof_twin: --window '%s' is not an integer %u..%u (the set-window "
                    "command's range)\n",
                    argv[*i], TLM_WINDOW_MIN, TLM_WINDOW_MAX);
            return -1;
        }
        a->window = (unsigned)v;
    } else if (strcmp(o, "--mode") == 0) {
        const char *m = argv[++*i];
        if (strcmp(m, "tumbling") != 0 && strcmp(m, "sliding") != 0) {
            fprintf(stderr, "tof_twin: --mode '%s' is not tumbling or sliding\n", m);
            return -1;
        }
        a->sliding = strcmp(m, "sliding") == 0;
    } else if (strcmp(o, "--command") == 0) {
        const char *why = a->ncommands == TOF_TWIN_USER_COMMANDS ? "too many --command" : NULL;
        struct user_command *c = &a->commands[a->ncommands];
        why = why != NULL ? why : tlm_command_from_arg(argv[++*i], &c->row, &c->cmd);
        if (why != NULL) {
            fprintf(stderr, "tof_twin: --command '%s': %s\n", argv[*i], why);
            return -1;
        }
        ++a->ncommands;
    } else if (strcmp(o, "--faults") == 0) {
        a->faults = argv[++*i];
    } else if (strcmp(o, "--seed") == 0) {
        if (!parse_u64(argv[++*i], 0, UINT64_MAX, &v)) {
            fprintf(stderr, "tof_twin: --seed '%s' is not a non-negative integer\n", argv[*i]);
            return -1;
        }
        a->seed = v;
    } else if (strcmp(o, "--out") == 0) {
        a->out = argv[++*i];
    } else if (strcmp(o, "--uart-out") == 0) {
        a->uart_out = argv[++*i];
    } else if (strcmp(o, "--i2c-log") == 0) {
        a->i2c_log = argv[++*i];
    } else if (strcmp(o, "--coverage") == 0) {
        a->coverage = argv[++*i];
    } else if (strcmp(o, "--report") == 0) {
        a->report = argv[++*i];
    } else if (strcmp(o, "--spurious-berr") == 0) {
        if (!parse_u64(argv[++*i], 0, 1000000, &v)) {
            fprintf(stderr, "tof_twin: --spurious-berr '%s' is not 0..1000000 ppm\n", argv[*i]);
            return -1;
        }
        a->spurious_berr_ppm = (uint32_t)v;
    } else if (strcmp(o, "--flash-cut") == 0) {
        if (!parse_u64(argv[++*i], 0, UINT32_MAX - 1u, &v)) {
            fprintf(stderr, "tof_twin: --flash-cut '%s' is not a count of flash operations\n",
                    argv[*i]);
            return -1;
        }
        a->flash_cut = (uint32_t)v;
    } else if (strcmp(o, "--flash-in") == 0) {
        a->flash_in = argv[++*i];
    } else if (strcmp(o, "--calibration") == 0) {
        a->calibration = argv[++*i];
    } else if (strcmp(o, "--flash-out") == 0) {
        a->flash_out = argv[++*i];
    } else if (strcmp(o, "--max-sim-s") == 0) {
        a->max_sim_s = strtod(argv[++*i], NULL);
        if (!(a->max_sim_s > 0.0)) {
            fprintf(stderr, "tof_twin: --max-sim-s '%s' is not a positive number\n", argv[*i]);
            return -1;
        }
    } else {
        return 0;
    }
    return 1;
}

/* The positionals and --out are given; a window or mode other than the flight image's
 * needs --late-command. 0, or -1 after a message. */
static int check_settings(const struct args *a) {
    if (a->elf == NULL || a->trace == NULL || a->out == NULL) {
        usage(stderr);
        return -1;
    }
    /* The flight image boots with window 100, tumbling (tof_app_default_config); another
     * window or mode is a set-window command after the boot status frame, applied some
     * 0.3 s after boot, so its windows no longer start at trace row 0 and the rows cannot
     * equal host_sim's (docs/boards.md). Refused unless asked for (the command tests and
     * the coverage run's command path). */
    if ((a->window != FLIGHT_WINDOW || a->sliding) && !a->late_command) {
        fprintf(stderr,
                "tof_twin: --window %u --mode %s: the flight image starts with window %u, "
                "tumbling; other settings arrive by command after boot, and its rows would not "
                "be host_sim's (docs/boards.md). Send them as a host would, to both tools: "
                "--command 0:'set-window N MODE' (DESIGN.md §6), or pass --late-command\n",
                a->window, a->sliding ? "sliding" : "tumbling", FLIGHT_WINDOW);
        return -1;
    }
    if (a->late_command && (a->window != FLIGHT_WINDOW || a->sliding)) {
        fprintf(stderr, "tof_twin: warning: --late-command: the rows are labelled as if the "
                        "commanded windows started at trace row 0; they are not host_sim's\n");
    }
    return 0;
}

int tof_twin_parse_args(int argc, char **argv, struct args *a) {
    *a = (struct args){.estimator = "consensus",
                       .window = FLIGHT_WINDOW,
                       .max_sim_s = 0.0,
                       .flash_cut = TWIN_FLASH_NO_CUT};
    int pos = 0;
    for (int i = 1; i < argc; ++i) {
        const char *o = argv[i];
        const bool has = i + 1 < argc;
        if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(o, "--strict") == 0) {
            a->strict = true;
        } else if (strcmp(o, "--hsi-fail") == 0) {
            a->hsi_fail = true;
        } else if (strcmp(o, "--late-command") == 0) {
            a->late_command = true;
        } else if (strcmp(o, "--save") == 0) {
            a->save = true;
        } else if (o[0] == '-' && o[1] == '-' && !has) {
            fprintf(stderr, "tof_twin: %s needs a value\n", o);
            return -1;
        } else {
            const int took = value_option(o, argv, &i, a);
            if (took < 0) {
                return -1;
            } else if (took > 0) {
                continue;
            } else if (o[0] == '-') {
                fprintf(stderr, "tof_twin: unknown option '%s'\n", o);
                usage(stderr);
                return -1;
            } else if (pos == 0) {
                a->elf = o;
                ++pos;
            } else if (pos == 1) {
                a->trace = o;
                ++pos;
            } else {
                fprintf(stderr, "tof_twin: unexpected argument '%s'\n", o);
                return -1;
            }
        }
    }
    return check_settings(a);
}
