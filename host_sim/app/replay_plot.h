/*
 * host_sim replay --plot: every estimator's estimates and the truth per estimate row in a
 * data file next to the figure, drawn by tools/plot_replay.py at the end.
 */
#ifndef HOST_SIM_REPLAY_PLOT_H
#define HOST_SIM_REPLAY_PLOT_H

#include <stdio.h>

#include "estimator/attitude.h"
#include "scene/row.h"

struct replay_plot {
    FILE *data; /* NULL: no plot asked for, or already closed */
    char data_path[4096];
};

/* Opens "<plot_path>.data.csv" and writes its header. 0, or -1 (said on stderr). */
int replay_plot_open(struct replay_plot *p, const char *plot_path);

/* One data row per enabled estimator of out, with row's truth. */
void replay_plot_row(struct replay_plot *p, const struct scene_row *row,
                     const struct attitude_output *out);

/* Closes the data, draws plot_path (titled trace_path) and removes the data. 0, or -1
 * (said on stderr). */
int replay_plot_render(struct replay_plot *p, const char *plot_path, const char *trace_path);

/* Closes and removes the data without drawing (the replay failed). */
void replay_plot_discard(struct replay_plot *p);

#endif /* HOST_SIM_REPLAY_PLOT_H */
