/* hal_records on the STM32L4's embedded flash: page erase, double-word programming, ECC on read
 * (stm32_flash.h). */
#include "stm32_flash.h"

#include <stddef.h>

#include "hal/hal_err.h"
#include "stm32_flash_regs.h"
#include "stm32_reg.h"

/* ECC double errors the NMI handler took (stm32_flash_nmi): a read compares the count. And
 * those a read found in ECCR before its NMI was taken (an NMI is taken after the load that
 * raised it, maybe after the driver's ECCR read): the NMI that follows is theirs. */
static volatile uint32_t ecc_nmis;
static volatile uint32_t ecc_seen_by_read, ecc_nmis_owed_taken;

int stm32_flash_init(struct stm32_flash *flash, const struct stm32_flash_config *cfg) {
    if (flash == NULL || cfg == NULL || cfg->pages == 0u ||
        (uint32_t)cfg->first_page + cfg->pages > STM32_FLASH_BANK_PAGES ||
        cfg->erase_budget_us == 0u || cfg->program_budget_us == 0u || cfg->time.ops == NULL ||
        cfg->time.ops->now_us == NULL) {
        return HAL_ERR_INVALID;
    }
    *flash = (struct stm32_flash){.cfg = cfg};
    return HAL_OK;
}

/* Wait until SR.BSY is clear, at most `budget_us` (and as many polls plus one, a backstop
 * for a stopped clock). */
static bool wait_not_busy(const struct stm32_flash_config *cfg, uint32_t budget_us) {
    const uint32_t start = cfg->time.ops->now_us(cfg->time.ctx);
    for (uint32_t polls = 0; polls <= budget_us; ++polls) {
        if ((stm32_reg_read(cfg->regs + STM32_FLASH_SR) & STM32_FLASH_SR_BSY) == 0u) {
            return true;
        }
        if (hal_time_elapsed_us(cfg->time.ops->now_us(cfg->time.ctx), start) > budget_us) {
            break;
        }
    }
    return false;
}

/* Steps 1-2 of both sequences (RM0351 §3.3.6, §3.3.7): no operation going on, the error
 * flags of an earlier one cleared; then CR unlocked (§3.3.5). */
static int begin(struct stm32_flash *flash) {
    const struct stm32_flash_config *cfg = flash->cfg;
    if (!wait_not_busy(cfg, cfg->erase_budget_us)) {
        return HAL_ERR_TIMEOUT;
    }
    stm32_reg_write(cfg->regs + STM32_FLASH_SR, STM32_FLASH_SR_ERRORS | STM32_FLASH_SR_EOP);
    if ((stm32_reg_read(cfg->regs + STM32_FLASH_CR) & STM32_FLASH_CR_LOCK) != 0u) {
        stm32_reg_write(cfg->regs + STM32_FLASH_KEYR, STM32_FLASH_KEY1);
        stm32_reg_write(cfg->regs + STM32_FLASH_KEYR, STM32_FLASH_KEY2);
    }
    if ((stm32_reg_read(cfg->regs + STM32_FLASH_CR) & STM32_FLASH_CR_LOCK) != 0u) {
        return HAL_ERR_DEVICE; /* locked until reset: a wrong key sequence happened before */
    }
    return HAL_OK;
}

/* After an operation (or a failed wait): take its error flags (cleared, kept in
 * last_sr_errors), end PG/PER, lock CR again and reset the data cache so reads see the new
 * content. `rc` is the operation's result so far. */
