/*
 * The calibration's age across resets: the operating time since the head's calibration, kept
 * as an append-only counter on two pages of record storage of its own (hal/hal_records.h),
 * apart from the record's pages (firmware/record.h), so that the drift allowance since
 * calibration (attitude_config.calibration_age_s) does not restart at every boot.
 *
 * An entry is one program granule (a double-word on the STM32L4, RM0351 §3.3.7), little-endian:
 *
 *     0 u32 age_s   the calibration's age this entry vouches for, seconds
 *     4 u16 tag     which calibration (tof_cal_tag(): the CRC of its record section)
 *     6 u16 CRC-16/CCITT-FALSE of bytes 0..5
 *
 * Entries are only appended; the age is the largest valid entry of the calibration in force
 * on either page. Each entry is written ahead of the time it covers: the entry written at an
 * age A says A + TOF_CAL_AGE_INTERVAL_S, so what is stored is never less than the age reached
 * (a reset loses at most one interval, on the side of a larger age). A power cut while an
 * entry is programmed leaves it blank or unreadable (an ECC error, skipped), never a valid
 * entry with another value; the previous entry still holds. When a page is full the other one
 * is erased and checked blank before it takes the next entry: the full page keeps the largest
 * entry until then, so no cut during an erase loses the age either.
 *
 * At boot the unit cannot know how long it was off (no clock runs while it is off): the age
 * handed to the estimator is the stored age plus an allowance for the time off
 * (tof_app_config.cal_off_allowance_s), and that sum is written at once, so the allowances of
 * successive boots add up until the next calibration (a re-zero or a calibration written)
 * starts the age again at 0.
 *
 * Wear: one entry per TOF_CAL_AGE_INTERVAL_S of operation and one per boot; a 2 KiB page holds
 * 256 entries. Ten years of continuous operation at 600 s: 525,960 entries, 2,055 page erases
 * alternating over two pages, 1,028 cycles each, about 10 % of the 10,000 cycles the STM32L476
 * datasheet (DS10198, "Flash memory endurance and data retention", N_END) guarantees per page;
 * ten boots a day add 36,525 entries (143 erases).
 */
#ifndef FIRMWARE_CAL_AGE_H
#define FIRMWARE_CAL_AGE_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_records.h"

/* One entry per 10 minutes of operation: the age after a reset is within this of the truth. */
#define TOF_CAL_AGE_INTERVAL_S 600u
#define TOF_CAL_AGE_ENTRY      8u
/* The largest age kept (136 years): a saturated counter stays there. */
#define TOF_CAL_AGE_MAX_S 0xFFFFFFF0u

/* What the boot found, the status frame's `cal_age` state. */
enum tof_cal_age_state {
    TOF_CAL_AGE_NONE = 0,    /* no calibration in force, or no storage: no age kept */
    TOF_CAL_AGE_KEPT = 1,    /* the stored age of this calibration, plus the off allowance */
    TOF_CAL_AGE_UNKNOWN = 2, /* a calibration with no entry (preloaded by a programmer, kept
                                by a firmware that kept none, or its first entry cut): taken
                                as made at this boot, counted from 0 */
    TOF_CAL_AGE_FAILED = 3,  /* the storage refused an entry: the age runs, not kept */
};

struct tof_cal_age {
    struct hal_records storage;
    uint16_t page[2];
    uint16_t slots;     /* entries per page */
    uint8_t active;     /* index into page[] of the page taking entries */
    uint16_t next_slot; /* the active page's next blank entry (slots: full) */
    bool counting;      /* a calibration's age is being kept */
    uint16_t tag;
    uint32_t base_s;   /* the age at base_us */
    uint64_t base_us;  /* the unit's clock when the age was base_s */
    uint32_t stored_s; /* the largest entry written: the age is kept up to here */
    uint8_t state;     /* enum tof_cal_age_state */
    int last_error;    /* the storage's hal_err of the last entry or erase refused, or 0 */
    uint8_t image[TOF_CAL_AGE_ENTRY];
};

/* Use pages `page_a` and `page_b` of `storage` (never the record's). HAL_ERR_INVALID when
 * storage has no ops, the pages are equal or out of range, or the granule is not 8 bytes
 * (one entry) or a page holds fewer than two entries. Nothing is read yet. */
int tof_cal_age_init(struct tof_cal_age *age, struct hal_records storage, uint16_t page_a,
                     uint16_t page_b);

/* The age at boot of the calibration tagged `tag` (`calibrated` false: none in force, nothing
 * kept): the largest entry with that tag plus `off_allowance_s` (KEPT), or 0 when there is none
 * (UNKNOWN), counted from `now_us`; that age plus one interval is written at once. Returns the
 * state (also in age->state). */
enum tof_cal_age_state tof_cal_age_boot(struct tof_cal_age *age, bool calibrated, uint16_t tag,
                                        uint32_t off_allowance_s, uint64_t now_us);

/* A new calibration (tagged `tag`) is in force at `now_us`: its age starts at 0, its first
 * entry written by the next tof_cal_age_poll() (nothing touches the storage here). HAL_OK, or
 * HAL_ERR_INVALID without storage. */
int tof_cal_age_restart(struct tof_cal_age *age, uint16_t tag, uint64_t now_us);

/* No calibration in force any more: nothing is kept until the next restart. */
void tof_cal_age_stop(struct tof_cal_age *age);

/* The calibration's age at `now_us`, seconds (0 when none is kept), never beyond
 * TOF_CAL_AGE_MAX_S. */
uint32_t tof_cal_age_now_s(const struct tof_cal_age *age, uint64_t now_us);

/* Once per main-loop iteration: when the age reaches what is stored, the next entry (one
 * interval ahead) is written; a full page's successor is erased first. Bounded: at most one
 * entry and one page erase (~25 ms on the STM32L4, once per 256 intervals). HAL_OK, or the
 * storage's error (state FAILED, retried at the next call). */
int tof_cal_age_poll(struct tof_cal_age *age, uint64_t now_us);

#endif /* FIRMWARE_CAL_AGE_H */
