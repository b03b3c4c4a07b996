/* CRC-16/CCITT-FALSE of every telemetry frame (telemetry/tlm_crc.h). */
#include "telemetry/tlm_crc.h"

/*
 * Nibble-wise table for polynomial 0x1021, MSB first: entry n is the register
 * after shifting the 4-bit value n (placed in the top nibble) through the
 * polynomial four times. Two lookups per byte: 32 bytes of flash instead of
 * the 512 of a byte-wise table, about 4x faster than bit-at-a-time. The unit
 * test recomputes every entry bit by bit.
 */
static const uint16_t crc_nibble_table[16] = {
    0x0000u, 0x1021u, 0x2042u, 0x3063u, 0x4084u, 0x50A5u, 0x60C6u, 0x70E7u,
    0x8108u, 0x9129u, 0xA14Au, 0xB16Bu, 0xC18Cu, 0xD1ADu, 0xE1CEu, 0xF1EFu,
};

static uint16_t crc_step_nibble(uint16_t crc, unsigned nibble) {
    unsigned index = ((unsigned)crc >> 12) ^ (nibble & 0x0Fu);
    return (uint16_t)((uint16_t)(crc << 4) ^ crc_nibble_table[index]);
}

uint16_t tlm_crc16(uint16_t crc, const uint8_t *data, size_t len) {
    for (size_t i = 0; i < len; ++i) {
        crc = crc_step_nibble(crc, (unsigned)data[i] >> 4);
        crc = crc_step_nibble(crc, data[i]);
    }
    return crc;
}
