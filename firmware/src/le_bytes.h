/*
 * Little-endian u32 in byte buffers, for the record's header and its sections (record.c,
 * settings.c, calibration_record.c; docs/explanation/firmware.md "Records"): one reading, whatever
 * the core's own byte order.
 */
#ifndef FIRMWARE_SRC_LE_BYTES_H
#define FIRMWARE_SRC_LE_BYTES_H

#include <stdint.h>

/* The u32 stored little-endian at p[0..3]. */
static inline uint32_t le_get_u32(const uint8_t *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Stores v little-endian at p[0..3]. */
static inline void le_put_u32(uint8_t *p, uint32_t v) {
    for (unsigned i = 0; i < 4u; ++i) {
        p[i] = (uint8_t)(v >> (8u * i));
    }
}

#endif /* FIRMWARE_SRC_LE_BYTES_H */
