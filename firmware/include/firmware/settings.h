/*
 * The user's settings kept across resets: what the link's commands set (window and
 * mode, primary estimator, Kalman process noise, raw stream, running), saved by the
 * `save` command into the record (firmware/record.h) and applied at boot.
 *
 * The record's payload is a list of sections, each `u8 id, u8 version, u16 length`
 * then its bytes, so the head's calibration gets a section of its own
 * (TOF_SECTION_CALIBRATION) in the same record: saving the settings keeps every other
 * section as it was, and a firmware that does not know a section leaves it alone.
 * Section 1 (settings) version 2, 24 bytes, little-endian (docs/explanation/firmware.md,
 * "Records"):
 *
 *     0 u16 window   2 u8 mode (0 tumbling, 1 sliding)   3 u8 primary estimator
 *     4 u8 running   5 u8 raw stream   6 u8 flags (bit 0 process noise set, bit 1 auto)
 *     7 u8 0         8 u32 qd (um²/s)  12 u32 qt (um²/s)
 *     16 i32 arm (um)   20 u16 period (ms)   22 u16 0
 *
 * Version 1 (the first 16 bytes, before arm and period were settings) is still read: its
 * arm and period are the image's.
 */
#ifndef FIRMWARE_SETTINGS_H
#define FIRMWARE_SETTINGS_H

#include <stdbool.h>
#include <stdint.h>

#include "firmware/app.h"
#include "firmware/record.h"

#define TOF_SECTION_SETTINGS    1u /* this header's */
#define TOF_SECTION_CALIBRATION 2u /* the head's calibration (firmware/calibration_record.h) */
#define TOF_SECTION_HEADER      4u /* u8 id, u8 version, u16 length */
#define TOF_SETTINGS_VERSION    2u
#define TOF_SETTINGS_LENGTH     24u
#define TOF_SETTINGS_V1_LENGTH  16u

struct tof_settings {
    uint16_t window;
    bool sliding;
    uint8_t primary; /* enum attitude_estimator */
    bool running;
    bool raw_output;
    bool process_noise_set; /* false: the image's configured process noise is kept */
    bool process_noise_auto;
    uint32_t qd_um2_per_s, qt_um2_per_s;
    int32_t arm_um;     /* the head's arm a; 0: the image's (a version 1 record) */
    uint16_t period_ms; /* the sample period; 0: the image's (a version 1 record) */
};

/* The settings `app` runs with now (process noise: `pn`, what the last accepted command set,
 * or process_noise_set false if none did). */
void tof_settings_capture(const struct tof_app *app, const struct tof_settings *pn,
                          struct tof_settings *out);

/* Apply `s` through the application's command functions. 0, or the first refusal's code
 * (the settings before it are applied: tof_settings_boot() undoes them). */
int tof_settings_apply(struct tof_app *app, const struct tof_settings *s);

/* Section id 0 is never used (a payload list check looks for it). */

/* The offset of section `id` in `payload` (`len` bytes): >= 0; -1 absent; -2 the sections do
 * not add up (a length running past the end). */
int tof_section_find(const uint8_t *payload, uint16_t len, uint8_t id);

/* Save `section` (its 4-byte header first, the length in it) into `store`'s record in place
 * of the section with its id, every other section kept as it was; returns once the new copy
 * is in use (tof_record_save_in_use(): the old page's erase may go on, stepped by the link's
 * poll). HAL_OK, HAL_ERR_STATE without storage, HAL_ERR_INVALID if they do not fit, or the
 * save's error. */
int tof_section_save(struct tof_record_store *store, const uint8_t *section);

/* Find the settings section in `payload` (`len` bytes) and decode it into `out`:
 * TOF_RECORD_LOADED; NONE (no such section); VERSION (a version this firmware does not
 * read); CORRUPT (sections that do not add up, a value out of range). */
enum tof_record_state tof_settings_decode(const uint8_t *payload, uint16_t len,
                                          struct tof_settings *out);

/*
 * At boot, after tof_app_init(): load the record from `store` (NULL: no storage) and apply
 * its settings; anything short of a record the application accepts leaves (or puts back)
 * the defaults. `out` gets the settings in force. Returns what happened (firmware/record.h).
 */
enum tof_record_state tof_settings_boot(struct tof_record_store *store, struct tof_app *app,
                                        struct tof_settings *out);

/* Save `s` into `store`'s record, other sections kept. HAL_OK, HAL_ERR_STATE without
 * storage, HAL_ERR_INVALID if they do not fit, or tof_record_save()'s error. */
int tof_settings_save(struct tof_record_store *store, const struct tof_settings *s);

/* As tof_settings_save(), in steps: begins the record's save (tof_record_save_begin), which
 * the caller then advances with tof_record_step() from its main loop. */
int tof_settings_save_begin(struct tof_record_store *store, const struct tof_settings *s);

#endif /* FIRMWARE_SETTINGS_H */
