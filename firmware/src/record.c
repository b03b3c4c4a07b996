/* A record kept in two copies on two pages, written so a power cut never loses it
 * (firmware/record.h). */
#include "firmware/record.h"

#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"
#include "telemetry/tlm_crc.h"
#include "le_bytes.h"

/* What one page holds. */
enum copy_kind { COPY_EMPTY, COPY_VALID, COPY_VERSION, COPY_CORRUPT };

/* Bytes a copy with `len` payload bytes takes on its page. */
static uint32_t image_size(uint16_t len) {
    return ((uint32_t)TOF_RECORD_HEADER + len + 2u + 7u) / 8u * 8u;
}

/* Serial-number order (RFC 1982 in spirit): a is newer than b if it is less than half the
 * counter's range ahead, so the sequence may wrap from 0xFFFFFFFF to 0. */
static bool newer(uint32_t a, uint32_t b) {
    return a != b && (uint32_t)(a - b) < 0x80000000u;
}

int tof_record_init(struct tof_record_store *store, struct hal_records storage, uint16_t page_a,
                    uint16_t page_b) {
    memset(store, 0, sizeof *store);
    store->current = -1;
    const struct hal_records_geometry *g = &storage.geometry;
    if (storage.ops == NULL || page_a == page_b || page_a >= g->page_count ||
        page_b >= g->page_count || g->page_size < TOF_RECORD_IMAGE_MAX ||
        g->program_granule == 0u || 8u % g->program_granule != 0u) {
        return HAL_ERR_INVALID;
    }
    store->storage = storage;
    store->page[0] = page_a;
    store->page[1] = page_b;
    return HAL_OK;
}

/* Read the copy on page[i] into store->image; its sequence and length through the pointers. */
static enum copy_kind read_copy(struct tof_record_store *store, unsigned i, uint32_t *seq,
                                uint16_t *len) {
    const struct hal_records *s = &store->storage;
    uint8_t *im = store->image;
    if (s->ops->read(s->ctx, store->page[i], 0u, im, TOF_RECORD_HEADER) != HAL_OK) {
        return COPY_CORRUPT; /* an ECC double error in the header */
    }
    bool erased = true;
    for (unsigned k = 0; k < TOF_RECORD_HEADER; ++k) {
        erased = erased && im[k] == s->geometry.erased_byte;
    }
    if (erased) {
        return COPY_EMPTY;
    }
    *len = (uint16_t)(im[6] | im[7] << 8);
    *seq = le_get_u32(&im[8]);
    if (le_get_u32(im) != TOF_RECORD_MAGIC || im[5] != 0u || *len > TOF_RECORD_PAYLOAD_MAX) {
        return COPY_CORRUPT;
    }
    if (im[4] != TOF_RECORD_FORMAT) {
        return COPY_VERSION; /* a format this firmware does not read, e.g. a newer one's */
    }
    const uint32_t size = image_size(*len);
    if (s->ops->read(s->ctx, store->page[i], TOF_RECORD_HEADER, &im[TOF_RECORD_HEADER],
                     size - TOF_RECORD_HEADER) != HAL_OK) {
        return COPY_CORRUPT;
    }
    const uint32_t end = TOF_RECORD_HEADER + *len;
    const uint16_t crc = tlm_crc16(TLM_CRC_INIT, im, end);
    bool ok = im[end] == (uint8_t)crc && im[end + 1u] == (uint8_t)(crc >> 8);
    for (uint32_t k = end + 2u; k < size; ++k) {
        ok = ok && im[k] == 0u;
    }
    return ok ? COPY_VALID : COPY_CORRUPT;
}

enum tof_record_state tof_record_load(struct tof_record_store *store) {
    store->current = -1;
    store->length = 0u;
    bool corrupt = false, version = false;
    for (unsigned i = 0; i < 2u; ++i) {
        uint32_t seq = 0u;
        uint16_t len = 0u;
        const enum copy_kind kind = read_copy(store, i, &seq, &len);
        corrupt = corrupt || kind == COPY_CORRUPT;
        version = version || kind == COPY_VERSION;
        if (kind == COPY_VALID && (store->current < 0 || newer(seq, store->sequence))) {
            store->current = (int8_t)i;
            store->sequence = seq;
            store->length = len;
            memcpy(store->payload, &store->image[TOF_RECORD_HEADER], len);
        }
    }
    if (store->current >= 0) {
        return TOF_RECORD_LOADED;
    }
    return version ? TOF_RECORD_VERSION : corrupt ? TOF_RECORD_CORRUPT : TOF_RECORD_NONE;
}

