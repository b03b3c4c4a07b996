/* Register-level fake of the STM32L4 flash interface for the record driver's tests
 * (fake_stm32_flash.h). */
#include "fake_stm32_flash.h"

#include <string.h>

#include "stm32_flash_regs.h"

struct fake_flash fake_flash;

#define R_ACR  (STM32_FLASH_ACR / 4u)
#define R_KEYR (STM32_FLASH_KEYR / 4u)
#define R_SR   (STM32_FLASH_SR / 4u)
#define R_CR   (STM32_FLASH_CR / 4u)
#define R_ECCR (STM32_FLASH_ECCR / 4u)

void fake_flash_reset(uint16_t first_pnb, bool bank2) {
    memset(&fake_flash, 0, sizeof fake_flash);
    memset(fake_flash.mem, 0xFF, sizeof fake_flash.mem);
    fake_flash.regs[R_CR] = STM32_FLASH_CR_LOCK; /* reset value 0xC000 0000: LOCK, OPTLOCK */
    fake_flash.regs[R_ACR] = STM32_FLASH_ACR_DCEN;
    fake_flash.first_pnb = first_pnb;
    fake_flash.bank2 = bank2;
    fake_flash.busy_reads = 3u;
}

uintptr_t fake_flash_regs(void) {
    return (uintptr_t)fake_flash.regs;
}

uintptr_t fake_flash_memory(void) {
    return (uintptr_t)fake_flash.mem;
}

static void start_busy(void) {
    fake_flash.busy_left = fake_flash.busy_reads;
}

/* An operation ends: its error flags (the injected ones too) or EOP. */
static void end_op(uint32_t errors) {
    errors |= fake_flash.inject_sr;
    fake_flash.inject_sr = 0u;
    fake_flash.regs[R_SR] |= errors != 0u ? errors : STM32_FLASH_SR_EOP;
    start_busy();
}

static void violation(uint32_t sr_flag) {
    ++fake_flash.violations;
    fake_flash.regs[R_SR] |= sr_flag;
}

static void erase(uint32_t cr) {
    fake_flash.last_erase_cr = cr;
    const uint32_t pnb = (cr & STM32_FLASH_CR_PNB_MASK) >> STM32_FLASH_CR_PNB_SHIFT;
    const bool bker = (cr & STM32_FLASH_CR_BKER) != 0u;
    if ((cr & STM32_FLASH_CR_PG) != 0u) {
        violation(STM32_FLASH_SR_PGSERR); /* PG and PER together */
        return;
    }
    if (bker == fake_flash.bank2 && pnb >= fake_flash.first_pnb &&
        pnb < fake_flash.first_pnb + FAKE_FLASH_PAGES && fake_flash.inject_sr == 0u) {
        const uint32_t page = pnb - fake_flash.first_pnb;
        memset(fake_flash.mem[page], 0xFF, FAKE_FLASH_PAGE_SIZE);
        memset(fake_flash.ecc_bad[page], 0, sizeof fake_flash.ecc_bad[page]);
        ++fake_flash.erases;
    } else if (fake_flash.inject_sr == 0u) {
        ++fake_flash.violations; /* a page that is not a record page: code would be erased */
    }
    end_op(0u);
}

static void write_cr(uint32_t value) {
    if ((fake_flash.regs[R_CR] & STM32_FLASH_CR_LOCK) != 0u) {
        ++fake_flash.violations; /* CR written while locked: ignored (§3.7.6) */
        return;
    }
    if (fake_flash.busy_left > 0u) {
        violation(STM32_FLASH_SR_PGSERR); /* CR written during an operation */
        return;
    }
    fake_flash.regs[R_CR] = value & ~STM32_FLASH_CR_STRT;
    if ((value & STM32_FLASH_CR_STRT) != 0u) {
        if ((value & STM32_FLASH_CR_PER) == 0u) {
            violation(STM32_FLASH_SR_PGSERR);
        } else {
            erase(value);
        }
    }
}

static void write_keyr(uint32_t value) {
    if (fake_flash.key_step == 0u && value == STM32_FLASH_KEY1 && !fake_flash.locked_until_reset) {
        fake_flash.key_step = 1u;
        return;
    }
    if (fake_flash.key_step == 1u && value == STM32_FLASH_KEY2) {
        fake_flash.regs[R_CR] &= ~STM32_FLASH_CR_LOCK;
        ++fake_flash.unlocks;
    } else {
        fake_flash.locked_until_reset = true; /* a wrong key: locked until the next reset */
        ++fake_flash.violations;
    }
    fake_flash.key_step = 0u;
}

