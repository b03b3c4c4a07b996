/*
 * host_sim calibrate CAL_TRACE.csv --out HEAD.cal [--report CAL.json] (docs/reference/tools.md,
 * §6a; docs/how-to/calibrate-a-head.md): fits each sensor's offset and gain from a fixture trace's
 * stations and writes the head-calibration file.
 */
#ifndef HOST_SIM_CALIBRATE_H
#define HOST_SIM_CALIBRATE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

/* The subcommand's --help text (cli.c prints it). */
extern const char calibrate_help[];

/* Runs `calibrate` (argv[0] is "calibrate"). Exit status: 0 written, 1 bad input or a
 * trace it cannot fit (stderr "file: what"), 2 bad command line. */
int calibrate_main(int argc, char **argv);

/*
 * Checks a fit's scatter (calibrate_scatter.c): every sensor alike fitting another arm, or a
 * sensor's scatter ratio above 100, refuses; a ratio above 3 is named on stderr with its likely
 * cause (temperature, arm, motion within stations); above 10 with a cause between stations
 * it refuses unless `accept`, and then `accepted` gets the HEAD.cal key saying so
 * ("scatter_accepted=B 21.23", else ""). 0: write, -1: nothing to be written (said).
 */
struct calfit_data;
struct calfit_result;
int calibrate_check_scatter(const char *trace, const struct calfit_data *d,
                            const struct calfit_result *res, bool accept, char *accepted,
                            size_t accepted_len);

/* Why the offsets' temperature coefficients were or were not fitted, one phrase for stderr
 * and the report ("fitted", or "the stations span 6.02 C (...), less than ...";
 * calibrate_report.c). */
#define CALIBRATE_THERMAL_WHY_MAX 256u
void calibrate_thermal_why(const struct calfit_data *d, const struct calfit_result *res, char *buf,
                           size_t len);

/* Writes the report JSON of a fit (calibrate_report.c). */
int calibrate_write_report(FILE *f, const char *trace, const struct calfit_data *d,
                           const struct calfit_result *res);

#endif /* HOST_SIM_CALIBRATE_H */