/* Build the copy of `payload` with sequence `seq` in store->image; its size. */
static uint32_t build_image(struct tof_record_store *store, const uint8_t *payload, uint16_t len,
                            uint32_t seq) {
    uint8_t *im = store->image;
    const uint32_t size = image_size(len);
    memset(im, 0, size);
    le_put_u32(im, TOF_RECORD_MAGIC);
    im[4] = TOF_RECORD_FORMAT;
    im[6] = (uint8_t)len;
    im[7] = (uint8_t)(len >> 8);
    le_put_u32(&im[8], seq);
    if (len > 0u) {
        memcpy(&im[TOF_RECORD_HEADER], payload, len);
    }
    const uint32_t end = TOF_RECORD_HEADER + len;
    const uint16_t crc = tlm_crc16(TLM_CRC_INIT, im, end);
    im[end] = (uint8_t)crc;
    im[end + 1u] = (uint8_t)(crc >> 8);
    return size;
}

/* Compare what page `page` holds with store->image, a double-word at a time. */
static int verify(const struct tof_record_store *store, uint16_t page, uint32_t size) {
    const struct hal_records *s = &store->storage;
    for (uint32_t at = 0; at < size; at += 8u) {
        uint8_t back[8];
        const int rc = s->ops->read(s->ctx, page, at, back, sizeof back);
        if (rc != HAL_OK) {
            return rc;
        }
        if (memcmp(back, &store->image[at], sizeof back) != 0) {
            return HAL_ERR_CORRUPT;
        }
    }
    return HAL_OK;
}

/* The steps of a save (struct tof_record_store, step). */
enum save_step {
    STEP_IDLE = 0,
    STEP_CHECK_TARGET, /* the target page blank? else start its erase */
    STEP_ERASE_TARGET, /* its erase running */
    STEP_PROGRAM,      /* program and verify the new copy */
    STEP_ERASE_OLD,    /* the new copy in use; the old page's erase running */
};

/* Start erasing page[i]: in the background if the storage can, else at once (then the
 * erase is over when this returns). HAL_OK or the storage's error. */
static int erase_begin(struct tof_record_store *store, unsigned i, bool *background) {
    const struct hal_records *s = &store->storage;
    *background = s->ops->erase_start != NULL && s->ops->erase_poll != NULL;
    return *background ? s->ops->erase_start(s->ctx, store->page[i])
                       : s->ops->erase(s->ctx, store->page[i]);
}

/* page[i] reads erased, all of it (the end of the previous save's erase, or a page never
 * written): it can be programmed without an erase. A marginal cell of an interrupted erase
 * that reads erased is caught by the verify after programming (the save then fails, the old
 * copy stays, and the next save erases the page first). */
static bool blank(struct tof_record_store *store, unsigned i) {
    const struct hal_records *s = &store->storage;
    for (uint32_t at = 0; at < s->geometry.page_size; at += 8u) {
        uint8_t b[8];
        const uint32_t n = s->geometry.page_size - at < 8u ? s->geometry.page_size - at : 8u;
        if (s->ops->read(s->ctx, store->page[i], at, b, n) != HAL_OK) {
            return false;
        }
        for (unsigned k = 0; k < n; ++k) {
            if (b[k] != s->geometry.erased_byte) {
                return false;
            }
        }
    }
    return true;
}

int tof_record_save_begin(struct tof_record_store *store, const uint8_t *payload, uint16_t len) {
    if (len > TOF_RECORD_PAYLOAD_MAX || store->storage.ops == NULL ||
        (len > 0u && payload == NULL)) {
        return HAL_ERR_INVALID;
    }
    if (store->step != STEP_IDLE && store->step != STEP_ERASE_OLD) {
        return HAL_ERR_STATE; /* a new copy is being written: one save at a time */
    }
    /* The new copy goes where the one in use is not; with none in use, to page[0]. */
    store->target = store->current == 0 ? 1u : 0u;
    store->save_seq = store->current < 0 ? 0u : store->sequence + 1u;
    store->save_len = len;
    store->save_size = build_image(store, payload, len, store->save_seq);
    /* The old page's erase still running is the target's: wait for it, then program. */
    store->step = store->step == STEP_ERASE_OLD ? STEP_ERASE_TARGET : STEP_CHECK_TARGET;
    return HAL_OK;
}

