/*
 * host_sim replay's words after the run: the trace's shape (too short, a partial window,
 * irregular time stamps) on stderr, the report JSON (--report) and the summary table on
 * stdout.
 */
#ifndef HOST_SIM_REPLAY_REPORT_H
#define HOST_SIM_REPLAY_REPORT_H

#include "replay_state.h"

/*
 * What the trace's length and time stamps mean for the windows (docs/reference/tools.md: windows
 * are counted in rows, t_ms labels them): a trace shorter than one window is an error;
 * a trailing partial window (kept in r->partial_rows) and irregular time stamps are
 * warnings on stderr (and in the report). Returns 0 or -1.
 */
int replay_report_shape(struct replay *r);

/* Writes the report JSON to path. 0, or -1 (said on stderr). */
int replay_report_write(const struct replay *r, const char *path);

/* Prints the summary table on stdout. */
void replay_report_summary(const struct replay *r);

#endif /* HOST_SIM_REPLAY_REPORT_H */
