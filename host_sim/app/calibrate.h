/*
 * host_sim calibrate CAL_TRACE.csv --out HEAD.cal [--report CAL.json] (docs/reference/tools.md,
 * §6a; docs/how-to/calibrate-a-head.md): fits each sensor's offset and gain from a fixture trace's
 * stations and writes the head-calibration file.
 */
#ifndef HOST_SIM_CALIBRATE_H
#define HOST_SIM_CALIBRATE_H

#include <stdio.h>

/* The subcommand's --help text (cli.c prints it). */
extern const char calibrate_help[];

/* Runs `calibrate` (argv[0] is "calibrate"). Exit status: 0 written, 1 bad input or a
 * trace it cannot fit (stderr "file: what"), 2 bad command line. */
int calibrate_main(int argc, char **argv);

/* Writes the report JSON of a fit (calibrate_report.c). */
struct calfit_data;
struct calfit_result;
int calibrate_write_report(FILE *f, const char *trace, const struct calfit_data *d,
                           const struct calfit_result *res);

#endif /* HOST_SIM_CALIBRATE_H */
