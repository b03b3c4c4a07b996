/*
 * hal_records (hal/hal_records.h) on the STM32L4's embedded flash (RM0351 §3): pages of
 * 2 KB erased with PER/PNB/BKER/STRT, programmed a double-word at a time with PG, every
 * BSY wait bounded by a time budget, the error flags cleared before and reported after
 * each operation, and ECC double errors (ECCR.ECCD) reported on read.
 *
 * The record pages are `pages` consecutive pages from page `first_page` of bank 1 or 2;
 * the board's linker script reserves them so no code or data is ever placed there
 * (boards/nucleo-l476rg/stm32l476rg.ld). CR is unlocked for each operation and locked
 * again after it, so a stray write between operations cannot program anything.
 */
#ifndef BOARDS_STM32_FLASH_H
#define BOARDS_STM32_FLASH_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_records.h"
#include "hal/hal_time.h"

#define STM32_FLASH_PAGE_SIZE  2048u /* RM0351 §3.3.1: 2 KB pages, 256 per bank */
#define STM32_FLASH_BANK_PAGES 256u

struct stm32_flash_config {
    uintptr_t regs;             /* FLASH register block (STM32L4_FLASH_REGS) */
    uintptr_t memory;           /* address of record page 0 in the memory map */
    uint16_t first_page;        /* PNB of record page 0 in its bank */
    uint16_t pages;             /* record pages, consecutive */
    bool bank2;                 /* the pages are in bank 2 (CR.BKER) */
    uint32_t erase_budget_us;   /* longest BSY of a page erase */
    uint32_t program_budget_us; /* longest BSY of one double-word */
    struct hal_time time;
};

struct stm32_flash {
    const struct stm32_flash_config *cfg;
    uint32_t last_sr_errors; /* SR error bits of the last failed operation (0: none) */
    uint32_t ecc_errors;     /* uncorrectable ECC errors seen on read */
    bool erasing;            /* an erase_start()ed erase not yet polled to its end */
    uint32_t erase_start_us; /* when it started (its budget runs from there) */
};

/* Bind `flash` to `cfg`. HAL_ERR_INVALID when the pages leave their bank or a budget or the
 * time source is missing. Touches no register. */
int stm32_flash_init(struct stm32_flash *flash, const struct stm32_flash_config *cfg);

/* hal_records ops (ctx: the struct stm32_flash *). */
extern const struct hal_records_ops stm32_flash_ops;

/* The hal_records handle of `flash` (geometry: 2 KB pages, 8-byte granule, erased 0xFF). */
struct hal_records stm32_flash_hal(struct stm32_flash *flash);

/* For the board's NMI handler: true (and ECCD cleared, the next read reports it) when the
 * NMI was the flash's ECC double error, which a read of a torn double-word raises
 * (RM0351 §3.3.2); false for any other NMI. */
bool stm32_flash_nmi(uintptr_t regs);

#endif /* BOARDS_STM32_FLASH_H */
