/*
 * A record that survives resets and power loss, on two pages of record storage
 * (hal/hal_records.h): each save writes a whole new copy to the page not holding the
 * current one, reads it back, and only then erases the old one, so a power cut at any
 * step leaves the old record or the new one, never neither and never a mix.
 *
 * A copy, little-endian, from the start of its page (docs/explanation/firmware.md, "Records"):
 *
 *     0  u32 magic 0x52464F54 ("TOFR")     4  u8 format version (1)    5  u8 0
 *     6  u16 payload length (<= TOF_RECORD_PAYLOAD_MAX)                8  u32 sequence
 *    12  payload                           12+len  u16 CRC-16/CCITT-FALSE of bytes 0..11+len
 *    then 0x00 up to the next double-word (what is programmed is whole double-words)
 *
 * At load the valid copy with the newer sequence number wins (serial-number order, so the
 * counter may wrap). What the payload holds is the caller's (firmware/settings.h).
 */
#ifndef FIRMWARE_RECORD_H
#define FIRMWARE_RECORD_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_records.h"

#define TOF_RECORD_MAGIC       0x52464F54u /* "TOFR" in memory order */
#define TOF_RECORD_FORMAT      1u
#define TOF_RECORD_HEADER      12u
#define TOF_RECORD_PAYLOAD_MAX 182u /* the settings (28) and the calibration (154) sections */
/* A copy's bytes on its page: header, payload, CRC, rounded up to a double-word. */
#define TOF_RECORD_IMAGE_MAX ((TOF_RECORD_HEADER + TOF_RECORD_PAYLOAD_MAX + 2u + 7u) / 8u * 8u)

/* What load found, also the status frame's `record` field (docs/reference/telemetry-protocol.md
 * §5.5). */
enum tof_record_state {
    TOF_RECORD_NONE = 0,       /* nothing stored (both pages erased): defaults */
    TOF_RECORD_LOADED = 1,     /* a valid record, used */
    TOF_RECORD_CORRUPT = 2,    /* no valid copy, something damaged stored: defaults */
    TOF_RECORD_VERSION = 3,    /* no valid copy of a format or section version this firmware
                                  reads: defaults */
    TOF_RECORD_REJECTED = 4,   /* a valid record the application refused: defaults */
    TOF_RECORD_NO_STORAGE = 5, /* the board has no record storage: defaults, save refused */
};
#define TOF_RECORD_STATE_LAST TOF_RECORD_NO_STORAGE

struct tof_record_store {
    struct hal_records storage;
    uint16_t page[2];
    int8_t current;    /* index into page[] of the copy in use, -1: none */
    uint32_t sequence; /* of the copy in use (the next save writes sequence + 1) */
    uint16_t length;   /* payload bytes of the copy in use */
    uint8_t payload[TOF_RECORD_PAYLOAD_MAX];
    uint8_t image[TOF_RECORD_IMAGE_MAX]; /* a copy being read or written */
    /* A save in steps (tof_record_save_begin, tof_record_step): */
    uint8_t step;   /* what the next tof_record_step() does (record.c; 0: nothing) */
    uint8_t target; /* index into page[] of the copy being written */
    uint16_t save_len;
    uint32_t save_seq, save_size;
};

/*
 * Use pages `page_a` and `page_b` of `storage`. HAL_ERR_INVALID when storage has no ops,
 * the pages are equal or out of range, or the geometry cannot hold a copy (page smaller
 * than TOF_RECORD_IMAGE_MAX, granule not 1..8 dividing 8). Nothing is read yet.
 */
int tof_record_init(struct tof_record_store *store, struct hal_records storage, uint16_t page_a,
                    uint16_t page_b);

/* Read both pages; the newest valid copy becomes the one in use (payload, length). Returns
 * TOF_RECORD_LOADED, NONE, CORRUPT or VERSION (the store then has no copy in use). */
enum tof_record_state tof_record_load(struct tof_record_store *store);

/*
 * Save `len` bytes of `payload` as the new record: erase the other page, program the copy
 * (sequence + 1), read it back and compare, then erase the old page. HAL_OK; HAL_ERR_INVALID
 * for len > TOF_RECORD_PAYLOAD_MAX; the storage's error of a failed step (HAL_ERR_CORRUPT for
 * a copy that read back wrong), the old record still in use; or the error of the last step
 * (erasing the old copy), the new record then in use all the same.
 */
int tof_record_save(struct tof_record_store *store, const uint8_t *payload, uint16_t len);

/*
 * As tof_record_save(), returning once the new copy is written, verified and in use: when
 * the storage erases in the background, the old page's erase goes on, ended by
 * tof_record_step() calls (tof_record_busy() says it runs). No wait for an erase unless the
 * other page is not blank (after a power cut during an erase) or an earlier erase still runs.
 */
int tof_record_save_in_use(struct tof_record_store *store, const uint8_t *payload, uint16_t len);

/*
 * The same save in steps, so that no main-loop iteration waits for a page erase (~22 ms on
 * the STM32L4, longer than a sample period) when the storage can erase in the background
 * (hal_records erase_start). Begin copies `payload` (the caller's buffer is free at once);
 * each tof_record_step() then does one thing: look whether the other page is blank, start
 * or poll its erase, program and verify the copy (~1.5 ms), start or poll the old page's
 * erase. HAL_OK from begin, or HAL_ERR_INVALID as tof_record_save (HAL_ERR_STATE while a
 * new copy is still being written). A begin while the previous save's old page is still
 * being erased waits for that erase: it is the page the new copy goes to.
 */
int tof_record_save_begin(struct tof_record_store *store, const uint8_t *payload, uint16_t len);

/*
 * Advance the save under way. HAL_ERR_NOT_READY while its new copy is not yet in use;
 * HAL_OK once it is (also when no save is under way; the old page's erase may still go on:
 * keep calling while tof_record_busy()); a storage error once, the save then abandoned
 * with the old copy still in use (or, for the old page's erase, the new one in use).
 */
int tof_record_step(struct tof_record_store *store);

/* A save or its old page's erase is still under way. */
bool tof_record_busy(const struct tof_record_store *store);

#endif /* FIRMWARE_RECORD_H */
