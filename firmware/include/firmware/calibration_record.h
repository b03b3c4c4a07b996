/*
 * The head's calibration kept in the record (firmware/record.h) as section 2
 * (TOF_SECTION_CALIBRATION, firmware/settings.h), and applied at boot to the estimator's
 * configuration (attitude_config.calibration, estimator/calibration.h).
 *
 * Section 2 version 3, 116 bytes, little-endian (docs/explanation/firmware.md, "Records"):
 *
 *     0 u32 head_id      the head it was made on: the number the user gave the head
 *                        (HEAD.cal key `head_id`; 0 = none), compared with the image's
 *                        tof_app_config.head_id
 *     4 u8  distance mode (1 short, 2 long: enum vl53_distance_mode)
 *     5 u8  flags: bit 0 gains fitted (else the gain bytes are 0 and the gain sd is the
 *                  parts' spread, CALIBRATION_UNCAL_GAIN_SD_PPM); bits 1-7 are 0
 *     6 u16 timing budget, ms
 *     8 + 18·i, sensor i = A, B, C, D:
 *           i32 offset_um  i32 gain_ppm (gain − 1)  u32 offset_sd_um  u32 gain_sd_ppm
 *           i16 offset_gain_corr_q15
 *    80 + 8·i, sensor i = A, B, C, D: u64 part_id, the part's own NVM identity (lot, wafer,
 *           die X/Y: vl53_part_id()) it was made with; 0: not bound (holds for any part)
 *   112 i32 arm_um   the arm in force when it was written (set-arm changes it); 0: not bound
 *
 * Version 1 is bytes 0..79 alone (80 bytes), version 2 bytes 0..111: still read, not bound
 * to parts (version 1) or an arm (versions 1 and 2). The telemetry commands carry that version-1
 * form (84 bytes with the header); what the firmware stores on board is version 2 with the running
 * parts' identities.
 *
 * A section is applied only when the record is valid, the section's version is 1 or 2, its
 * values are within estimator/calibration.h's bounds, and head, parts, distance mode and
 * timing budget and arm are the running image's; anything else leaves the head uncalibrated (never
 * `ok`) and says why (enum tof_cal_state, the status frame's `calibration` byte).
 */
#ifndef FIRMWARE_CALIBRATION_RECORD_H
#define FIRMWARE_CALIBRATION_RECORD_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/calibration.h"
#include "firmware/app.h"
#include "firmware/record.h"
#include "firmware/settings.h"

#define TOF_CALIBRATION_VERSION   3u
#define TOF_CALIBRATION_LENGTH    116u
#define TOF_CALIBRATION_V2_LENGTH 112u /* also the arm's offset in version 3 */
#define TOF_CALIBRATION_V1_LENGTH 80u  /* also the parts' identities' offset in version 2 */
/* The version-1 form the telemetry commands carry: header and 80 bytes. */
#define TOF_CAL_WIRE_SIZE  (TOF_SECTION_HEADER + TOF_CALIBRATION_V1_LENGTH)
#define TOF_CAL_FLAG_GAINS 0x01u

/* What boot found of the calibration, the status frame's `calibration` byte
 * (docs/reference/telemetry-protocol.md §5.5). Every state but APPLIED leaves the head
 * uncalibrated. */
enum tof_cal_state {
    TOF_CAL_NONE = 0,         /* no calibration section (nothing stored, or never sent) */
    TOF_CAL_APPLIED = 1,      /* a section of this head and configuration, in force */
    TOF_CAL_CORRUPT = 2,      /* no valid record, or a section with values out of range */
    TOF_CAL_VERSION = 3,      /* a record or section version this firmware does not read */
    TOF_CAL_OTHER_HEAD = 4,   /* made on another head (head_id differs) */
    TOF_CAL_OTHER_MODE = 5,   /* made in another distance mode */
    TOF_CAL_REJECTED = 6,     /* valid, but the estimator refused it */
    TOF_CAL_NO_STORAGE = 7,   /* the board has no record storage */
    TOF_CAL_OTHER_PARTS = 8,  /* made with other parts (a part's NVM identity differs) */
    TOF_CAL_OTHER_BUDGET = 9, /* made at another timing budget */
    TOF_CAL_OTHER_ARM = 10,   /* made at another arm */
};
#define TOF_CAL_STATE_LAST TOF_CAL_OTHER_ARM

/* The configuration a calibration was made in (and the head and parts it was made on). */
struct tof_cal_binding {
    uint32_t head_id;
    uint8_t mode;                          /* enum vl53_distance_mode */
    uint16_t budget_ms;                    /* the parts' timing budget */
    uint64_t part_id[CALIBRATION_SENSORS]; /* each part's NVM identity; 0: not bound */
    int32_t arm_um;                        /* the arm; 0: not bound */
};

/* The section in its version-1 form (TOF_CAL_WIRE_SIZE bytes, header included: what the
 * telemetry commands carry; bind->part_id is not in it) of `cal` made in `bind`. HAL_OK, or
 * HAL_ERR_INVALID (nothing written) for a `cal` that is not calibrated or out of
 * estimator/calibration.h's bounds. `has_gain` false: gains not fitted (gain_ppm must be 0;
 * the gain sd is not stored). */
