/*
 * Register-level fake of the STM32L4 flash interface (RM0351 §3) for the record driver's
 * host tests (stm32_flash.c compiled with STM32_REG_HOOKS): KEYR's unlock sequence (a wrong
 * key locks CR until reset), CR ignored while locked, page erase on PER + STRT, double-word
 * programming with PG (PROGERR on a double-word that is not erased, PGAERR on a second word
 * out of place, PGSERR on a write without PG), SR write-1-to-clear, BSY for a scripted
 * number of reads, ECCR.ECCD on a read of a double-word marked unreadable. Anything the
 * reference manual forbids is counted in `violations` as well as flagged as the part does.
 */
#ifndef TESTS_BOARDS_FAKE_STM32_FLASH_H
#define TESTS_BOARDS_FAKE_STM32_FLASH_H

#include <stdbool.h>
#include <stdint.h>

#define FAKE_FLASH_PAGES     2u
#define FAKE_FLASH_PAGE_SIZE 2048u

struct fake_flash {
    uint32_t regs[8]; /* ACR, PDKEYR, KEYR, OPTKEYR, SR, CR, ECCR, (0x1C) */
    uint8_t mem[FAKE_FLASH_PAGES][FAKE_FLASH_PAGE_SIZE];
    bool ecc_bad[FAKE_FLASH_PAGES][FAKE_FLASH_PAGE_SIZE / 8u];
    /* script */
    uint16_t first_pnb;  /* PNB of mem page 0 */
    bool bank2;          /* BKER the pages need */
    uint32_t busy_reads; /* SR reads that show BSY after an operation starts (UINT32_MAX: for
                            ever) */
    uint32_t inject_sr;  /* error flags the next operation raises (e.g. WRPERR) */
    /* state */
    unsigned key_step; /* 0: none, 1: KEY1 seen */
    bool locked_until_reset;
    uint32_t busy_left;
    bool first_word_pending;
    uint32_t first_word;
    uintptr_t first_addr;
    /* observations */
    uint32_t violations, erases, programs, unlocks;
    uint32_t last_erase_cr; /* CR at the last STRT */
    bool dcache_reset;      /* DCRST written with DCEN clear */
};

extern struct fake_flash fake_flash;

/* Locked, all erased, BSY for 3 reads per operation, no injection. */
void fake_flash_reset(uint16_t first_pnb, bool bank2);

/* Addresses for the driver's config. */
uintptr_t fake_flash_regs(void);
uintptr_t fake_flash_memory(void);

/* Dispatch (fake_stm32.c): true if `addr` is the flash fake's, with the value read. */
bool fake_flash_read(uintptr_t addr, uint32_t *value);
bool fake_flash_write(uintptr_t addr, uint32_t value);

#endif /* TESTS_BOARDS_FAKE_STM32_FLASH_H */
