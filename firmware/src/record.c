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

int tof_record_save(struct tof_record_store *store, const uint8_t *payload, uint16_t len) {
    if (len > TOF_RECORD_PAYLOAD_MAX || store->storage.ops == NULL ||
        (len > 0u && payload == NULL)) {
        return HAL_ERR_INVALID;
    }
    const struct hal_records *s = &store->storage;
    /* The new copy goes where the one in use is not; with none in use, to page[0]. */
    const unsigned target = store->current == 0 ? 1u : 0u;
    const uint32_t seq = store->current < 0 ? 0u : store->sequence + 1u;
    const uint32_t size = build_image(store, payload, len, seq);
    int rc = s->ops->erase(s->ctx, store->page[target]);
    if (rc == HAL_OK) {
        rc = s->ops->program(s->ctx, store->page[target], 0u, store->image, size);
    }
    if (rc == HAL_OK) {
        rc = verify(store, store->page[target], size);
    }
    if (rc != HAL_OK) {
        return rc; /* the old copy, untouched, stays the one in use */
    }
    store->current = (int8_t)target;
    store->sequence = seq;
    store->length = len;
    if (len > 0u) {
        memmove(store->payload, payload, len); /* payload may be store->payload itself */
    }
    /* The new copy is verified: only now may the old one go (firmware/record.h). A failed
     * erase leaves an older valid copy behind, which load ranks below the new one. */
    return s->ops->erase(s->ctx, store->page[1u - target]);
}
