#include "firmware/est_csv.h"

void tof_est_csv_row(struct tof_text *t, uint32_t t_ms, const struct attitude_estimate *e) {
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
    tof_text_str(t, "\n");
}
