/*
 * The head's calibration kept in the record (firmware/record.h) as section 2
 * (TOF_SECTION_CALIBRATION, firmware/settings.h), and applied at boot to the estimator's
 * configuration (attitude_config.calibration, estimator/calibration.h).
 *
 * Section 2 version 5, 150 bytes, little-endian (docs/reference/calibration-file.md, "The
 * record"):
 *
 *     0 u32 head_id      the head it was made on: the number the user gave the head
 *                        (HEAD.cal key `head_id`; 0 = none), compared with the image's
 *                        tof_app_config.head_id
 *     4 u8  distance mode (1 short, 2 long: enum vl53_distance_mode)
 *     5 u8  flags: bit 0 gains fitted (else the gain bytes are 0 and the gain sd is the
 *                  parts' spread, CALIBRATION_UNCAL_GAIN_SD_PPM); bit 1 thermal (the
 *                  offsets' temperature coefficients were measured, else bytes 80..113 are
 *                  0); bits 2-7 are 0
 *     6 u16 timing budget, ms
 *     8 + 18·i, sensor i = A, B, C, D:
 *           i32 offset_um  i32 gain_ppm (gain − 1)  u32 offset_sd_um  u32 gain_sd_ppm
 *           i16 offset_gain_corr_q15
 *    80 i16 cal_temp_cdeg  the temperature at which offset_um holds, 0.01 °C
 *    82 + 8·i, sensor i = A, B, C, D:
 *           i32 temp_coeff_nm_per_c (d offset / dT)  u32 temp_coeff_sd_nm_per_c (its 1σ)
 *   114 + 8·i, sensor i = A, B, C, D: u64 part_id, the part's own NVM identity (lot, wafer,
 *           die X/Y: vl53_part_id()) it was made with; 0: not bound (holds for any part)
 *   146 i32 arm_um   the arm in force when it was written (set-arm changes it); 0: not bound
 *
 * Version 4 is bytes 0..113 alone (114 bytes): the form the telemetry commands carry (118
 * bytes with the header), bound to neither parts nor an arm; what the firmware stores on
 * board is version 5 with the running parts' identities and arm.
 *
 * The versions before the thermal fields are still read, as a calibration without them
 * (thermal false: the offsets hold at whatever temperature the head is): version 1 is
 * bytes 0..79 alone (80 bytes), version 2 is version 1 and the parts at 80 + 8·i (112
 * bytes), version 3 is version 2 and the arm at 112 (116 bytes); flag bit 1 is reserved
 * (0) in them. Versions 1 and 4 bind no parts, versions 1, 2 and 4 no arm.
 *
 * A section is applied only when the record is valid, the section's version is 1 to 5, its
 * length is its version's, its values are within estimator/calibration.h's bounds (a field
 * out of them is named: enum tof_cal_field), the thermal fields are 0 without the thermal
 * flag, and head, parts, distance mode and timing budget and arm are the running image's;
 * anything else leaves the head uncalibrated (never `ok`) and says why (enum tof_cal_state,
 * the status frame's `calibration` byte).
 */
#ifndef FIRMWARE_CALIBRATION_RECORD_H
#define FIRMWARE_CALIBRATION_RECORD_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/calibration.h"
#include "firmware/app.h"
#include "firmware/record.h"
#include "firmware/settings.h"

#define TOF_CALIBRATION_VERSION      5u
#define TOF_CALIBRATION_LENGTH       150u
#define TOF_CALIBRATION_WIRE_VERSION 4u   /* the first with the thermal fields */
#define TOF_CALIBRATION_V4_LENGTH    114u /* also the parts' identities' offset in version 5 */
#define TOF_CALIBRATION_V3_LENGTH    116u
#define TOF_CALIBRATION_V2_LENGTH    112u /* also the arm's offset in version 3 */
#define TOF_CALIBRATION_V1_LENGTH    80u /* also the parts' (v2, v3), the thermal fields' (v4, v5) */
/* The version-4 form the telemetry commands carry: header and 114 bytes. */
#define TOF_CAL_WIRE_SIZE    (TOF_SECTION_HEADER + TOF_CALIBRATION_V4_LENGTH)
#define TOF_CAL_FLAG_GAINS   0x01u
#define TOF_CAL_FLAG_THERMAL 0x02u /* versions 4 and 5 */

