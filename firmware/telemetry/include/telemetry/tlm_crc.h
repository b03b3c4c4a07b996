/*
 * CRC-16/CCITT-FALSE, the checksum of every telemetry frame.
 *
 * Parameters (Greg Cook's "Catalogue of parametrised CRC algorithms", entry
 * CRC-16/IBM-3740, alias CRC-16/CCITT-FALSE): width 16, polynomial 0x1021,
 * initial value 0xFFFF, input and output not reflected, no final XOR, check
 * value 0x29B1 for the ASCII bytes "123456789". "CCITT" alone is ambiguous
 * (KERMIT, XMODEM and AUG-CCITT share the polynomial but not the rest), so the
 * protocol names the variant exactly.
 */
#ifndef TELEMETRY_TLM_CRC_H
#define TELEMETRY_TLM_CRC_H

#include <stddef.h>
#include <stdint.h>

/* Initial register value of CRC-16/CCITT-FALSE. */
#define TLM_CRC_INIT 0xFFFFu

/* Check value: tlm_crc16(TLM_CRC_INIT, "123456789", 9) == TLM_CRC_CHECK. */
#define TLM_CRC_CHECK 0x29B1u

/*
 * Continue a CRC-16/CCITT-FALSE over `len` bytes at `data` from register value
 * `crc` (TLM_CRC_INIT to start); returns the new register value, which is the
 * CRC once all bytes are in. `data` may be NULL only when `len` is 0.
 */
uint16_t tlm_crc16(uint16_t crc, const uint8_t *data, size_t len);

#endif /* TELEMETRY_TLM_CRC_H */
