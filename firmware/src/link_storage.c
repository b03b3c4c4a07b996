/* The link's record storage table (firmware/link_storage.h): the storage modules' functions. */
#include "firmware/link_storage.h"

const struct tof_link_storage_ops tof_link_storage = {
    .settings_boot = tof_settings_boot,
    .settings_save_begin = tof_settings_save_begin,
    .record_step = tof_record_step,
    .record_busy = tof_record_busy,
    .cal_boot = tof_cal_boot,
    .cal_recheck = tof_cal_recheck,
    .cal_write = tof_cal_write,
    .cal_write_head = tof_cal_write_head,
    .cal_read = tof_cal_read,
    .cal_tag = tof_cal_tag,
    .rezero_fit = tof_rezero_fit,
    .age_restart = tof_cal_age_restart,
    .age_now_s = tof_cal_age_now_s,
    .age_poll = tof_cal_age_poll,
};