static void write_memory(uintptr_t addr, uint32_t value) {
    const uintptr_t off = addr - fake_flash_memory();
    if ((fake_flash.regs[R_CR] & STM32_FLASH_CR_PG) == 0u || fake_flash.busy_left > 0u) {
        violation(STM32_FLASH_SR_PGSERR);
        return;
    }
    if (!fake_flash.first_word_pending) {
        if (off % 8u != 0u) {
            violation(STM32_FLASH_SR_PGAERR);
            return;
        }
        fake_flash.first_word_pending = true;
        fake_flash.first_word = value;
        fake_flash.first_addr = addr;
        return;
    }
    fake_flash.first_word_pending = false;
    if (addr != fake_flash.first_addr + 4u) {
        violation(STM32_FLASH_SR_PGAERR);
        return;
    }
    uint8_t *dw = &fake_flash.mem[0][0] + (off - 4u);
    const size_t page = (off - 4u) / FAKE_FLASH_PAGE_SIZE,
                 d = ((off - 4u) % FAKE_FLASH_PAGE_SIZE) / 8u;
    bool erased = !fake_flash.ecc_bad[page][d];
    for (unsigned k = 0; k < 8u; ++k) {
        erased = erased && dw[k] == 0xFFu;
    }
    if (!erased) {
        end_op(STM32_FLASH_SR_PROGERR); /* RM0351 §3.3.7: only erased double-words */
        return;
    }
    if (fake_flash.inject_sr == 0u) {
        const uint32_t words[2] = {fake_flash.first_word, value};
        for (unsigned k = 0; k < 8u; ++k) {
            dw[k] = (uint8_t)(words[k / 4u] >> (8u * (k % 4u)));
        }
        ++fake_flash.programs;
    }
    end_op(0u);
}

bool fake_flash_write(uintptr_t addr, uint32_t value) {
    const uintptr_t regs = fake_flash_regs(), mem = fake_flash_memory();
    if (addr >= mem && addr < mem + sizeof fake_flash.mem) {
        write_memory(addr, value);
        return true;
    }
    if (addr < regs || addr >= regs + sizeof fake_flash.regs) {
        return false;
    }
    switch ((addr - regs) / 4u) {
    case R_KEYR:
        write_keyr(value);
        break;
    case R_SR:
        fake_flash.regs[R_SR] &= ~(value & (STM32_FLASH_SR_ERRORS | STM32_FLASH_SR_EOP));
        break;
    case R_CR:
        write_cr(value);
        break;
    case R_ECCR:
        fake_flash.regs[R_ECCR] &= ~(value & (STM32_FLASH_ECCR_ECCD | STM32_FLASH_ECCR_ECCC));
        break;
    case R_ACR:
        if ((value & STM32_FLASH_ACR_DCRST) != 0u && (value & STM32_FLASH_ACR_DCEN) == 0u) {
            fake_flash.dcache_reset = true;
        } else if ((value & STM32_FLASH_ACR_DCRST) != 0u) {
            ++fake_flash.violations; /* DCRST only while DCEN = 0 (§3.3.4) */
        }
        fake_flash.regs[R_ACR] = value;
        break;
    default:
        ++fake_flash.violations;
        break;
    }
    return true;
}

bool fake_flash_read(uintptr_t addr, uint32_t *value) {
    const uintptr_t regs = fake_flash_regs(), mem = fake_flash_memory();
    if (addr >= mem && addr < mem + sizeof fake_flash.mem) {
        const uintptr_t off = addr - mem;
        const uint8_t *p = &fake_flash.mem[0][0] + off;
        *value = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
        if (fake_flash.ecc_bad[off / FAKE_FLASH_PAGE_SIZE][(off % FAKE_FLASH_PAGE_SIZE) / 8u]) {
            fake_flash.regs[R_ECCR] |= STM32_FLASH_ECCR_ECCD | (uint32_t)(off & 0x7FFFFu);
        }
        return true;
    }
    if (addr < regs || addr >= regs + sizeof fake_flash.regs) {
        return false;
    }
    const uint32_t index = (uint32_t)((addr - regs) / 4u);
    if (index == R_SR) {
        uint32_t sr = fake_flash.regs[R_SR];
        if (fake_flash.busy_left > 0u) {
            sr |= STM32_FLASH_SR_BSY;
            if (fake_flash.busy_reads != UINT32_MAX) {
                --fake_flash.busy_left;
            }
        }
        *value = sr;
        return true;
    }
    *value = index == R_KEYR ? 0u : fake_flash.regs[index];
    return true;
}
