/* The simulated record storage with STM32L4 flash rules and power-cut injection (sim/sim_flash.h).
 */
#include "sim/sim_flash.h"

#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"

int sim_flash_init(struct sim_flash *flash, uint16_t pages, uint32_t page_size) {
    if (pages == 0u || pages > SIM_FLASH_PAGES_MAX || page_size == 0u ||
        page_size > SIM_FLASH_PAGE_MAX || page_size % SIM_FLASH_GRANULE != 0u) {
        return HAL_ERR_INVALID;
    }
    memset(flash, 0, sizeof *flash);
    memset(flash->mem, 0xFF, sizeof flash->mem);
    flash->pages = pages;
    flash->page_size = page_size;
    flash->cut_after = SIM_FLASH_NO_CUT;
    flash->powered = true;
    return HAL_OK;
}

void sim_flash_cut_after(struct sim_flash *flash, uint32_t ops, bool torn) {
    flash->cut_after = ops == SIM_FLASH_NO_CUT ? ops : flash->ops + ops;
    flash->torn = torn;
}

void sim_flash_power_on(struct sim_flash *flash) {
    flash->cut_after = SIM_FLASH_NO_CUT;
    flash->torn = false;
    flash->powered = true;
}

void sim_flash_poke(struct sim_flash *flash, uint16_t page, uint32_t offset, uint8_t xor_mask) {
    if (page < flash->pages && offset < flash->page_size) {
        flash->mem[page][offset] ^= xor_mask;
    }
}

/* What happens to the next operation: 1 apply it, 0 drop it (no power), -1 tear it. */
static int next_op(struct sim_flash *flash) {
    if (!flash->powered) {
        return 0;
    }
    const uint32_t n = flash->ops++;
    if (flash->cut_after != SIM_FLASH_NO_CUT && n >= flash->cut_after) {
        flash->powered = false;
        return flash->torn ? -1 : 0;
    }
    return 1;
}

static void set_ecc_bad(struct sim_flash *flash, uint16_t page, uint32_t dword, bool bad) {
    const uint8_t bit = (uint8_t)(1u << (dword % 8u));
    if (bad) {
        flash->ecc_bad[page][dword / 8u] |= bit;
    } else {
        flash->ecc_bad[page][dword / 8u] &= (uint8_t)~bit;
    }
}

static bool ecc_bad(const struct sim_flash *flash, uint16_t page, uint32_t dword) {
    return (flash->ecc_bad[page][dword / 8u] & (1u << (dword % 8u))) != 0u;
}

static bool in_page(const struct sim_flash *flash, uint16_t page, uint32_t offset, size_t len) {
    return page < flash->pages && offset <= flash->page_size &&
           len <= (size_t)(flash->page_size - offset);
}

static int flash_read(void *ctx, uint16_t page, uint32_t offset, uint8_t *out, size_t len) {
    struct sim_flash *flash = ctx;
    if (!in_page(flash, page, offset, len)) {
        return HAL_ERR_INVALID;
    }
    memcpy(out, &flash->mem[page][offset], len);
    int rc = HAL_OK;
    for (size_t i = 0; i < len; i += SIM_FLASH_GRANULE - (offset + i) % SIM_FLASH_GRANULE) {
        if (ecc_bad(flash, page, (uint32_t)(offset + i) / SIM_FLASH_GRANULE)) {
            rc = HAL_ERR_CORRUPT; /* ECCD: the whole read is reported, as the driver does */
        }
    }
    return rc;
}

static int flash_erase(void *ctx, uint16_t page) {
    struct sim_flash *flash = ctx;
    if (page >= flash->pages) {
        return HAL_ERR_INVALID;
    }
    const int op = next_op(flash);
    if (op == 0) {
        return HAL_OK; /* no power: the caller is not running any more either */
    }
    /* A torn erase clears the first half only (the model's worst case, sim_flash.h). */
    const uint32_t n = op > 0 ? flash->page_size : flash->page_size / 2u;
    memset(flash->mem[page], 0xFF, n);
    for (uint32_t d = 0; d < n / SIM_FLASH_GRANULE; ++d) {
        set_ecc_bad(flash, page, d, false);
    }
    ++flash->erases;
    return HAL_OK;
}

static bool dword_erased(const struct sim_flash *flash, uint16_t page, uint32_t offset) {
    for (uint32_t k = 0; k < SIM_FLASH_GRANULE; ++k) {
        if (flash->mem[page][offset + k] != 0xFFu) {
            return false;
        }
    }
    return !ecc_bad(flash, page, offset / SIM_FLASH_GRANULE);
}

static int flash_program(void *ctx, uint16_t page, uint32_t offset, const uint8_t *data,
                         size_t len) {
    struct sim_flash *flash = ctx;
    if (!in_page(flash, page, offset, len) || offset % SIM_FLASH_GRANULE != 0u ||
        len % SIM_FLASH_GRANULE != 0u) {
        ++flash->refusals; /* PGAERR / SIZERR on the part */
        return HAL_ERR_INVALID;
    }
    for (size_t i = 0; i < len; i += SIM_FLASH_GRANULE) {
        const uint32_t at = offset + (uint32_t)i;
        if (flash->powered && !dword_erased(flash, page, at)) {
            ++flash->refusals; /* PROGERR: the double-word was not erased */
            return HAL_ERR_DEVICE;
        }
        const int op = next_op(flash);
        if (op == 0) {
            continue;
        }
        /* Torn: the first word lands, the double-word's ECC does not match it. */
        memcpy(&flash->mem[page][at], &data[i], op > 0 ? SIM_FLASH_GRANULE : 4u);
        set_ecc_bad(flash, page, at / SIM_FLASH_GRANULE, op < 0);
        ++flash->programs;
    }
    return HAL_OK;
}

const struct hal_records_ops sim_flash_ops = {
    .read = flash_read, .erase = flash_erase, .program = flash_program};

struct hal_records sim_flash_hal(struct sim_flash *flash) {
    const struct hal_records rec = {
        .ops = &sim_flash_ops,
        .ctx = flash,
        .geometry = {.page_size = flash->page_size,
                     .page_count = flash->pages,
                     .program_granule = (uint8_t)SIM_FLASH_GRANULE,
                     .erased_byte = 0xFFu},
    };
    return rec;
}