static int finish(struct stm32_flash *flash, int rc) {
    const struct stm32_flash_config *cfg = flash->cfg;
    const uint32_t errors = stm32_reg_read(cfg->regs + STM32_FLASH_SR) & STM32_FLASH_SR_ERRORS;
    stm32_reg_write(cfg->regs + STM32_FLASH_SR, errors | STM32_FLASH_SR_EOP);
    if (rc != HAL_ERR_TIMEOUT) { /* CR may not be written while BSY (PGSERR) */
        stm32_reg_modify(cfg->regs + STM32_FLASH_CR,
                         STM32_FLASH_CR_PG | STM32_FLASH_CR_PER | STM32_FLASH_CR_PNB_MASK |
                             STM32_FLASH_CR_BKER,
                         0u);
        stm32_reg_modify(cfg->regs + STM32_FLASH_CR, 0u, STM32_FLASH_CR_LOCK);
    }
    const uint32_t acr = stm32_reg_read(cfg->regs + STM32_FLASH_ACR);
    stm32_reg_write(cfg->regs + STM32_FLASH_ACR, acr & ~STM32_FLASH_ACR_DCEN);
    stm32_reg_write(cfg->regs + STM32_FLASH_ACR,
                    (acr & ~STM32_FLASH_ACR_DCEN) | STM32_FLASH_ACR_DCRST);
    stm32_reg_write(cfg->regs + STM32_FLASH_ACR, acr & ~STM32_FLASH_ACR_DCRST);
    if (errors != 0u) {
        flash->last_sr_errors = errors;
        return rc == HAL_OK ? HAL_ERR_DEVICE : rc;
    }
    return rc;
}

static bool in_range(const struct stm32_flash *flash, uint16_t page, uint32_t offset, size_t len) {
    return flash != NULL && flash->cfg != NULL && page < flash->cfg->pages &&
           offset <= STM32_FLASH_PAGE_SIZE && len <= STM32_FLASH_PAGE_SIZE - offset;
}

/* §3.3.6 "Page erase" up to STRT: PER, the page (PNB) and its bank (BKER), then STRT. The
 * records' bank is not the one the code runs from, so the core goes on meanwhile (§3.3.8
 * read-while-write). */
static int flash_erase_start(void *ctx, uint16_t page) {
    struct stm32_flash *flash = ctx;
    if (!in_range(flash, page, 0u, 0u) || flash->erasing) {
        return HAL_ERR_INVALID;
    }
    const struct stm32_flash_config *cfg = flash->cfg;
    const int rc = begin(flash);
    if (rc != HAL_OK) {
        return rc;
    }
    const uint32_t pnb = (uint32_t)(cfg->first_page + page) << STM32_FLASH_CR_PNB_SHIFT;
    stm32_reg_modify(cfg->regs + STM32_FLASH_CR,
                     STM32_FLASH_CR_PNB_MASK | STM32_FLASH_CR_BKER | STM32_FLASH_CR_PG,
                     STM32_FLASH_CR_PER | pnb | (cfg->bank2 ? STM32_FLASH_CR_BKER : 0u));
    stm32_reg_modify(cfg->regs + STM32_FLASH_CR, 0u, STM32_FLASH_CR_STRT);
    flash->erasing = true;
    flash->erase_start_us = cfg->time.ops->now_us(cfg->time.ctx);
    return HAL_OK;
}

/* The started erase: BSY still set (within its budget), or its end: error flags, PER
 * cleared, CR locked (finish). */
static int flash_erase_poll(void *ctx) {
    struct stm32_flash *flash = ctx;
    if (flash == NULL || !flash->erasing) {
        return HAL_OK;
    }
    const struct stm32_flash_config *cfg = flash->cfg;
    if ((stm32_reg_read(cfg->regs + STM32_FLASH_SR) & STM32_FLASH_SR_BSY) != 0u) {
        const uint32_t now = cfg->time.ops->now_us(cfg->time.ctx);
        if (hal_time_elapsed_us(now, flash->erase_start_us) <= cfg->erase_budget_us) {
            return HAL_ERR_NOT_READY;
        }
        flash->erasing = false;
        return finish(flash, HAL_ERR_TIMEOUT);
    }
    flash->erasing = false;
    return finish(flash, HAL_OK);
}