/* Program and verify the new copy; make it the one in use and start erasing the old page
 * (firmware/record.h: only now may it go). */
static int program_step(struct tof_record_store *store) {
    const struct hal_records *s = &store->storage;
    int rc =
        s->ops->program(s->ctx, store->page[store->target], 0u, store->image, store->save_size);
    if (rc == HAL_OK) {
        rc = verify(store, store->page[store->target], store->save_size);
    }
    if (rc != HAL_OK) {
        store->step = STEP_IDLE;
        return rc; /* the old copy, untouched, stays the one in use */
    }
    store->current = (int8_t)store->target;
    store->sequence = store->save_seq;
    store->length = store->save_len;
    memcpy(store->payload, &store->image[TOF_RECORD_HEADER], store->save_len);
    /* A failed erase leaves an older valid copy behind, which load ranks below the new one:
     * the save stands all the same (the error is still returned). */
    bool background = false;
    rc = erase_begin(store, 1u - store->target, &background);
    store->step = rc == HAL_OK && background ? STEP_ERASE_OLD : STEP_IDLE;
    return rc;
}

int tof_record_step(struct tof_record_store *store) {
    const struct hal_records *s = &store->storage;
    bool background = false;
    int rc = HAL_OK;
    switch (store->step) {
    case STEP_CHECK_TARGET:
        if (blank(store, store->target)) {
            store->step = STEP_PROGRAM;
            return HAL_ERR_NOT_READY;
        }
        rc = erase_begin(store, store->target, &background);
        store->step = rc != HAL_OK ? STEP_IDLE : background ? STEP_ERASE_TARGET : STEP_PROGRAM;
        return rc != HAL_OK ? rc : HAL_ERR_NOT_READY;
    case STEP_ERASE_TARGET:
        rc = s->ops->erase_poll(s->ctx);
        if (rc == HAL_ERR_NOT_READY) {
            return rc;
        }
        store->step = rc == HAL_OK ? STEP_PROGRAM : STEP_IDLE;
        return rc == HAL_OK ? HAL_ERR_NOT_READY : rc;
    case STEP_PROGRAM:
        return program_step(store);
    case STEP_ERASE_OLD:
        rc = s->ops->erase_poll(s->ctx);
        if (rc == HAL_ERR_NOT_READY) {
            return HAL_OK; /* the new copy is in use: the save is done for the caller */
        }
        store->step = STEP_IDLE; /* over; a failure leaves an older copy, ranked below */
        return rc;
    default:
        return HAL_OK;
    }
}

bool tof_record_busy(const struct tof_record_store *store) {
    return store->step != STEP_IDLE;
}

/* Upper bound on the steps of one blocking save: each poll of an erase is one step, and an
 * erase's own budget ends it (HAL_ERR_TIMEOUT) long before. */
#define SAVE_STEPS_MAX 10000000u

/* The steps of a save until it is over, or (`in_use`) until the new copy is in use. */
static int save_steps(struct tof_record_store *store, const uint8_t *payload, uint16_t len,
                      bool in_use) {
    int rc = tof_record_save_begin(store, payload, len);
    for (uint32_t n = 0;
         rc == HAL_OK && tof_record_busy(store) && !(in_use && store->step == STEP_ERASE_OLD);
         ++n) {
        rc = n < SAVE_STEPS_MAX ? tof_record_step(store) : HAL_ERR_TIMEOUT;
        rc = rc == HAL_ERR_NOT_READY ? HAL_OK : rc;
    }
    return rc;
}

int tof_record_save(struct tof_record_store *store, const uint8_t *payload, uint16_t len) {
    return save_steps(store, payload, len, false);
}

int tof_record_save_in_use(struct tof_record_store *store, const uint8_t *payload, uint16_t len) {
    return save_steps(store, payload, len, true);
}
