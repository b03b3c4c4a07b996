/*
 * STM32L4 embedded flash interface registers (RM0351 Rev 9, §3.7 "FLASH registers";
 * base 0x4002 2000, §2.2.2 memory map). Offsets from the block's base; bits named as in
 * the reference manual. Only what the record driver (stm32_flash.c) uses.
 */
#ifndef BOARDS_STM32_FLASH_REGS_H
#define BOARDS_STM32_FLASH_REGS_H

#define STM32L4_FLASH_REGS 0x40022000u /* RM0351 §2.2.2, Table 1: FLASH registers */

#define STM32_FLASH_ACR  0x00u /* §3.7.1 access control */
#define STM32_FLASH_KEYR 0x08u /* §3.7.3 key */
#define STM32_FLASH_SR   0x10u /* §3.7.5 status */
#define STM32_FLASH_CR   0x14u /* §3.7.6 control */
#define STM32_FLASH_ECCR 0x18u /* §3.7.7 ECC */

/* KEYR: the two keys, in this order, unlock CR (§3.3.5 "Unlocking the Flash memory"); any
 * other write locks it until the next reset (and raises a bus error). */
#define STM32_FLASH_KEY1 0x45670123u
#define STM32_FLASH_KEY2 0xCDEF89ABu

/* ACR: the ART accelerator's data cache, reset after an erase or program so no read sees
 * the old content (§3.3.4: DCRST only while DCEN = 0). */
#define STM32_FLASH_ACR_DCEN  (1u << 10)
#define STM32_FLASH_ACR_DCRST (1u << 12)

/* SR: write 1 to clear the flags (§3.7.5). */
#define STM32_FLASH_SR_EOP     (1u << 0)
#define STM32_FLASH_SR_OPERR   (1u << 1)
#define STM32_FLASH_SR_PROGERR (1u << 3) /* programming a double-word that is not erased */
#define STM32_FLASH_SR_WRPERR  (1u << 4)
#define STM32_FLASH_SR_PGAERR  (1u << 5) /* alignment: not a double-word in one row */
#define STM32_FLASH_SR_SIZERR  (1u << 6) /* a write that is not a 32-bit word */
#define STM32_FLASH_SR_PGSERR  (1u << 7) /* sequence: PG/PER/STRT out of order */
#define STM32_FLASH_SR_MISERR  (1u << 8)
#define STM32_FLASH_SR_FASTERR (1u << 9)
#define STM32_FLASH_SR_RDERR   (1u << 14)
#define STM32_FLASH_SR_OPTVERR (1u << 15)
#define STM32_FLASH_SR_BSY     (1u << 16)
#define STM32_FLASH_SR_ERRORS                                                                      \
    (STM32_FLASH_SR_OPERR | STM32_FLASH_SR_PROGERR | STM32_FLASH_SR_WRPERR |                       \
     STM32_FLASH_SR_PGAERR | STM32_FLASH_SR_SIZERR | STM32_FLASH_SR_PGSERR |                       \
     STM32_FLASH_SR_MISERR | STM32_FLASH_SR_FASTERR | STM32_FLASH_SR_RDERR |                       \
     STM32_FLASH_SR_OPTVERR)

/* CR (§3.7.6). */
#define STM32_FLASH_CR_PG        (1u << 0)
#define STM32_FLASH_CR_PER       (1u << 1)
#define STM32_FLASH_CR_PNB_SHIFT 3u /* PNB[7:0]: page in its bank, bits 10:3 */
#define STM32_FLASH_CR_PNB_MASK  (0xFFu << 3)
#define STM32_FLASH_CR_BKER      (1u << 11) /* the page is in bank 2 */
#define STM32_FLASH_CR_STRT      (1u << 16)
#define STM32_FLASH_CR_LOCK      (1u << 31)

/* ECCR (§3.7.7): ECCD (two bits wrong: not correctable, also raises an NMI, §3.3.2) and
 * ECCC are cleared by writing 1; ADDR_ECC is the double-word's offset in its bank. */
#define STM32_FLASH_ECCR_ADDR_MASK 0x7FFFFu
#define STM32_FLASH_ECCR_BK_ECC    (1u << 19)
#define STM32_FLASH_ECCR_ECCC      (1u << 30)
#define STM32_FLASH_ECCR_ECCD      (1u << 31)

#endif /* BOARDS_STM32_FLASH_REGS_H */
