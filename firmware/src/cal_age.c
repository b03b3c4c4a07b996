/* The calibration's age as an append-only counter on record storage (firmware/cal_age.h). */
#include "firmware/cal_age.h"

#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"
#include "telemetry/tlm_crc.h"
#include "telemetry/tlm_messages.h"
#include "le_bytes.h"

/* The status frame carries enum tof_cal_age_state as it is (link.c). */
_Static_assert(TOF_CAL_AGE_NONE == (int)TLM_CAL_AGE_NONE &&
                   TOF_CAL_AGE_KEPT == (int)TLM_CAL_AGE_KEPT &&
                   TOF_CAL_AGE_UNKNOWN == (int)TLM_CAL_AGE_UNKNOWN &&
                   TOF_CAL_AGE_FAILED == (int)TLM_CAL_AGE_FAILED,
               "age states are the status frame's codes");

int tof_cal_age_init(struct tof_cal_age *age, struct hal_records storage, uint16_t page_a,
                     uint16_t page_b) {
    memset(age, 0, sizeof *age);
    const struct hal_records_geometry *g = &storage.geometry;
    if (storage.ops == NULL || page_a == page_b || page_a >= g->page_count ||
        page_b >= g->page_count || g->program_granule != TOF_CAL_AGE_ENTRY ||
        g->page_size / TOF_CAL_AGE_ENTRY < 2u || g->page_size / TOF_CAL_AGE_ENTRY > 0xFFFFu) {
        return HAL_ERR_INVALID;
    }
    age->storage = storage;
    age->page[0] = page_a;
    age->page[1] = page_b;
    age->slots = (uint16_t)(g->page_size / TOF_CAL_AGE_ENTRY);
    return HAL_OK;
}

enum slot_kind { SLOT_BLANK, SLOT_VALID, SLOT_OTHER };

/* Read entry `slot` of page[i]: blank, a valid entry (*age_s, *tag), or anything else (an ECC
 * error of a cut program, a torn erase's leftovers, a wrong CRC). */
static enum slot_kind read_slot(struct tof_cal_age *age, unsigned i, uint16_t slot, uint32_t *age_s,
                                uint16_t *tag) {
    const struct hal_records *s = &age->storage;
    uint8_t *e = age->image;
    if (s->ops->read(s->ctx, age->page[i], (uint32_t)slot * TOF_CAL_AGE_ENTRY, e,
                     TOF_CAL_AGE_ENTRY) != HAL_OK) {
        return SLOT_OTHER;
    }
    bool blank = true;
    for (unsigned k = 0; k < TOF_CAL_AGE_ENTRY; ++k) {
        blank = blank && e[k] == s->geometry.erased_byte;
    }
    if (blank) {
        return SLOT_BLANK;
    }
    if (tlm_crc16(TLM_CRC_INIT, e, 6u) != (uint16_t)(e[6] | e[7] << 8)) {
        return SLOT_OTHER;
    }
    *age_s = le_get_u32(e);
    *tag = (uint16_t)(e[4] | e[5] << 8);
    return SLOT_VALID;
}

/* The largest entry tagged `tag` on both pages (*found false: none). The active page is the
 * one holding it (so a switch never erases it), else a page with entries and room, else page
 * 0; its next slot the one after its last non-blank one. */
static uint32_t scan(struct tof_cal_age *age, uint16_t tag, bool *found) {
    uint32_t best = 0u;
    unsigned best_page = 0u;
    *found = false;
    uint16_t last_used[2] = {0u, 0u};
    bool any[2] = {false, false};
    for (unsigned i = 0; i < 2u; ++i) {
        for (uint16_t slot = 0; slot < age->slots; ++slot) {
            uint32_t a = 0u;
            uint16_t t = 0u;
            const enum slot_kind k = read_slot(age, i, slot, &a, &t);
            if (k != SLOT_BLANK) {
                last_used[i] = (uint16_t)(slot + 1u);
            }
            any[i] = any[i] || k == SLOT_VALID;
            if (k == SLOT_VALID && t == tag && (!*found || a > best)) {
                best = a;
                best_page = i;
                *found = true;
            }
        }
    }
    if (*found) {
        age->active = (uint8_t)best_page;
    } else {
        age->active =
            any[1] && last_used[1] < age->slots && !(any[0] && last_used[0] < age->slots) ? 1u : 0u;
    }
    age->next_slot = last_used[age->active];
    return best;
}

/* page[i] reads blank from end to end. */
static bool page_blank(struct tof_cal_age *age, unsigned i) {
    for (uint16_t slot = 0; slot < age->slots; ++slot) {
        uint32_t a = 0u;
        uint16_t t = 0u;
        if (read_slot(age, i, slot, &a, &t) != SLOT_BLANK) {
            return false;
        }
    }
    return true;
}

/* Make the other page the active one: erased (waited for, bounded by the storage's own
 * erase budget) and checked blank. The full page keeps its entries until the next switch. */
