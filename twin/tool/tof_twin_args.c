/* tof_twin's command line: the options of host_sim replay that the flight image can honour,
 * and the twin's own (--strict, --coverage, --hsi-fail, --spurious-berr, --max-sim-s, and the
 * record storage's --save, --flash-cut, --flash-in, --flash-out). */
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "telemetry/tlm_command_text.h"
#include "tof_twin.h"

static void usage(FILE *f) {
    fputs("usage: tof_twin FIRMWARE.elf TRACE.csv --out EST.csv [options]\n"
          "       tof_twin FIRMWARE.elf TRACE.csv --pty [--flash-in FILE] [--flash-out FILE] "
          "[options]\n"
          "The flight ELF on the emulated STM32L476 against the simulated sensor head fed by "
          "TRACE.csv\n"
          "(README \"Digital twin\", docs/reference/tools.md). Its EST.csv rows equal host_sim "
          "replay's.\n"
          "\n"
          "host_sim replay's options the flight image honours:\n"
          "  --estimator NAME      consensus (default), consensus-paper, kalman or mean: the "
          "rows of EST.csv\n"
          "  --window N            2..255 (default 100, the image's; another needs "
          "--late-command)\n"
          "  --mode tumbling|sliding  (default tumbling; sliding needs --late-command)\n"
          "  --faults SPEC         sensor and bus faults (host_sim replay --faults)\n"
          "  --seed S              seed of the faults (default 0)\n"
          "  --calibration HEAD.cal  the head's calibration, preloaded as the stored record's "
          "section\n"
          "                        (written to the record: says so on stderr; refused: says why)\n"
          "  --command ROW:TEXT    a command (tof_telemetry.py --send syntax) sent when trace "
          "row ROW\n"
          "                        is sampled; repeatable, in order (at most 16)\n"
          "  --i2c-log BUS.csv     every I2C transaction (t_us,addr,write,read,result)\n"
          "Outputs:\n"
          "  --out EST.csv         the estimates (required unless --pty)\n"
          "  --uart-out CAPTURE.bin  every byte the firmware sent on USART2\n"
          "  --report FILE.json    the run's figures (watchdog_resets, hardfaults, "
          "loop_overruns,\n"
          "                        loop_max_us, uart_overruns, commands_sent, commands_acked, "
          "pty_*, ...)\n"
          "  --coverage FILE       executed flash address ranges\n"
          "The serial line:\n"
          "  --pty                 USART2 on a pseudo-terminal: the first line on stdout is "
          "`pty PATH`\n"
          "                        (tools/tof_telemetry.py --port PATH). Simulated time never "
          "runs\n"
          "                        ahead of the host's clock while a line is open; with none "
          "open the\n"
          "                        twin runs free until the trace's first pass is over. The "
          "trace\n"
          "                        loops; the run ends on SIGINT or SIGTERM (or --max-sim-s), "
          "then\n"
          "                        writes --flash-out and --report\n"
          "Storage (the record pages, 4096 bytes: settings and calibration):\n"
          "  --flash-in FILE       the record pages at power-on (a unit's storage from an "
          "earlier run)\n"
          "  --flash-out FILE      the record pages at the end of the run\n"
          "  --save                send `save` once the options' settings are in force\n"
          "  --flash-cut N         power cut at the Nth flash erase or double-word program\n"
          "The twin's own:\n"
          "  --late-command        accept a window or mode the rows cannot match (they arrive "
          "by command)\n"
          "  --strict              stop at the first access the reference manual forbids\n"
          "  --hsi-fail            HSI16 never becomes ready (the firmware's clock fallback)\n"
          "  --spurious-berr PPM   errata ES0250 spurious BERR on PPM of the I2C bytes "
          "(0..1000000)\n"
          "  --max-sim-s S         stop after S seconds of simulated time (default: the trace "
          "+ 30 s)\n"
          "  --help, -h            this text\n"
          "Exit status: 0 done; 1 the run or an output failed (message on stderr); 2 bad "
          "options.\n",
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
    if (a->elf == NULL || a->trace == NULL || (a->out == NULL && !a->pty)) {
        fprintf(stderr, "tof_twin: %s\n",
                a->elf == NULL     ? "missing FIRMWARE.elf"
                : a->trace == NULL ? "missing TRACE.csv"
                                   : "missing --out EST.csv (or --pty)");
        usage(stderr);
        return -1;
    }
    /* The flight image boots with window 100, tumbling (tof_app_default_config); another
     * window or mode is a set-window command after the boot status frame, applied some
     * 0.3 s after boot, so its windows no longer start at trace row 0 and the rows cannot
     * equal host_sim's (docs/explanation/boards.md). Refused unless asked for (the command tests
     * and the coverage run's command path). */
    if ((a->window != FLIGHT_WINDOW || a->sliding) && !a->late_command) {
        fprintf(
            stderr,
            "tof_twin: --window %u --mode %s: the flight image starts with window %u, "
            "tumbling; other settings arrive by command after boot, and its rows would not "
            "be host_sim's (docs/explanation/boards.md). Send them as a host would, to both tools: "
            "--command 0:'set-window N MODE' (docs/reference/tools.md), or pass --late-command\n",
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
        } else if (strcmp(o, "--pty") == 0) {
            a->pty = true;
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
