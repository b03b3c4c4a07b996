/*
 * What the telemetry link does with record storage, as one table of the storage modules'
 * functions (firmware/record.h, settings.h, calibration_record.h, cal_age.h, rezero.h).
 * A board with storage hands tof_link_storage to tof_link_set_records(); a board without
 * never names it, so none of that code is linked into its image: the NUCLEO-G071RB's 64 KiB
 * hold every estimator feature only without it (docs/explanation/boards.md, "Records").
 * The link answers every storage command of such a board as `no-storage`.
 */
#ifndef FIRMWARE_LINK_STORAGE_H
#define FIRMWARE_LINK_STORAGE_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/app.h"
#include "firmware/cal_age.h"
#include "firmware/calibration_record.h"
#include "firmware/record.h"
#include "firmware/rezero.h"
#include "firmware/settings.h"

struct tof_link_storage_ops {
    enum tof_record_state (*settings_boot)(struct tof_record_store *store, struct tof_app *app,
                                           struct tof_settings *out);
    int (*settings_save_begin)(struct tof_record_store *store, const struct tof_settings *s);
    int (*record_step)(struct tof_record_store *store);
    bool (*record_busy)(const struct tof_record_store *store);
    enum tof_cal_state (*cal_boot)(struct tof_record_store *store, struct tof_app *app);
    enum tof_cal_state (*cal_recheck)(const struct tof_record_store *store, struct tof_app *app);
    enum tof_cal_state (*cal_write)(struct tof_record_store *store, struct tof_app *app,
                                    const uint8_t *section, int *error);
    enum tof_cal_state (*cal_write_head)(struct tof_record_store *store, struct tof_app *app,
                                         const struct calibration_head *cal, int *error);
    void (*cal_read)(const struct tof_record_store *store, uint8_t *section);
    uint16_t (*cal_tag)(const struct tof_record_store *store);
    bool (*rezero_fit)(const struct tof_rezero *z, const struct calibration_head *cal,
                       struct calibration_head *out);
    int (*age_restart)(struct tof_cal_age *age, uint16_t tag, uint64_t now_us);
    uint32_t (*age_now_s)(const struct tof_cal_age *age, uint64_t now_us);
    int (*age_poll)(struct tof_cal_age *age, uint64_t now_us);
};

/* The storage modules themselves. */
extern const struct tof_link_storage_ops tof_link_storage;

#endif /* FIRMWARE_LINK_STORAGE_H */
