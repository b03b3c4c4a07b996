/*
 * Simulated record storage: a hal_records implementation with the rules of the
 * STM32L4's flash (RM0351 §3.3.5-3.3.7): erase sets a page to 0xFF; only erased
 * double-words (8 bytes, aligned) may be programmed, whole; anything else is refused
 * as the part refuses it (PROGERR / PGAERR / SIZERR: HAL_ERR_DEVICE, nothing written).
 *
 * Power-cut injection: after `cut_after` erases and programs (counted over both, one
 * program op per double-word) the model stops applying them, as a part whose supply
 * is gone. The operation the cut falls in can be torn: an erase leaves the page's
 * first half erased and the rest as it was, a program leaves the double-word half
 * written and unreadable (an ECC double error, RM0351 §3.3.2: reads give
 * HAL_ERR_CORRUPT). That is this model's assumption of the worst an interrupted
 * operation leaves, not a figure of RM0351. Integer C, no heap: host_sim, QEMU, tests.
 */
#ifndef SIM_FLASH_H
#define SIM_FLASH_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_records.h"

#define SIM_FLASH_PAGES_MAX  4u
#define SIM_FLASH_PAGE_MAX   2048u /* STM32L4 page: 2 KB (RM0351 §3.3.1) */
#define SIM_FLASH_GRANULE    8u    /* a double-word (RM0351 §3.3.7) */
#define SIM_FLASH_NO_CUT     UINT32_MAX
#define SIM_FLASH_DWORDS_MAX (SIM_FLASH_PAGE_MAX / SIM_FLASH_GRANULE)

struct sim_flash {
    uint16_t pages;
    uint32_t page_size;
    uint8_t mem[SIM_FLASH_PAGES_MAX][SIM_FLASH_PAGE_MAX];
    /* double-words that read as an ECC double error (bit per double-word) */
    uint8_t ecc_bad[SIM_FLASH_PAGES_MAX][SIM_FLASH_DWORDS_MAX / 8u];
    /* power cut: operations (erases + double-word programs) applied before it */
    uint32_t cut_after;
    bool torn;    /* the operation the cut falls in is half done, not left out */
    uint32_t ops; /* erases + double-word programs attempted since init */
    bool powered; /* false once the cut happened: nothing more is applied */
    uint32_t erases, programs, refusals;
};

/* `pages` pages of `page_size` bytes (a multiple of 8, at most SIM_FLASH_PAGE_MAX), all
 * erased, no cut. HAL_ERR_INVALID for a size or count out of range. */
int sim_flash_init(struct sim_flash *flash, uint16_t pages, uint32_t page_size);

/* Cut the power after `ops` more erases / double-word programs (SIM_FLASH_NO_CUT: never);
 * `torn`: the next one after them is half applied. */
void sim_flash_cut_after(struct sim_flash *flash, uint32_t ops, bool torn);

/* Power back (a reboot): the memory as the cut left it, no cut pending. */
void sim_flash_power_on(struct sim_flash *flash);

/* Backdoor for tests: flip bits of one byte (no ECC check follows: the model keeps
 * data as written, as ECC-correctable flips would). Ignored out of range. */
void sim_flash_poke(struct sim_flash *flash, uint16_t page, uint32_t offset, uint8_t xor_mask);

/* hal_records over a sim_flash (ctx: the struct sim_flash *). */
extern const struct hal_records_ops sim_flash_ops;

/* The hal_records handle of `flash`. */
struct hal_records sim_flash_hal(struct sim_flash *flash);

#endif /* SIM_FLASH_H */