/* Which field of a section tof_cal_decode() refused (the first it found wrong). */
enum tof_cal_field {
    TOF_CAL_FIELD_NONE = 0,       /* none: decoded, or no section at all */
    TOF_CAL_FIELD_HEADER = 1,     /* sections that do not add up, or a length not the version's */
    TOF_CAL_FIELD_FLAGS = 2,      /* a reserved flag bit set */
    TOF_CAL_FIELD_MODE = 3,       /* a distance mode other than 1 or 2 */
    TOF_CAL_FIELD_BUDGET = 4,     /* timing budget 0 */
    TOF_CAL_FIELD_OFFSET = 5,     /* |offset_um| > CALIBRATION_OFFSET_MAX_UM */
    TOF_CAL_FIELD_GAIN = 6,       /* |gain_ppm| > CALIBRATION_GAIN_MAX_PPM, or not fitted */
    TOF_CAL_FIELD_OFFSET_SD = 7,  /* offset_sd_um > CALIBRATION_OFFSET_MAX_UM */
    TOF_CAL_FIELD_GAIN_SD = 8,    /* gain_sd_ppm > CALIBRATION_GAIN_MAX_PPM, or not fitted */
    TOF_CAL_FIELD_TEMP_COEFF = 9, /* |.| > CALIBRATION_TEMP_COEFF_MAX_NM_PER_C, or not thermal */
    TOF_CAL_FIELD_TEMP_COEFF_SD = 10, /* > CALIBRATION_TEMP_COEFF_MAX_NM_PER_C, or not thermal */
    TOF_CAL_FIELD_CAL_TEMP = 11,      /* outside CALIBRATION_TEMP_MIN/MAX_CDEG, or not thermal */
    TOF_CAL_FIELD_ARM = 12            /* a negative arm */
};

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

/* The section in its version-4 form (TOF_CAL_WIRE_SIZE bytes, header included: what the
 * telemetry commands carry; bind->part_id and bind->arm_um are not in it) of `cal` made in
 * `bind`. HAL_OK, or HAL_ERR_INVALID (`out` all zero) for a `cal` that is not calibrated,
 * out of estimator/calibration.h's bounds, or a binding without a mode or budget (the
 * decoder's own check of the bytes written). `has_gain` false: gains not fitted (gain_ppm must
 * be 0; the gain sd is not stored). `cal->thermal` false: the thermal fields are stored as 0
 * whatever `cal` holds there. */
int tof_cal_encode(const struct calibration_head *cal, bool has_gain,
                   const struct tof_cal_binding *bind, uint8_t *out);

/* The version-5 section (TOF_SECTION_HEADER + TOF_CALIBRATION_LENGTH bytes) made of the
 * version-1 to -5 section `section` (its header says which) with part i bound to
 * `part_id[i]` where `section` binds it to none (0, or versions 1 and 4), the thermal fields
 * kept (versions 4, 5) or 0, and the arm kept (versions 3, 5) or not bound (0). HAL_OK, or
 * HAL_ERR_INVALID (nothing written) for another header or a flag reserved in its version. */
int tof_cal_bind_parts(const uint8_t *section, const uint64_t part_id[CALIBRATION_SENSORS],
                       uint8_t *out);

/* Bind the version-5 section `section` (as tof_cal_bind_parts() makes it) to `arm_um` when
 * it is bound to none. */
void tof_cal_bind_arm(uint8_t *section, int32_t arm_um);

/* Find section 2 in `payload` (`len` bytes) and decode it (versions 1 to 5): TOF_CAL_APPLIED
 * with *cal and *bind filled (nothing checked against an image yet; a version without parts
 * or arm: 0; without the thermal fields: thermal false, they 0); NONE; VERSION; CORRUPT
 * (sections that do not add up, a wrong length for the version, a value out of bounds, a
 * reserved bit set, thermal fields without the thermal flag) with *field (unless `field` is
 * NULL) naming what was wrong; else *field is TOF_CAL_FIELD_NONE. */
enum tof_cal_state tof_cal_decode(const uint8_t *payload, uint16_t len,
                                  struct calibration_head *cal, struct tof_cal_binding *bind,
                                  enum tof_cal_field *field);

/* The field's name as a message says it ("temp_coeff_nm_per_c"); never NULL. */
const char *tof_cal_field_name(enum tof_cal_field field);

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
 * The write-calibration command (docs/reference/telemetry-protocol.md): `section` (version 4,
 * TOF_CAL_WIRE_SIZE bytes as the command carries it, or any version 1 to 5 its header names,
 * as long as that version's length) is decoded and checked against this image (head, parts,
 * distance mode, budget), saved into the record as version 5 bound to the running parts and
 * arm (tof_cal_bind_parts(), tof_cal_bind_arm(); other sections kept) and put in force.
 * Returns
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

/* The calibration section of the record in use into `section` in its version-4 form
 * (TOF_CAL_WIRE_SIZE bytes: what read-calibration sends; the parts' identities and the arm
 * are not in it; a stored version without the thermal fields gives them as 0), or zeros
 * when there is none. */
void tof_cal_read(const struct tof_record_store *store, uint8_t *section);

/* Which calibration the record in use holds, for its age (firmware/cal_age.h): the CRC-16 of
 * its calibration section (header and body as stored), or 0 when it holds none. */
uint16_t tof_cal_tag(const struct tof_record_store *store);

/* The binding of the running image (its head id, distance mode, timing budget; part_id 0). */
struct tof_cal_binding tof_cal_binding_of(const struct tof_app_config *cfg);

#endif /* FIRMWARE_CALIBRATION_RECORD_H */
