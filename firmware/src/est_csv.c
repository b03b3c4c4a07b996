/* The estimate CSV rows of docs/reference/tools.md, integer text only (see firmware/est_csv.h). */
#include "firmware/est_csv.h"

void tof_est_csv_row(struct tof_text *t, uint32_t t_ms, const struct attitude_estimate *e,
                     bool temp_known, int16_t temp_cdeg) {
    tof_text_u64(t, t_ms);
    tof_text_str(t, ",");
    if (e->alpha_valid) {
        tof_text_fixed(t, e->alpha_udeg, 6);
    }
    tof_text_str(t, ",");
    if (e->beta_valid) {
        tof_text_fixed(t, e->beta_udeg, 6);
    }
    tof_text_str(t, ",");
    if (e->distance_valid) {
        tof_text_fixed(t, e->distance_um, 3);
    }
    tof_text_str(t, ",");
    tof_text_str(t, attitude_status_name(e->status));
    /* an sd only beside a value: an unobservable axis has none (never a claimed 0) */
    tof_text_str(t, ",");
    if (e->alpha_valid) {
        tof_text_fixed(t, e->alpha_sd_udeg, 6);
    }
    tof_text_str(t, ",");
    if (e->beta_valid) {
        tof_text_fixed(t, e->beta_sd_udeg, 6);
    }
    tof_text_str(t, ",");
    if (e->distance_valid) {
        tof_text_fixed(t, e->distance_sd_um, 3);
    }
    tof_text_str(t, ",");
    char why[ATTITUDE_WHY_TEXT_MAX];
    if (attitude_why_format(e->why, why, sizeof why) < 0) {
        t->overflow = 1; /* cannot happen with ATTITUDE_WHY_TEXT_MAX: say so rather than lie */
    }
    tof_text_str(t, why);
    tof_text_str(t, ",");
    if (temp_known) {
        tof_text_fixed(t, temp_cdeg, 2);
    }
    tof_text_str(t, "\n");
}