int tof_cal_encode(const struct calibration_head *cal, bool has_gain,
                   const struct tof_cal_binding *bind, uint8_t *out);

/* The version-3 section (TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH bytes) made of the
 * version-1, -2 or -3 section `section` (its header says which) with part i bound to
 * `part_id[i]` where `section` binds it to none (0 or version 1), and the arm kept (version
 * 3) or not bound (0). HAL_OK, or HAL_ERR_INVALID (nothing written) for another header. */
int tof_cal_bind_parts(const uint8_t *section, const uint64_t part_id[CALIBRATION_SENSORS],
                       uint8_t *out);

/* Bind the version-3 section `section` (as tof_cal_bind_parts() makes it) to `arm_um` when
 * it is bound to none. */
void tof_cal_bind_arm(uint8_t *section, int32_t arm_um);

/* Find section 2 in `payload` (`len` bytes) and decode it (version 1 or 2): TOF_CAL_APPLIED
 * with *cal and *bind filled (nothing checked against an image yet; version 1: every
 * part_id 0); NONE; VERSION; CORRUPT (sections that do not add up, a wrong length for the
 * version, a value out of bounds, a reserved bit set). */
enum tof_cal_state tof_cal_decode(const uint8_t *payload, uint16_t len,
                                  struct calibration_head *cal, struct tof_cal_binding *bind);

/* Whether a calibration made in `bind` holds for an image configured as `cfg` whose parts
 * have the NVM identities `running` (0: unknown, e.g. a part that did not come up; NULL: all
 * unknown): APPLIED, OTHER_HEAD, OTHER_PARTS (a part bound in `bind` and known running with
 * another identity), OTHER_MODE, OTHER_BUDGET or OTHER_ARM (an arm bound in `bind` and not
 * the configuration's), the first that applies in this order. */
enum tof_cal_state tof_cal_check(const struct tof_cal_binding *bind,
                                 const struct tof_app_config *cfg,
                                 const uint64_t running[CALIBRATION_SENSORS]);

/* The NVM identities of `app`'s parts as the bring-up (or a recovery) read them, 0 where
 * none was read. */
void tof_cal_running_parts(const struct tof_app *app, uint64_t running[CALIBRATION_SENSORS]);

/*
 * At boot, after tof_app_init() (and tof_settings_boot(), which it does not disturb): load
 * the record from `store` (NULL: no storage), and apply its calibration section to the
 * estimator (tof_app_set_calibration()) when it holds for this image. Anything else leaves
 * the configuration's calibration (an uncalibrated head unless the image says otherwise).
 * Returns what happened.
 */
enum tof_cal_state tof_cal_boot(struct tof_record_store *store, struct tof_app *app);

/*
 * The stored calibration (the record in use, `store` as loaded) checked again against the
 * configuration in force, after it changed (the set-period command changes the timing
 * budget): applied when it holds, else the configuration's own calibration (uncalibrated)
 * is put in force. Returns what happened, as tof_cal_boot().
 */
enum tof_cal_state tof_cal_recheck(const struct tof_record_store *store, struct tof_app *app);

/*
 * The write-calibration command (docs/reference/telemetry-protocol.md): `section` (version 1,
 * TOF_CAL_WIRE_SIZE bytes as the command carries it, or version 2, TOF_SECTION_HEADER +
 * TOF_CALIBRATION_LENGTH bytes; its header says which) is decoded and checked against this
 * image (head, parts, distance mode, budget), saved into the record as version 2 bound to
 * the running parts and arm (tof_cal_bind_parts(), tof_cal_bind_arm(); other sections kept)
 * and put in force. Returns
 * APPLIED; CORRUPT or VERSION (nothing done); OTHER_HEAD, OTHER_PARTS, OTHER_MODE or
 * OTHER_BUDGET (refused: it would not hold here); NO_STORAGE or REJECTED with *error the storage's
 * hal code or the estimator's attitude_error (the record and the estimator as before).
 */
enum tof_cal_state tof_cal_write(struct tof_record_store *store, struct tof_app *app,
                                 const uint8_t *section, int *error);

/* As tof_cal_write() for `cal` made in this image's configuration (the re-zero's result);
 * its gains count as fitted unless all four are 0 with the parts' spread as sd. */
enum tof_cal_state tof_cal_write_head(struct tof_record_store *store, struct tof_app *app,
                                      const struct calibration_head *cal, int *error);

/* The calibration section of the record in use into `section` in its version-1 form
 * (TOF_CAL_WIRE_SIZE bytes: what read-calibration sends; the parts' identities are not in
 * it), or zeros when there is none. */
void tof_cal_read(const struct tof_record_store *store, uint8_t *section);

/* Which calibration the record in use holds, for its age (firmware/cal_age.h): the CRC-16 of
 * its calibration section (header and body as stored), or 0 when it holds none. */
uint16_t tof_cal_tag(const struct tof_record_store *store);

/* The binding of the running image (its head id, distance mode, timing budget; part_id 0). */
struct tof_cal_binding tof_cal_binding_of(const struct tof_app_config *cfg);

#endif /* FIRMWARE_CALIBRATION_RECORD_H */