static int flash_program(void *ctx, uint16_t page, uint32_t offset, const uint8_t *data,
                         size_t len) {
    struct stm32_flash *flash = ctx;
    if (!in_range(flash, page, offset, len) || offset % 8u != 0u || len % 8u != 0u ||
        (len > 0u && data == NULL)) {
        return HAL_ERR_INVALID; /* PGAERR / SIZERR on the part: refused before it */
    }
    const struct stm32_flash_config *cfg = flash->cfg;
    int rc = begin(flash);
    if (rc != HAL_OK) {
        return rc;
    }
    /* §3.3.7 "Normal programming": PG, then the two words of an aligned double-word, the
     * first at the lower address; BSY, then EOP or an error flag, per double-word. */
    stm32_reg_modify(cfg->regs + STM32_FLASH_CR, STM32_FLASH_CR_PER, STM32_FLASH_CR_PG);
    const uintptr_t at = cfg->memory + (uintptr_t)page * STM32_FLASH_PAGE_SIZE + offset;
    for (size_t i = 0; i < len && rc == HAL_OK; i += 8u) {
        for (size_t w = 0; w < 8u; w += 4u) {
            const uint8_t *b = &data[i + w];
            stm32_reg_write(at + i + w, (uint32_t)b[0] | (uint32_t)b[1] << 8 |
                                            (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24);
        }
        if (!wait_not_busy(cfg, cfg->program_budget_us)) {
            rc = HAL_ERR_TIMEOUT;
        } else if ((stm32_reg_read(cfg->regs + STM32_FLASH_SR) & STM32_FLASH_SR_ERRORS) != 0u) {
            rc = HAL_ERR_DEVICE; /* PROGERR: the double-word was not erased, ... */
        }
    }
    return finish(flash, rc);
}

static int flash_read(void *ctx, uint16_t page, uint32_t offset, uint8_t *out, size_t len) {
    struct stm32_flash *flash = ctx;
    if (!in_range(flash, page, offset, len) || (len > 0u && out == NULL)) {
        return HAL_ERR_INVALID;
    }
    const struct stm32_flash_config *cfg = flash->cfg;
    const uint32_t nmis_before = ecc_nmis;
    stm32_reg_write(cfg->regs + STM32_FLASH_ECCR, STM32_FLASH_ECCR_ECCD | STM32_FLASH_ECCR_ECCC);
    const uintptr_t base = cfg->memory + (uintptr_t)page * STM32_FLASH_PAGE_SIZE;
    for (size_t i = 0; i < len;) {
        const uint32_t pos = offset + (uint32_t)i;
        const uint32_t word = stm32_reg_read(base + (pos & ~3u)); /* aligned 32-bit reads */
        for (uint32_t k = pos & 3u; k < 4u && i < len; ++k, ++i) {
            out[i] = (uint8_t)(word >> (8u * k));
        }
    }
    const uint32_t eccr = stm32_reg_read(cfg->regs + STM32_FLASH_ECCR);
    if ((eccr & STM32_FLASH_ECCR_ECCD) != 0u || ecc_nmis != nmis_before) {
        stm32_reg_write(cfg->regs + STM32_FLASH_ECCR, STM32_FLASH_ECCR_ECCD);
        if ((eccr & STM32_FLASH_ECCR_ECCD) != 0u) {
            ecc_seen_by_read = ecc_seen_by_read + 1u;
        }
        ++flash->ecc_errors;
        return HAL_ERR_CORRUPT;
    }
    return HAL_OK;
}

bool stm32_flash_nmi(uintptr_t regs) {
    if ((stm32_reg_read(regs + STM32_FLASH_ECCR) & STM32_FLASH_ECCR_ECCD) != 0u) {
        stm32_reg_write(regs + STM32_FLASH_ECCR, STM32_FLASH_ECCR_ECCD);
        ecc_nmis = ecc_nmis + 1u;
        return true;
    }
    if (ecc_nmis_owed_taken != ecc_seen_by_read) { /* a read already reported this one */
        ecc_nmis_owed_taken = ecc_nmis_owed_taken + 1u;
        return true;
    }
    return false;
}

const struct hal_records_ops stm32_flash_ops = {.read = flash_read,
                                                .erase = NULL, /* erase_start + poll */
                                                .program = flash_program,
                                                .erase_start = flash_erase_start,
                                                .erase_poll = flash_erase_poll};

struct hal_records stm32_flash_hal(struct stm32_flash *flash) {
    const struct hal_records rec = {
        .ops = &stm32_flash_ops,
        .ctx = flash,
        .geometry = {.page_size = STM32_FLASH_PAGE_SIZE,
                     .page_count = flash->cfg != NULL ? flash->cfg->pages : 0u,
                     .program_granule = 8u,
                     .erased_byte = 0xFFu},
    };
    return rec;
}
