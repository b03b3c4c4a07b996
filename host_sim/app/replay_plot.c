/* host_sim replay --plot: the data file and the call of tools/plot_replay.py (replay_plot.h). */
#include "replay_plot.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#ifndef TOF_SOURCE_DIR
#error "TOF_SOURCE_DIR must name the repository (for tools/plot_replay.py)"
#endif

int replay_plot_open(struct replay_plot *p, const char *plot_path) {
    snprintf(p->data_path, sizeof p->data_path, "%s.data.csv", plot_path);
    p->data = fopen(p->data_path, "w");
    if (p->data == NULL) {
        fprintf(stderr, "host_sim replay: %s: %s\n", p->data_path, strerror(errno));
        return -1;
    }
    fputs("t_ms,estimator,alpha_deg,beta_deg,distance_mm,status,true_alpha_deg,"
          "true_beta_deg,alpha_sd_deg,beta_sd_deg\n",
          p->data);
    return 0;
}

void replay_plot_row(struct replay_plot *p, const struct scene_row *row,
                     const struct attitude_output *out) {
    FILE *f = p->data;
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct attitude_estimate *est = &out->est[e];
        if (est->reason == ATTITUDE_REASON_DISABLED) {
            continue;
        }
        fprintf(f, "%u,%s,", row->t_ms, attitude_estimator_name((enum attitude_estimator)e));
        if (est->alpha_valid) {
            fprintf(f, "%.6f", est->alpha_udeg / 1e6);
        }
        fputc(',', f);
        if (est->beta_valid) {
            fprintf(f, "%.6f", est->beta_udeg / 1e6);
        }
        fprintf(f, ",%.3f,%s,", est->distance_um / 1e3, attitude_status_name(est->status));
        if (row->has_alpha) {
            fprintf(f, "%.6f", row->alpha_deg);
        }
        fputc(',', f);
        if (row->has_beta) {
            fprintf(f, "%.6f", row->beta_deg);
        }
        fputc(',', f);
        if (est->alpha_valid) {
            fprintf(f, "%.6f", est->alpha_sd_udeg / 1e6);
        }
        fputc(',', f);
        if (est->beta_valid) {
            fprintf(f, "%.6f", est->beta_sd_udeg / 1e6);
        }
        fputc('\n', f);
    }
}

int replay_plot_render(struct replay_plot *p, const char *plot_path, const char *trace_path) {
    if (fclose(p->data) != 0) {
        p->data = NULL;
        fprintf(stderr, "host_sim replay: %s: write failed\n", p->data_path);
        return -1;
    }
    p->data = NULL;
    if (strchr(p->data_path, '\'') != NULL || strchr(trace_path, '\'') != NULL) {
        fprintf(stderr,
                "host_sim replay: --plot: paths with a quote character are not supported\n");
        return -1;
    }
    char cmd[12288];
    snprintf(cmd, sizeof cmd, "/usr/bin/python3 '%s/tools/plot_replay.py' '%s' '%s' --title '%s'",
             TOF_SOURCE_DIR, p->data_path, plot_path, trace_path);
    const int rc = system(cmd);
    if (rc != 0) {
        fprintf(stderr,
                "host_sim replay: plotting failed (status %d); is python3-matplotlib installed? "
                "(tools/setup.sh)\n",
                rc);
        return -1;
    }
    remove(p->data_path);
    return 0;
}

void replay_plot_discard(struct replay_plot *p) {
    if (p->data != NULL) {
        fclose(p->data);
        p->data = NULL;
        remove(p->data_path);
    }
}