static int switch_page(struct tof_cal_age *age) {
    const struct hal_records *s = &age->storage;
    const unsigned other = age->active ^ 1u;
    int rc;
    if (s->ops->erase != NULL) {
        rc = s->ops->erase(s->ctx, age->page[other]);
    } else {
        rc = s->ops->erase_start(s->ctx, age->page[other]);
        /* erase_poll() ends with its own timeout (hal_records.h): a bounded wait */
        for (uint32_t polls = 0; rc == HAL_OK && polls < 10000000u; ++polls) {
            rc = s->ops->erase_poll(s->ctx);
            if (rc != HAL_ERR_NOT_READY) {
                break;
            }
        }
    }
    if (rc == HAL_OK && !page_blank(age, other)) {
        rc = HAL_ERR_CORRUPT;
    }
    if (rc == HAL_OK) {
        age->active = (uint8_t)other;
        age->next_slot = 0u;
    }
    return rc;
}

/* Append the entry (age_s, tag) to the active page (switching pages when it is full). */
static int append(struct tof_cal_age *age, uint32_t age_s, uint16_t tag) {
    int rc = HAL_OK;
    if (age->next_slot >= age->slots) {
        rc = switch_page(age);
    }
    if (rc == HAL_OK) {
        uint8_t *e = age->image;
        le_put_u32(e, age_s);
        e[4] = (uint8_t)tag;
        e[5] = (uint8_t)(tag >> 8);
        const uint16_t crc = tlm_crc16(TLM_CRC_INIT, e, 6u);
        e[6] = (uint8_t)crc;
        e[7] = (uint8_t)(crc >> 8);
        const struct hal_records *s = &age->storage;
        const uint16_t slot = age->next_slot;
        /* the slot is spent whatever happens: a failed program may have left it non-blank */
        age->next_slot = (uint16_t)(slot + 1u);
        rc = s->ops->program(s->ctx, age->page[age->active], (uint32_t)slot * TOF_CAL_AGE_ENTRY, e,
                             TOF_CAL_AGE_ENTRY);
    }
    if (rc == HAL_OK) {
        age->stored_s = age_s;
        age->last_error = 0;
    } else {
        age->last_error = rc;
        age->state = TOF_CAL_AGE_FAILED;
    }
    return rc;
}

static uint32_t add_sat(uint32_t a, uint32_t b) {
    return a > TOF_CAL_AGE_MAX_S - b ? TOF_CAL_AGE_MAX_S : a + b;
}

enum tof_cal_age_state tof_cal_age_boot(struct tof_cal_age *age, bool calibrated, uint16_t tag,
                                        uint32_t off_allowance_s, uint64_t now_us) {
    age->counting = false;
    age->state = TOF_CAL_AGE_NONE;
    if (age->storage.ops == NULL || !calibrated) {
        return TOF_CAL_AGE_NONE;
    }
    bool found = false;
    const uint32_t stored = scan(age, tag, &found);
    age->counting = true;
    age->tag = tag;
    /* no entry: a calibration stored without its age (preloaded by a programmer, or by a
     * firmware that kept none) is taken as made at this boot (cal_age.h) */
    age->base_s = found ? add_sat(stored, off_allowance_s) : 0u;
    age->base_us = now_us;
    age->state = found ? TOF_CAL_AGE_KEPT : TOF_CAL_AGE_UNKNOWN;
    const uint8_t state = age->state;
    if (append(age, add_sat(age->base_s, TOF_CAL_AGE_INTERVAL_S), tag) == HAL_OK) {
        age->state = state;
    }
    return (enum tof_cal_age_state)age->state;
}

int tof_cal_age_restart(struct tof_cal_age *age, uint16_t tag, uint64_t now_us) {
    if (age->storage.ops == NULL) {
        return HAL_ERR_INVALID;
    }
    if (age->slots == 0u) {
        return HAL_ERR_INVALID;
    }
    age->counting = true;
    age->tag = tag;
    age->base_s = 0u;
    age->base_us = now_us;
    age->state = TOF_CAL_AGE_KEPT;
    /* Written by the next poll (the storage may be busy with the calibration's own record
     * now); a reset before it finds no entry of this calibration: age 0, which it is. An
     * earlier calibration with the same tag may have left larger entries: they are kept and
     * win (a larger age, never a smaller one). */
    age->stored_s = 0u;
    return HAL_OK;
}

void tof_cal_age_stop(struct tof_cal_age *age) {
    age->counting = false;
    age->state = TOF_CAL_AGE_NONE;
}

uint32_t tof_cal_age_now_s(const struct tof_cal_age *age, uint64_t now_us) {
    if (!age->counting) {
        return 0u;
    }
    const uint64_t s = now_us > age->base_us ? (now_us - age->base_us) / 1000000u : 0u;
    return s >= TOF_CAL_AGE_MAX_S ? TOF_CAL_AGE_MAX_S : add_sat(age->base_s, (uint32_t)s);
}

int tof_cal_age_poll(struct tof_cal_age *age, uint64_t now_us) {
    if (!age->counting) {
        return HAL_OK;
    }
    const uint32_t now_s = tof_cal_age_now_s(age, now_us);
    if (age->state != TOF_CAL_AGE_FAILED && now_s < age->stored_s) {
        return HAL_OK;
    }
    if (now_s >= TOF_CAL_AGE_MAX_S && age->stored_s >= TOF_CAL_AGE_MAX_S) {
        return HAL_OK; /* saturated and kept */
    }
    const uint8_t state = age->state == TOF_CAL_AGE_FAILED ? (uint8_t)TOF_CAL_AGE_KEPT : age->state;
    const int rc = append(age, add_sat(now_s, TOF_CAL_AGE_INTERVAL_S), age->tag);
    if (rc == HAL_OK) {
        age->state = state;
    }
    return rc;
}
